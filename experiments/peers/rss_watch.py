#!/usr/bin/env python3
"""Runs a trainer and measures its resident memory from outside (Linux /proc), for forest-peers, whose
C++ source does not measure it. Usage: rss_watch.py [--merge-into R.json] -- COMMAND [ARGS ...]

The command's stdout is passed through line by line. Each line starting with "seed N:" (forest-peers
prints one after the fits and the held-out scoring of each seed) ends an interval: the wrapper reads
the child's VmHWM (peak RSS since the previous line), then resets the peak to the current RSS (writes
5 to /proc/PID/clear_refs, Linux >= 4.0). The interval between the first and the second "seed" line
therefore holds the fits of the second seed (and its scoring, which allocates little in forest-peers),
after both CSVs have been read: its peak is "RSS during the fit". The process peak is the largest of
all intervals' peaks and of the peak after the last line (ru_maxrss at exit, which after a reset covers
only the time since it). "RSS before the fit" is the smallest RSS sampled (every 5 ms) in the second
interval: the data and the previous forest, before the fit's own allocations. The command's stdout
should be line-buffered (run.sh starts forest-peers under `stdbuf -oL`).

--merge-into adds to R.json (written by the command): peak_rss_mb (whole process, reading the CSVs
included), fit_peak_rss_mb (the largest peak of the intervals after the first, null with one seed),
rss_before_fit_mb (smallest sampled RSS in the second interval) and rss_method. MB = 2^20 bytes."""
import json
import os
import re
import subprocess
import sys
import threading


def status(pid):
    """(VmHWM, VmRSS) in kB of a live process, or None."""
    try:
        with open(f"/proc/{pid}/status") as f:
            text = f.read()
    except OSError:
        return None
    vals = dict(re.findall(r"^(VmHWM|VmRSS):\s+(\d+) kB", text, re.M))
    if len(vals) != 2:
        return None
    return int(vals["VmHWM"]), int(vals["VmRSS"])


def reset_peak(pid):
    try:
        with open(f"/proc/{pid}/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def main():
    args = sys.argv[1:]
    merge = None
    if args[:1] == ["--merge-into"]:
        merge, args = args[1], args[2:]
    if args[:1] == ["--"]:
        args = args[1:]
    if not args:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    child = subprocess.Popen(args, stdout=subprocess.PIPE, text=True, bufsize=1)
    intervals = []  # (peak kB, smallest sampled RSS kB) of each interval
    low = [None]  # smallest RSS sampled in the current interval
    lock = threading.Lock()
    done = threading.Event()

    def sample():
        while not done.wait(0.005):
            st = status(child.pid)
            if st is not None:
                with lock:
                    low[0] = st[1] if low[0] is None else min(low[0], st[1])

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    resettable = True
    for line in child.stdout:
        sys.stdout.write(line)
        sys.stdout.flush()
        if re.match(r"seed \d+:", line):
            st = status(child.pid)
            if st is None:
                continue
            with lock:
                intervals.append((st[0], low[0]))
                low[0] = None
                resettable = resettable and reset_peak(child.pid)
    done.set()
    sampler.join()
    _, code, usage = os.wait4(child.pid, 0)
    rc = os.waitstatus_to_exitcode(code)
    last_kb = usage.ru_maxrss  # the peak since the last reset (or of the whole run without one)
    if rc != 0:
        sys.exit(rc)
    if merge:
        mb = lambda kb: round(kb / 1024.0, 1)
        fit = intervals[1:] if resettable else []
        res = json.load(open(merge))
        res["peak_rss_mb"] = mb(max([last_kb] + [p for p, _ in intervals]))
        res["fit_peak_rss_mb"] = mb(max(p for p, _ in fit)) if fit else None
        res["rss_before_fit_mb"] = mb(fit[0][1]) if fit and fit[0][1] is not None else None
        res["rss_method"] = ("outside (rss_watch.py): /proc/PID/status VmHWM, reset at each 'seed' line; fit = "
                             "intervals after the first (fits and scoring of seeds 2..); before = smallest RSS "
                             "sampled every 5 ms in the second interval")
        tmp = merge + ".tmp"
        with open(tmp, "w") as f:
            json.dump(res, f, indent=1)
            f.write("\n")
        os.replace(tmp, merge)
    sys.exit(rc)


if __name__ == "__main__":
    main()
