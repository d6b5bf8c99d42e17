#!/usr/bin/env python3
"""Split a sequence into STEP interleaved sub-sequences (phases) of every STEP-th frame.

usage: subsample.py SEQUENCE_DIR STEP OUT_PREFIX

Writes OUT_PREFIX-pK/sequence.json for K = 0..STEP-1: frames K, K+STEP, K+2*STEP, ... of the input
(images referred to where they are, times and labels kept). Every frame of the input is in exactly one
phase, so extracting each phase and testing on all of them scores every frame once, with tracks made at
STEP times the input's frame spacing (CamVid val, 15 Hz, with STEP 15: the 1 Hz spacing of the train
runs).
"""
import json, os, sys

src, step, prefix = sys.argv[1], int(sys.argv[2]), sys.argv[3]
s = json.load(open(os.path.join(src, "sequence.json")))
frames = s["frames"]
if step < 1 or step > len(frames):
    sys.exit(f"subsample: {src}: STEP {step} outside 1..{len(frames)}")
labelled = set(s.get("labels", {}).get("labelled_frames", []))
for f in frames:
    for k in ("left", "right", "label"):
        if k in f and not os.path.isabs(f[k]):
            sys.exit(f"subsample: {src}: relative path {f[k]}")
for k in range(step):
    idx = list(range(k, len(frames), step))
    t = dict(s)
    t["frames"] = [frames[i] for i in idx]
    if "labels" in s:
        t["labels"] = dict(s["labels"])
        t["labels"]["labelled_frames"] = [j for j, i in enumerate(idx) if i in labelled]
    t["name"] = f"{s.get('name', os.path.basename(src))}-p{k}"
    t["extra"] = dict(s.get("extra", {}))
    t["extra"]["subsampled_from"] = {"sequence": os.path.abspath(src), "step": step, "frames": idx}
    out = f"{prefix}-p{k}"
    os.makedirs(out, exist_ok=True)
    json.dump(t, open(os.path.join(out, "sequence.json"), "w"), indent=1)
    print(f"{out}/sequence.json: {len(idx)} frames ({idx[0]}, {idx[0] + step}, ...)")
