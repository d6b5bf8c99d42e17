#!/usr/bin/env python3
"""The plane-sweep options of a CamVid run: runs filmed faster than 2 Hz (median frame interval under
0.5 s, from sequence.json's frame times: val, 15 Hz) read neighbours 4 m away (within 24 frames), so that
their dense depth is measured as the 1 Hz runs' is (docs/camvid.md, "Dense geometry").

usage: sweep_options.py SEQUENCE_DIR    prints the extract-features options (nothing for a slow run)
Used by benchmark.sh and cross_validate.py.
"""
import json
import os
import sys


def median_step(sequence):
    """The median time between a sequence's frames, seconds (None without frame times)."""
    with open(os.path.join(sequence, "sequence.json")) as f:
        times = [fr.get("time") for fr in json.load(f)["frames"]]
    steps = sorted(b - a for a, b in zip(times, times[1:]) if a is not None and b is not None)
    return steps[len(steps) // 2] if steps else None


def sweep_options(sequence):
    step = median_step(sequence)
    return ["--sweep-baseline", "4", "--sweep-reach", "24"] if step is not None and step < 0.5 else []


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: sweep_options.py SEQUENCE_DIR")
    print(" ".join(sweep_options(sys.argv[1])))
