#!/usr/bin/env python3
"""Is the accuracy gap to scikit-learn the split score? A small numpy extra-trees (the same rule as
libforest's grow_tree: every candidate column gets one threshold uniform in (min, max] over the node's
rows, best score splits, value < threshold goes left, leaf when pure / constant / fewer than n_min rows;
prediction = summed normalised leaf distributions) run with two scores on one corpus:
  wp: Wehenkel-Pavella 2 I(C;S) / (H(C) + H(S))   (ours, thesis)
  ig: information gain I(C;S)                       (scikit-learn criterion='entropy')
Usage: score_check.py TRAIN.csv HELDOUT.csv [--seeds 20] [-M 7] [--n-min 5]"""
import argparse
import sys

import numpy as np


def entropy_terms(counts):  # counts: (C, p) -> sum_k n_k log n_k per column
    c = counts.astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(c > 0, c * np.log(np.where(c > 0, c, 1)), 0.0).sum(axis=0)


def xlogx(v):
    v = np.asarray(v, dtype=np.float64)
    return np.where(v > 0, v * np.log(np.where(v > 0, v, 1)), 0.0)


def grow(X, Y1, y, n_min, rng, score):
    nodes = []  # (col, thr, left, right) or (None, dist)

    def build(idx):
        me = len(nodes)
        nodes.append(None)
        counts = np.bincount(y[idx], minlength=Y1.shape[1])
        m = len(idx)
        if (counts > 0).sum() <= 1 or m < n_min or m < 2:
            nodes[me] = (None, counts / m)
            return me
        Xn = X[idx]
        lo, hi = Xn.min(axis=0), Xn.max(axis=0)
        live = np.nonzero(lo < hi)[0]
        if live.size == 0:
            nodes[me] = (None, counts / m)
            return me
        lo64, hi64 = lo[live].astype(np.float64), hi[live].astype(np.float64)
        t = hi64 - rng.random(live.size) * (hi64 - lo64)
        t = np.where(t > lo64, t, hi64)
        mask = Xn[:, live] < t  # (m, L)
        left = Y1[idx].T.astype(np.float64) @ mask  # (C, L)
        right = counts[:, None] - left
        nl = left.sum(axis=0)
        nr = m - nl
        hc = xlogx(m) - xlogx(counts).sum()
        hs = xlogx(m) - xlogx(nl) - xlogx(nr)
        hcs = (xlogx(nl) - xlogx(left).sum(axis=0)) + (xlogx(nr) - xlogx(right).sum(axis=0))
        ig = hc - hcs
        sc = 2 * ig / (hc + hs) if score == "wp" else ig
        sc = np.where((nl > 0) & (nr > 0), sc, -1)
        j = int(np.argmax(sc))
        col, thr = int(live[j]), float(t[j])
        go_left = X[idx, col] < thr
        li = build(idx[go_left])
        ri = build(idx[~go_left])
        nodes[me] = (col, thr, li, ri)
        return me

    build(np.arange(len(y)))
    return nodes


def predict(trees, X, C):
    acc = np.zeros((X.shape[0], C))
    for nodes in trees:
        for i in range(X.shape[0]):
            n = nodes[0]
            while n[0] is not None:
                n = nodes[n[2] if X[i, n[0]] < n[1] else n[3]]
            acc[i] += n[1]
    return acc.argmax(axis=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("train")
    ap.add_argument("heldout")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("-M", type=int, default=7)
    ap.add_argument("--n-min", type=int, default=5)
    a = ap.parse_args()
    tr = np.loadtxt(a.train, delimiter=",", skiprows=1, dtype=np.float32, ndmin=2)
    he = np.loadtxt(a.heldout, delimiter=",", skiprows=1, dtype=np.float32, ndmin=2)
    X, y = tr[:, 1:], tr[:, 0].astype(int)
    Xh, yh = he[:, 1:], he[:, 0].astype(int)
    C = int(max(y.max(), yh.max())) + 1
    Y1 = np.eye(C, dtype=np.int64)[y]
    for score in ("wp", "ig"):
        accs = []
        for s in range(1, a.seeds + 1):
            rng = np.random.default_rng(s)
            trees = [grow(X, Y1, y, a.n_min, rng, score) for _ in range(a.M)]
            accs.append(float(np.mean(predict(trees, Xh, C) == yh)))
        print(f"{score}: mean accuracy {100 * np.mean(accs):.2f} (sd {100 * np.std(accs, ddof=1):.2f}) over {a.seeds} seeds")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
