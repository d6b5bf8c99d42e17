#!/usr/bin/env python3
"""Helpers of experiments/camvid/benchmark.sh.

  benchmark_summary.py measure RECORD.json -- COMMAND... [--then COMMAND...]
                                                          runs the commands one after the other (each
                                                          must succeed), writes their wall seconds and
                                                          peak resident set (MB) to RECORD.json
  benchmark_summary.py summary OUT --train S --test S --kt N --trees M
                                                          prints the table of OUT/eval/*/results.json
                                                          and writes OUT/summary.json
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
    ("combined", "combined", ["combined", "combined_context"], "S+M + appearance + auto-context + smoothing"),
    ("sm_six", "sm_six", ["sm_six"], "S+M six point features"),
    ("sm_dense", "sm_dense", ["sm_dense"], "S+M six + dense geometry"),
    ("sm_path", "sm_path", ["sm_path"], "S+M as sm, + fZC distance to the camera path"),
    ("sm_context", "sm_context", ["sm_six", "sm_context"], "S+M six + auto-context"),
    ("combined_forest", "combined_forest", ["combined"], "S+M + appearance"),
    ("combined_smooth", "combined_smooth", ["combined"], "S+M + appearance + smoothing"),
    ("combined_context", "combined_context", ["combined", "combined_context"], "S+M + appearance + auto-context"),
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


def summary(out, train, test, kt, trees):
    runs = {}
    for name, folder, trainings, title in RUNS:
        r = load(os.path.join(out, "eval", folder, "results.json"))
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
    print(f"CamVid: trained on {train}, tested on {test} ({runs['sm']['test_frames']} frames), Kt = {kt}, M = {trees};"
          " accuracies in %, per-class columns are per-class accuracy")
    for row in [head] + rows:
        print("  ".join(str(v).rjust(w) if i else str(v).ljust(w) for i, (v, w) in enumerate(zip(row, widths))))
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
    a = p.parse_args()
    summary(a.out, a.train, a.test, a.kt, a.trees)


if __name__ == "__main__":
    main()
