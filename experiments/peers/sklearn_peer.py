#!/usr/bin/env python3
"""scikit-learn's ExtraTreesClassifier on an exported corpus (train-forest --export-corpus), the
peer of forest-peers: all candidate columns, one random threshold each (max_features=None),
entropy, min_samples_split=5, 7 trees, no bootstrap. Times the fit only, wall clock and process CPU (medians of --repeat fits),
then predicts the held-out rows (mean of the trees' normalised leaf distributions, argmax).
Memory (Linux): the peak RSS of the whole process (peak_rss_mb, reading the CSVs included) and of the
fits alone (fit_peak_rss_mb: the peak is reset to the current RSS, rss_before_fit_mb, just before each
fit by writing 5 to /proc/self/clear_refs, then read after it). MB = 2^20 bytes."""
import argparse
import json
import os
import statistics
import sys
import time


def fail(msg):
    print(f"sklearn_peer: error: {msg}", file=sys.stderr)
    sys.exit(1)


def rss_status():
    """(VmHWM, VmRSS) of this process in kB, or None where /proc is missing."""
    try:
        with open("/proc/self/status") as f:
            text = f.read()
    except OSError:
        return None
    vals = {}
    for line in text.splitlines():
        if line.startswith(("VmHWM:", "VmRSS:")):
            vals[line[:5]] = int(line.split()[1])
    return (vals["VmHWM"], vals["VmRSS"]) if len(vals) == 2 else None


def reset_peak():
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def read_corpus(path, np):
    try:
        with open(path) as f:
            header = f.readline().rstrip("\r\n")
    except OSError as e:
        fail(f"{path}: cannot be read: {e.strerror}")
    if not header.startswith("label,"):
        fail(f"{path}: header: expected 'label,<candidate names>'")
    try:
        data = np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.float32, ndmin=2)
    except ValueError as e:
        fail(f"{path}: {e}")
    if data.shape[1] != header.count(",") + 1:
        fail(f"{path}: rows have {data.shape[1]} fields, header {header.count(',') + 1}")
    y = data[:, 0].astype(np.int64)
    # Column-major float32: the layout sklearn's splitter reads best (and ours: candidate-major).
    X = np.asfortranarray(data[:, 1:])
    return header, X, y


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("train")
    ap.add_argument("heldout")
    ap.add_argument("-M", "--trees", type=int, default=7)
    ap.add_argument("--min-samples-split", type=int, default=5)
    ap.add_argument("--seeds", default="1", help="comma-separated random_state values, one run each")
    ap.add_argument("--repeat", type=int, default=3, help="timed fits per seed (median reported)")
    ap.add_argument("--n-jobs", type=int, default=1, help="sklearn n_jobs (trees in parallel); -1 = all cores")
    ap.add_argument("-o", "--out", help="result JSON file")
    a = ap.parse_args()
    import numpy as np
    import sklearn
    from sklearn.ensemble import ExtraTreesClassifier

    h1, X, y = read_corpus(a.train, np)
    h2, Xh, yh = read_corpus(a.heldout, np)
    if h1 != h2:
        fail(f"{a.heldout}: header differs from {a.train}'s: the corpora must share their columns")
    seeds = [int(s) for s in a.seeds.split(",") if s]
    runs = []
    peak_kb = 0  # peaks before each reset: the process peak is the largest of them and the last one
    fit_peaks, before_fit = [], []
    for seed in seeds:
        times, cpu_times = [], []
        for _ in range(a.repeat):
            clf = None  # the previous forest is freed before the next fit, as in forest-peers
            clf = ExtraTreesClassifier(n_estimators=a.trees, criterion="entropy", max_features=None,
                                       min_samples_split=a.min_samples_split, bootstrap=False,
                                       n_jobs=a.n_jobs, random_state=seed)
            st = rss_status()
            measured = st is not None and reset_peak()
            if measured:
                peak_kb = max(peak_kb, st[0])
                before_fit.append(rss_status()[1])
            t0, c0 = time.perf_counter(), time.process_time()
            clf.fit(X, y)
            cpu_times.append(time.process_time() - c0)
            times.append(time.perf_counter() - t0)
            if measured:
                fit_peaks.append(rss_status()[0])
        pred = clf.predict(Xh)
        acc = float(np.mean(pred == yh))
        per_class = [float(np.mean(pred[yh == k] == k)) for k in np.unique(yh)]
        nodes = int(sum(e.tree_.node_count for e in clf.estimators_))
        sec, cpu = statistics.median(times), statistics.median(cpu_times)
        runs.append({"seed": seed, "accuracy": acc, "class_average": float(np.mean(per_class)),
                     "seconds": sec, "seconds_all": times, "cpu_seconds": cpu, "cpu_seconds_all": cpu_times,
                     "nodes": nodes})
        print(f"seed {seed}: accuracy {acc:.4f}, fit {sec:.4f} s wall, {cpu:.4f} s CPU (medians of {a.repeat}), {nodes} nodes",
              flush=True)
    res = {"tool": f"scikit-learn {sklearn.__version__} ExtraTreesClassifier",
           "train": a.train, "heldout": a.heldout, "rows_train": int(X.shape[0]),
           "rows_heldout": int(Xh.shape[0]), "columns": int(X.shape[1]), "trees": a.trees,
           "min_samples_split": a.min_samples_split, "n_jobs": a.n_jobs, "repeat": a.repeat,
           "runs": runs, "mean_accuracy": statistics.mean(r["accuracy"] for r in runs),
           "median_seconds": statistics.median(r["seconds"] for r in runs),
           "median_cpu_seconds": statistics.median(r["cpu_seconds"] for r in runs)}
    st = rss_status()
    if st is not None and fit_peaks:
        mb = lambda kb: round(kb / 1024.0, 1)
        res.update({"peak_rss_mb": mb(max(peak_kb, st[0])), "fit_peak_rss_mb": mb(max(fit_peaks)),
                    "rss_before_fit_mb": mb(max(before_fit)),
                    "rss_method": "inside: /proc/self/status VmHWM, reset (clear_refs 5) before each fit"})
    else:
        import resource
        res.update({"peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1),
                    "fit_peak_rss_mb": None, "rss_before_fit_mb": None, "rss_method": "getrusage ru_maxrss"})
    print(f"mean accuracy {res['mean_accuracy']:.4f} over {len(runs)} seeds, median fit "
          f"{res['median_seconds']:.4f} s wall, {res['median_cpu_seconds']:.4f} s CPU; peak RSS "
          f"{res['peak_rss_mb']} MB (process), {res['fit_peak_rss_mb']} MB (fit)")
    if a.out:
        tmp = a.out + ".tmp"
        with open(tmp, "w") as f:
            json.dump(res, f, indent=1)
            f.write("\n")
        os.replace(tmp, a.out)


if __name__ == "__main__":
    main()
