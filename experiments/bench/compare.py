#!/usr/bin/env python3
"""Compares Google Benchmark binaries on a machine whose neighbours move the timings.

On the shared 2-core VMs a benchmark's figures drift by up to 1.6x within minutes (the same binary:
CamVid per-pixel 21.4 ms at 14:37 and 35 ms at 14:51 on 2026-12-04), so two binaries run one after the
other, or one run of each, cannot tell a 10 % change from the drift. This script alternates the
binaries round after round (A B A B ...) on the same benchmark filter, collects every repetition
(not the aggregates), and reports per case and binary the minimum (the run least disturbed) and the
median, and each binary's minimum against the first binary's.

With --cpu the figures are Google Benchmark's cpu_time (the calling thread's CPU time) instead of the
real time: on a machine busier than its cores, a one-thread case's CPU time is the least disturbed
figure (the real time counts the waits for a core).

Usage: compare.py [--filter REGEX] [--rounds N] [--repetitions R] [--cpu] [--json OUT] BINARY [BINARY ...]
  e.g. compare.py --filter 'BM_LabelFrameCamVid/mode:1' --rounds 4 /tmp/bench_eval_old build/bin/bench_eval
The binaries see the same environment (SMSEG_BENCH_FOREST etc. pass through).
"""
import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from collections import defaultdict
from pathlib import Path


def run_once(binary, pattern, repetitions, clock="real_time"):
    """Every repetition of every case of one run of `binary`: {case: [time in ms, ...]}, `clock` being
    real_time or cpu_time."""
    with tempfile.NamedTemporaryFile(suffix=".json") as out:
        cmd = [binary, f"--benchmark_filter={pattern}", f"--benchmark_repetitions={repetitions}",
               f"--benchmark_out={out.name}", "--benchmark_out_format=json"]
        try:
            done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        except OSError as e:  # not executable, not a program
            sys.exit(f"compare.py: {binary}: cannot be run ({e.strerror})")
        if done.returncode != 0:
            last = (done.stderr.strip().splitlines() or [""])[-1][:300]
            sys.exit(f"compare.py: {binary}: exited with {done.returncode}: {last}")
        text = Path(out.name).read_text()
    if not text.strip():  # nothing matched the filter: Google Benchmark writes no report
        return {}
    try:
        report = json.loads(text)
    except json.JSONDecodeError as e:
        sys.exit(f"compare.py: {binary}: its --benchmark_out is not JSON ({e})")
    scale = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}
    times = defaultdict(list)
    for b in report.get("benchmarks", []):
        if b.get("run_type") != "iteration" or b.get("error_occurred"):
            continue
        times[b["run_name"]].append(b[clock] * scale[b.get("time_unit", "ns")])
    return times


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("binaries", nargs="+", help="Google Benchmark binaries (the first is the reference)")
    ap.add_argument("--filter", default=".", help="--benchmark_filter for every binary")
    ap.add_argument("--rounds", type=int, default=4, help="runs of each binary, alternated")
    ap.add_argument("--repetitions", type=int, default=5, help="--benchmark_repetitions per run")
    ap.add_argument("--cpu", action="store_true", help="cpu_time (the calling thread's) instead of real time")
    ap.add_argument("--json", help="also write the collected times and the summary here")
    a = ap.parse_args()
    if a.rounds < 1 or a.repetitions < 1:
        sys.exit("compare.py: --rounds and --repetitions must be at least 1")
    for b in a.binaries:
        if not Path(b).is_file():
            sys.exit(f"compare.py: {b}: no such file")
    times = {b: defaultdict(list) for b in a.binaries}
    for r in range(a.rounds):
        for b in a.binaries:
            for case, ts in run_once(b, a.filter, a.repetitions, "cpu_time" if a.cpu else "real_time").items():
                times[b][case].extend(ts)
    cases = sorted({c for b in a.binaries for c in times[b]})
    if not cases:
        sys.exit(f"compare.py: no benchmark matches --filter {a.filter!r}")
    summary = []
    ref = a.binaries[0]
    unit = "cpu ms" if a.cpu else "ms"
    print(f"{'case':62s} {'binary':28s} {'min ' + unit:>10s} {'median ' + unit:>13s} {'n':>4s} {'min / ref':>9s}")
    for case in cases:
        for b in a.binaries:
            ts = times[b].get(case, [])
            if not ts:
                continue
            row = {"case": case, "binary": b, "min_ms": min(ts), "median_ms": statistics.median(ts), "n": len(ts)}
            ref_ts = times[ref].get(case)
            row["min_vs_reference"] = min(ts) / min(ref_ts) if ref_ts else None
            summary.append(row)
            ratio = f"{row['min_vs_reference']:.3f}" if row["min_vs_reference"] else ""
            print(f"{case:62s} {Path(b).name[:28]:28s} {row['min_ms']:10.3f} {row['median_ms']:13.3f} {len(ts):4d} {ratio:>9s}")
    if a.json:
        Path(a.json).write_text(json.dumps({"rounds": a.rounds, "repetitions": a.repetitions, "filter": a.filter,
                                            "clock": "cpu_time" if a.cpu else "real_time",
                                            "summary": summary,
                                            "times_ms": {b: dict(times[b]) for b in a.binaries}}, indent=1))


if __name__ == "__main__":
    main()
