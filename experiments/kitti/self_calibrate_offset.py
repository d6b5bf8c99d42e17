#!/usr/bin/env python3
"""The disparity offset a stereo sequence's own tracks ask for, without ground truth.

Usage: self_calibrate_offset.py SEQUENCE WORK
  SEQUENCE  a stereo sequence folder (sequence.json: calibration fx, fy, cx, cy, baseline)
  WORK      its work folder from extract-features (WORK/tracks.json: tracks with pixels and disparities)

A constant error in every disparity (a right image shifted against its calibration: docs/real-scale.md,
"KITTI front end") bends the 3D points by their depth (z = f b / d), and no rigid motion then carries
one frame's points onto the next frame's observations as well as it does with the right disparities.
So, for a trial offset added to every disparity, each consecutive pair of frames gets the rigid motion
that best reprojects its tracked points (pixel and disparity in the second frame; Gauss-Newton on a
Huber loss, from the previous trial's motion), and the trial scores the median reprojection error over
all pairs. The offset of least error (a parabola through the best trial and its neighbours, after a
coarse and a fine pass) is printed, on top of the offset the tracks were made with (tracks.json's
summary.disparity_offset_px, else the calibration's disparity_offset). Put the total into the
sequence with `import-kitti --disparity-offset`. The stereo front end does the same from its first
11 frames by default (`extract-features --disparity-offset auto`, docs/real-scale.md "KITTI front
end"); this script uses all of a work folder's pairs. Needs numpy (Debian python3-numpy). The last
line of the output is the estimate:
  disparity offset: +0.80 px (tracks made with +0.00, extra +0.80)
"""
import json
import sys

import numpy as np

MAX_POINTS = 300  # per frame pair: enough for six parameters, and the search stays fast


def consecutive_observations(tracks):
    """Per frame f: rows (u, v, d in f; u, v, d in f + 1) of the tracks seen in both."""
    rows = {}
    for tr in tracks:
        f, x, y, d = tr["frames"], tr["x"], tr["y"], tr["d"]
        for k in range(len(f) - 1):
            if f[k + 1] == f[k] + 1:
                rows.setdefault(f[k], []).append((x[k], y[k], d[k], x[k + 1], y[k + 1], d[k + 1]))
    out = {}
    for f, r in rows.items():
        a = np.array(r, dtype=float)
        if len(a) > MAX_POINTS:  # evenly spread, the same rows for every trial
            a = a[np.linspace(0, len(a) - 1, MAX_POINTS).astype(int)]
        out[f] = a
    return out


def rotation(w):
    th = np.linalg.norm(w)
    if th < 1e-12:
        return np.eye(3)
    k = w / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


def back_project(u, v, d, cal):
    z = cal["fx"] * cal["baseline"] / d
    return np.stack([(u - cal["cx"]) * z / cal["fx"], (v - cal["cy"]) * z / cal["fy"], z], 1)


def project(P, cal):
    z = P[:, 2]
    return np.stack([cal["fx"] * P[:, 0] / z + cal["cx"], cal["fy"] * P[:, 1] / z + cal["cy"],
                     cal["fx"] * cal["baseline"] / z], 1)


def fit_motion(P, seen, cal, R, t, iterations=6):
    """The rigid motion (R, t) reprojecting points P onto `seen` (u, v, d) best under a Huber loss
    (1 px), by Gauss-Newton from (R, t); returns it and each point's reprojection error."""
    def residual(R_, t_):
        return (project(P @ R_.T + t_, cal) - seen).ravel()

    for _ in range(iterations):
        r0 = residual(R, t)
        a = np.abs(r0)
        w = np.where(a < 1.0, 1.0, 1.0 / np.maximum(a, 1e-9))
        J = np.empty((r0.size, 6))
        for j in range(6):
            step = np.zeros(6)
            step[j] = 1e-6
            J[:, j] = (residual(rotation(step[:3]) @ R, t + step[3:]) - r0) / 1e-6
        dx = np.linalg.solve(J.T @ (J * w[:, None]) + 1e-9 * np.eye(6), -J.T @ (w * r0))
        R, t = rotation(dx[:3]) @ R, t + dx[3:]
        if np.linalg.norm(dx) < 1e-8:
            break
    return R, t, np.linalg.norm(project(P @ R.T + t, cal) - seen, axis=1)


def score(pairs, cal, extra, motions):
    """Median reprojection error (px) over every pair with `extra` px added to every disparity."""
    errors = []
    for f, a in pairs.items():
        d1, d2 = a[:, 2] + extra, a[:, 5] + extra
        ok = (d1 > 1) & (d2 > 1)
        if ok.sum() < 20:
            continue
        P = back_project(a[ok, 0], a[ok, 1], d1[ok], cal)
        seen = np.stack([a[ok, 3], a[ok, 4], d2[ok]], 1)
        R, t = motions.get(f, (np.eye(3), np.zeros(3)))
        R, t, e = fit_motion(P, seen, cal, R, t)
        motions[f] = (R, t)
        errors.append(e)
    return float(np.median(np.concatenate(errors))) if errors else float("nan")


def search(pairs, cal):
    """Coarse then fine trials; returns the table and the offset of least error."""
    motions = {}
    table = {}
    for extra in np.arange(-3.0, 3.01, 0.5):
        table[round(float(extra), 3)] = score(pairs, cal, extra, motions)
    best = min((e, x) for x, e in table.items() if np.isfinite(e))[1]
    for extra in np.arange(best - 0.375, best + 0.38, 0.125):
        key = round(float(extra), 3)
        if key not in table:
            table[key] = score(pairs, cal, extra, motions)
    xs = sorted(table)
    i = min(range(len(xs)), key=lambda k: table[xs[k]])
    if 0 < i < len(xs) - 1:  # the vertex of the parabola through the best trial and its neighbours
        (x0, x1, x2), (e0, e1, e2) = xs[i - 1:i + 2], (table[xs[i - 1]], table[xs[i]], table[xs[i + 1]])
        denom = (x0 - x1) * (x0 - x2) * (x1 - x2)
        a = (x2 * (e1 - e0) + x1 * (e0 - e2) + x0 * (e2 - e1)) / denom
        b = (x2 * x2 * (e0 - e1) + x1 * x1 * (e2 - e0) + x0 * x0 * (e1 - e2)) / denom
        return table, (-b / (2 * a) if a > 0 else x1)
    return table, xs[i]


def main(argv):
    if len(argv) != 3:
        sys.exit(__doc__)
    seq_file, tracks_file = argv[1].rstrip("/") + "/sequence.json", argv[2].rstrip("/") + "/tracks.json"
    try:
        cal = json.load(open(seq_file))["calibration"]
        if not all(isinstance(cal.get(k), (int, float)) for k in ("fx", "fy", "cx", "cy", "baseline")):
            raise ValueError("not a stereo calibration (fx, fy, cx, cy, baseline)")
    except (OSError, ValueError, KeyError, TypeError) as e:
        sys.exit(f"self_calibrate_offset.py: error: {seq_file}: {e}")
    try:
        doc = json.load(open(tracks_file))
        pairs = consecutive_observations(doc["tracks"])
        summary = doc.get("summary") if isinstance(doc.get("summary"), dict) else {}
        base = float(summary.get("disparity_offset_px", cal.get("disparity_offset", 0.0)))
    except (OSError, ValueError, KeyError, TypeError, IndexError) as e:
        sys.exit(f"self_calibrate_offset.py: error: {tracks_file}: not readable as tracks ({type(e).__name__}: {e})")
    if len(pairs) < 2:
        sys.exit(f"self_calibrate_offset.py: error: {argv[2]}/tracks.json: fewer than two frame pairs share tracks")
    table, extra = search(pairs, cal)
    for x in sorted(table):
        print(f"  extra {x:+.3f} px: median reprojection error {table[x]:.4f} px")
    print(f"disparity offset: {base + extra:+.2f} px (tracks made with {base:+.2f}, extra {extra:+.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
