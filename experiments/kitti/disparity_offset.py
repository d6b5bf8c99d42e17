#!/usr/bin/env python3
"""The disparity offset that best explains a stereo sequence's ground-truth motion.

Usage: disparity_offset.py SEQUENCE WORK
  SEQUENCE  a stereo sequence folder with ground-truth poses (import-kitti of a slice with poses.txt)
  WORK      its work folder from extract-features (WORK/tracks.json: tracks with pixels and disparities)

For every track seen in two consecutive frames, the ground-truth relative motion carries its first 3D
point (from pixel and disparity d1 + offset) into the second camera; the predicted disparity there,
minus the offset, should equal the measured d2. For a trial offset the script counts the pairs whose
predicted pixel lands within 3 px and takes the median of (predicted - measured) disparity; the offset
where that median crosses zero is printed, with the table. A correct calibration gives ~0. Put the value
into the sequence with `import-kitti --disparity-offset` (calibration.disparity_offset, docs/formats.md).
Needs numpy (Debian python3-numpy).
"""
import json
import sys

import numpy as np


def pose_matrix(p):
    m = np.eye(4)
    m[:3, :3] = np.array(p["R"]).reshape(3, 3)
    m[:3, 3] = p["t"]
    return m


def consecutive_pairs(tracks):
    for tr in tracks:
        f, x, y, d = tr["frames"], tr["x"], tr["y"], tr["d"]
        for k in range(len(f) - 1):
            if f[k + 1] == f[k] + 1:
                yield f[k], (x[k], y[k], d[k]), (x[k + 1], y[k + 1], d[k + 1])


def median_residual(pairs, motions, cal, offset):
    fx, fy, cx, cy, fb = cal["fx"], cal["fy"], cal["cx"], cal["cy"], cal["fx"] * cal["baseline"]
    res = []
    for f, (u, v, d1), (u2, v2, d2) in pairs:
        if d1 + offset <= 0.5:
            continue
        z = fb / (d1 + offset)
        q = motions[f] @ np.array([(u - cx) * z / fx, (v - cy) * z / fy, z, 1.0])
        if q[2] <= 0.5:
            continue
        if abs(fx * q[0] / q[2] + cx - u2) > 3 or abs(fy * q[1] / q[2] + cy - v2) > 3:
            continue
        res.append(fb / q[2] - offset - d2)
    return (float(np.median(res)) if res else float("nan")), len(res)


def main(argv):
    if len(argv) != 3:
        sys.exit(__doc__)
    seq = json.load(open(argv[1].rstrip("/") + "/sequence.json"))
    work = json.load(open(argv[2].rstrip("/") + "/tracks.json"))
    cal = seq["calibration"]
    if "ground_truth" not in seq:
        sys.exit(f"{argv[1]}: the sequence has no ground-truth poses")
    gt = [pose_matrix(p) for p in seq["ground_truth"]["poses"]]
    # Camera-to-world in our convention (y down, z forward inside the camera): frame f's camera
    # coordinates to frame f+1's.
    motions = {f: np.linalg.inv(gt[f + 1]) @ gt[f] for f in range(len(gt) - 1)}
    pairs = list(consecutive_pairs(work["tracks"]))
    print(f"{len(pairs)} consecutive observation pairs; calibration disparity_offset "
          f"{cal.get('disparity_offset', 0)} px (the tracks were made with it)")
    trials = np.arange(-3.0, 3.01, 0.25)  # on top of the offset the tracks were made with
    rows = [(t, *median_residual(pairs, motions, cal, t)) for t in trials]
    for t, med, n in rows:
        print(f"  extra offset {t:+.2f} px: median predicted - measured disparity {med:+.3f} px over {n} pairs")
    best = None
    for (t0, m0, _), (t1, m1, _) in zip(rows, rows[1:]):
        if np.isfinite(m0) and np.isfinite(m1) and (m0 <= 0 <= m1 or m0 >= 0 >= m1):
            best = t0 + (t1 - t0) * (0 - m0) / (m1 - m0) if m1 != m0 else t0
            break
    if best is None:
        print("no zero crossing in the range tried")
        return 1
    print(f"offset explaining the ground-truth motion: {best + cal.get('disparity_offset', 0):+.2f} px "
          f"(extra {best:+.2f} px over the calibration's)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
