#!/usr/bin/env python3
"""Attach the labels of a labelled work folder to a work folder extracted without labels.

usage: attach-labels.py UNLABELLED_WORK LABELLED_WORK OUT_WORK

extract-features drops tracks whose labels disagree between labelled frames (a training filter) on
every sequence it is given, so a test sequence extracted with its labels has had ground truth shape
its features. The test run is therefore extracted from a copy of its sequence.json without labels;
this script makes OUT_WORK = the unlabelled stacks (hard links) plus the labelled folder's
NNNNNN.labels.npy files (label images only, no features), and lists those frames as labelled in
OUT_WORK/stacks.json. Both folders must come from the same images (same sequence name, frames, size).
"""
import json, os, shutil, sys

unl, lab, out = sys.argv[1:4]
su = json.load(open(os.path.join(unl, "stacks.json")))
sl = json.load(open(os.path.join(lab, "stacks.json")))
for k in ("sequence_name", "frames", "image_size", "classes", "features"):
    if su[k] != sl[k]:
        sys.exit(f"attach-labels: {k} differs between {unl} and {lab}")
if su["labelled_frames"]:
    sys.exit(f"attach-labels: {unl} already has labelled frames")
if os.path.exists(out):
    sys.exit(f"attach-labels: {out} exists")
shutil.copytree(unl, out, copy_function=os.link)
for f in sl["labelled_frames"]:
    name = f"{f:06d}.labels.npy"
    shutil.copyfile(os.path.join(lab, "stacks", name), os.path.join(out, "stacks", name))
su["labelled_frames"] = sl["labelled_frames"]
su["labels_from"] = os.path.abspath(lab)
os.remove(os.path.join(out, "stacks.json"))  # a hard link: do not write through it
json.dump(su, open(os.path.join(out, "stacks.json"), "w"), indent=1)
print(f"{out}: {len(sl['labelled_frames'])} labelled frames from {lab}")
