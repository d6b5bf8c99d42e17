#!/usr/bin/env python3
"""Combines the results of one peers run (experiments/peers/run.sh) into one table (stdout, Markdown)
and one JSON. Each DIR holds one corpus's ours.json (forest-peers) and the peers' PEER.json; every
trainer's runs over all corpora and seeds are pooled: mean held-out accuracy (and its spread), median
fit seconds (wall clock and process CPU), our accuracy difference (ours - peer, points; mean of the
per-corpus differences) and our speed-up (peer median seconds / ours) against each peer, and the peak
RSS (MB, largest over the corpora) of the whole process (CSV reading included) and during the fits,
where the result files have them (peak_rss_mb, fit_peak_rss_mb; run.sh records both).
Usage: summarise.py DIR [DIR ...] [--peers sklearn,ranger,ranger_prob] [--ours STEM] [--machine M.json] -o peers.json
                    [--markdown peers.md]"""
import argparse
import json
import os
import statistics
import sys


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        print(f"summarise: error: {path}: {e}", file=sys.stderr)
        sys.exit(1)


def pooled(results):
    runs = [r for res in results for r in res["runs"]]
    accs = [r["accuracy"] for r in runs]
    return {"tool": results[0]["tool"], "runs": len(runs),
            "mean_accuracy": statistics.mean(accs),
            "sd_accuracy": statistics.stdev(accs) if len(accs) > 1 else 0.0,
            "per_corpus_accuracy": [res["mean_accuracy"] for res in results],
            "mean_class_average": statistics.mean(r["class_average"] for r in runs),
            "median_seconds": statistics.median(r["seconds"] for r in runs),
            "median_cpu_seconds": statistics.median(r["cpu_seconds"] for r in runs),
            "min_seconds": min(min(r["seconds_all"]) for r in runs),
            "mean_nodes": statistics.mean(r["nodes"] for r in runs),
            "peak_rss_mb": max_or_none(res.get("peak_rss_mb") for res in results),
            "fit_peak_rss_mb": max_or_none(res.get("fit_peak_rss_mb") for res in results),
            "rss_before_fit_mb": max_or_none(res.get("rss_before_fit_mb") for res in results)}


def max_or_none(values):
    values = [v for v in values if v is not None]
    return max(values) if values else None


def mb(v):
    return "n/a" if v is None else f"{v:.0f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--peers", default="sklearn,ranger,ranger_prob")
    ap.add_argument("--ours", default="ours", help="our result file's stem in each DIR (e.g. ours-information-gain)")
    ap.add_argument("--machine", help="JSON describing the machine and its load")
    ap.add_argument("-o", "--out", required=True)
    ap.add_argument("--markdown")
    a = ap.parse_args()
    names = ["ours"] + [p for p in a.peers.split(",") if p]
    results = {n: [load(os.path.join(d, (a.ours if n == "ours" else n) + ".json")) for d in a.dirs] for n in names}
    rows = []
    ours = pooled(results["ours"])
    for n in names:
        row = pooled(results[n])
        row["name"] = n
        if n != "ours":
            diffs = [100 * (o["mean_accuracy"] - p["mean_accuracy"]) for o, p in zip(results["ours"], results[n])]
            row["our_accuracy_minus_peer_points"] = statistics.mean(diffs)
            row["per_corpus_difference_points"] = diffs
            row["our_speedup_wall"] = row["median_seconds"] / ours["median_seconds"]
            row["our_speedup_cpu"] = row["median_cpu_seconds"] / ours["median_cpu_seconds"]
            row["within_1_point"] = abs(row["our_accuracy_minus_peer_points"]) <= 1.0
            row["at_least_3x_faster_wall"] = row["our_speedup_wall"] >= 3.0
            row["at_least_3x_faster_cpu"] = row["our_speedup_cpu"] >= 3.0
            for k in ("peak_rss_mb", "fit_peak_rss_mb"):
                if ours[k] is not None and row[k] is not None:
                    row[k.replace("_mb", "") + "_at_most_peer"] = ours[k] <= row[k]
        rows.append(row)
    lines = ["| trainer | held-out accuracy % (sd) | class-avg % | fit s wall | fit s CPU | nodes/forest "
             "| ours - peer (points) | our speed-up wall / CPU | peak RSS MB process / fit |",
             "|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        peer = row["name"] != "ours"
        diff = f"{row['our_accuracy_minus_peer_points']:+.2f}" if peer else ""
        sp = f"{row['our_speedup_wall']:.1f}x / {row['our_speedup_cpu']:.1f}x" if peer else ""
        lines.append(f"| {row['tool']} | {100 * row['mean_accuracy']:.2f} ({100 * row['sd_accuracy']:.2f}) | "
                     f"{100 * row['mean_class_average']:.2f} | {row['median_seconds']:.3f} | "
                     f"{row['median_cpu_seconds']:.3f} | {row['mean_nodes']:.0f} | {diff} | {sp} | "
                     f"{mb(row['peak_rss_mb'])} / {mb(row['fit_peak_rss_mb'])} |")
    lines.append("")
    lines.append("Per corpus (mean accuracy % over the seeds): " + "; ".join(
        f"corpus {i + 1}: " + ", ".join(f"{r['name']} {100 * r['per_corpus_accuracy'][i]:.2f}" for r in rows)
        for i in range(len(a.dirs))))
    table = "\n".join(lines)
    print(table)
    first = results["ours"][0]
    res = {"format": "smseg-peers", "version": 1,
           "setup": {k: first[k] for k in ("rows_train", "rows_heldout", "columns", "classes", "trees", "n_min",
                                           "threads", "repeat")},
           "corpora": a.dirs, "seeds": [r["seed"] for r in first["runs"]],
           "machine": load(a.machine) if a.machine else None, "rows": rows}
    tmp = a.out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(res, f, indent=1)
        f.write("\n")
    os.replace(tmp, a.out)
    if a.markdown:
        with open(a.markdown + ".tmp", "w") as f:
            f.write(table + "\n")
        os.replace(a.markdown + ".tmp", a.markdown)


if __name__ == "__main__":
    main()
