#!/usr/bin/env python3
"""Copy a sequence folder's manifest without its labels (the images stay where they are).

usage: strip-labels.py SEQUENCE_DIR OUT_DIR

Writes OUT_DIR/sequence.json: the same frames (absolute image paths, as import-camvid writes them)
with no "label" and no labelled frames, so that extract-features sees no ground truth.
"""
import json, os, sys

src, out = sys.argv[1:3]
s = json.load(open(os.path.join(src, "sequence.json")))
for f in s["frames"]:
    for k in ("left", "right"):
        if k in f and not os.path.isabs(f[k]):
            sys.exit(f"strip-labels: {src}: relative image path {f[k]}")
    f.pop("label", None)
s["labels"]["labelled_frames"] = []
os.makedirs(out, exist_ok=True)
json.dump(s, open(os.path.join(out, "sequence.json"), "w"), indent=1)
print(f"{out}/sequence.json: {len(s['frames'])} frames, labels removed")
