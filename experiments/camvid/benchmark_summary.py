#!/usr/bin/env python3
"""Helpers of experiments/camvid/benchmark.sh.

  benchmark_summary.py measure RECORD.json -- COMMAND... [--then COMMAND...]
                                                          runs the commands one after the other (each
                                                          must succeed), writes their wall seconds and
                                                          peak resident set (MB) to RECORD.json
  benchmark_summary.py summary OUT --train S --test S --kt N --trees M [--cross-validation CV.json]
                                                          prints the table of OUT/eval/*/results.json
                                                          and writes OUT/summary.json; with a
                                                          cross_validate.py record, each run's fold
                                                          means at the run's own class prior power
                                                          beside its figures
"""
import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

RUNS = [  # (name in summary.json, eval folder, measured trainings (seconds add up, peak is the largest), title)
    ("sm", "sm", ["sm"], "S+M: six + dense geometry, sqrt balance, Potts smoothing"),
    ("combined", "combined", ["combined_m20"], "S+M + appearance + people detectors + HOG classes, M = 20, lightness, smoothing, prior-corrected"),
    ("sm_six", "sm_six", ["sm_six"], "S+M six point features"),
    ("sm_dense", "sm_dense", ["sm_dense"], "S+M six + dense geometry"),
    ("sm_path", "sm_path", ["sm_path"], "S+M as sm, + fZC distance to the camera path"),
    ("sm_context", "sm_context", ["sm_six", "sm_context"], "S+M six + auto-context"),
    ("combined_forest", "combined_forest", ["combined"], "S+M + appearance"),
    ("combined_smooth", "combined_smooth", ["combined"], "S+M + appearance + smoothing"),
    ("combined_context", "combined_context", ["combined", "combined_context"], "S+M + appearance + auto-context"),
    ("combined_context_smooth", "combined_context_smooth", ["combined", "combined_context"],
     "S+M + appearance + auto-context + smoothing"),
    ("combined_forest_m20", "combined_forest_m20", ["combined_m20"], "S+M + appearance + people detectors + HOG classes, M = 20, lightness"),
    ("combined_smooth_m20", "combined_smooth_m20", ["combined_m20"], "S+M + appearance + people detectors + HOG classes, M = 20, lightness, smoothing"),
]

def write_json_atomic(path, value):
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", dir=folder)
    with os.fdopen(fd, "w") as f:
        json.dump(value, f, indent=2)
        f.write("\n")
    os.replace(tmp, path)


def measure(record, commands):
    start = time.monotonic()
    for command in commands:
        code = subprocess.call(command)
        if code != 0:
            sys.exit(f"benchmark.sh: {command[0]} failed (exit {code})")
    seconds = time.monotonic() - start
    peak_kb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss  # Linux: kilobytes
    write_json_atomic(record, {"seconds": round(seconds, 1), "peak_rss_mb": round(peak_kb / 1024.0, 1)})


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"benchmark.sh: {path}: {e}")


def fold_means(path):
    """Each run's fold means and spreads per class prior power ("0", "0.5", ...) from a cross_validate.py
    record ({} without)."""
    if not path:
        return {}
    return load(path).get("summary", {})


def at_power(per_power, power):
    """The fold means of a run evaluated at `power` (--prior-power), or None when the record lacks it."""
    return per_power.get(f"{power:g}")


def print_fold_means(runs, folds, test):
    """The protocol's fold means beside the figures of this run's test split."""
    cell = lambda e, m: f"{100 * e[m]['mean']:.1f} ± {100 * e[m]['spread']:.1f}"
    print(f"Leave-one-run-out fold means ± spread (train and val runs, each held out at 1 Hz) beside {test}:")
    for name, run in runs.items():
        e = at_power(folds.get(name, {}), run["prior_power"])
        cv = (f"{cell(e, 'global')} / {cell(e, 'class_average')} / {cell(e, 'mean_iou')}" if e else "not cross-validated")
        print(f"  {name:17s} folds {cv:40s}  {test} {100 * run['global_accuracy']:.1f} / "
              f"{100 * run['class_average_accuracy']:.1f} / {100 * run['mean_iou']:.1f}")


def summary(out, train, test, kt, trees, cross_validation=None):
    runs, forest_kt = {}, {}
    for name, folder, trainings, title in RUNS:
        r = load(os.path.join(out, "eval", folder, "results.json"))
        tested = trainings[-1]  # the forest the run labels with (auto-context: the second one)
        if tested not in forest_kt:
            forest_kt[tested] = load(os.path.join(out, "forests", tested + ".json"))["params"]["Kt"]
        measured = [load(os.path.join(out, "measure", t + ".json")) for t in trainings]
        m = {"seconds": sum(x["seconds"] for x in measured), "peak_rss_mb": max(x["peak_rss_mb"] for x in measured)}
        runs[name] = {
            "title": title,
            "global_accuracy": r["global_accuracy"],
            "class_average_accuracy": r["class_average_accuracy"],
            "mean_iou": r["mean_iou"],
            "per_class": {c["class"]: {"accuracy": c["accuracy"], "iou": c["iou"]} for c in r["per_class"]},
            "train_seconds": m["seconds"],
            "train_peak_rss_mb": m["peak_rss_mb"],
            "eval_ms_per_frame": 1000.0 * r["seconds_per_frame"],
            "smooth_ms_per_frame": 1000.0 * r.get("smooth_seconds_per_frame", 0.0),
            "test_frames": len(r["per_frame"]),
            "trees": r["params"]["trees"],
            "kt": forest_kt[tested],
            "prior_power": r["params"].get("prior_power", 0.0),  # eval-forest records it when it is not 0
        }
    classes = list(runs["sm"]["per_class"].keys())
    pct = lambda v: f"{100.0 * v:5.1f}"
    head = ["run", "global", "class-avg", "mIoU"] + [c[:6] for c in classes] + ["train s", "peak MB"]
    rows = []
    for name, run in runs.items():
        rows.append([run["title"], pct(run["global_accuracy"]), pct(run["class_average_accuracy"]), pct(run["mean_iou"])]
                    + [pct(run["per_class"][c]["accuracy"]) for c in classes]
                    + [f"{run['train_seconds']:.0f}", f"{run['train_peak_rss_mb']:.0f}"])
    widths = [max(len(str(x[i])) for x in [head] + rows) for i in range(len(head))]
    # Runs whose forest is not the common one (the headline's: M = 20, Kt = 60 000).
    other = sorted({f"{name}: M = {run['trees']}, Kt = {run['kt']}" for name, run in runs.items()
                    if run["trees"] != trees or run["kt"] != kt})
    print(f"CamVid: trained on {train}, tested on {test} ({runs['sm']['test_frames']} frames), Kt = {kt}, M = {trees}"
          + (f" ({', '.join(other)})" if other else "") + "; accuracies in %, per-class columns are per-class accuracy")
    for row in [head] + rows:
        print("  ".join(str(v).rjust(w) if i else str(v).ljust(w) for i, (v, w) in enumerate(zip(row, widths))))
    folds = fold_means(cross_validation)
    if folds:
        print_fold_means(runs, folds, test)
        for name, run in runs.items():
            e = at_power(folds.get(name, {}), run["prior_power"])
            if e:
                run["fold_means"] = {m: e[m] for m in ("global", "class_average", "mean_iou")}
    write_json_atomic(os.path.join(out, "summary.json"),
                      {"format": "smseg-camvid-benchmark", "version": 1, "train": train.split(","), "test": test,
                       "Kt": kt, "M": trees, "runs": runs})
    print(f"summary: {os.path.join(out, 'summary.json')}")


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "measure":
        if len(sys.argv) < 5 or sys.argv[3] != "--":
            sys.exit("usage: benchmark_summary.py measure RECORD.json -- COMMAND... [--then COMMAND...]")
        commands = [[]]
        for arg in sys.argv[4:]:
            if arg == "--then":
                commands.append([])
            else:
                commands[-1].append(arg)
        if any(not c for c in commands):
            sys.exit("benchmark_summary.py measure: an empty command")
        measure(sys.argv[2], commands)
        return
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("summary")
    s.add_argument("out")
    s.add_argument("--train", required=True)
    s.add_argument("--test", required=True)
    s.add_argument("--kt", type=int, required=True)
    s.add_argument("--trees", type=int, required=True)
    s.add_argument("--cross-validation", help="a cross_validate.py record (cross-validation.json)")
    a = p.parse_args()
    summary(a.out, a.train, a.test, a.kt, a.trees, a.cross_validation)


if __name__ == "__main__":
    main()
