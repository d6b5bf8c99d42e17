#!/usr/bin/env python3
"""The option-range sweep (docs/reliability.md, "Every accepted value works").

Every numeric option of every tool, read from the tool's own --help (so a new option is covered
without touching this file), is tried at the ends of its declared range, just outside them, and at
NaN / +-inf, on a small fixture of real inputs (a synthetic sequence, its work folder and forest, a
cloud, a tabletop sequence, CamVid's and KITTI's manifests, Middlebury pairs). Each run has a time
and an address-space limit. A case passes when:
  - a value outside the range, or a non-finite one, is refused as bad usage (exit 2, the option named);
  - a value inside the range finishes within the limits with exit 0, or exit 1 and one line naming
    what failed (a data error the value leads to), never a signal, a hang or library text alone;
  - a numeric option declares a range at all (an option without one is reported as unranged).

usage: option_ranges.py BIN_DIR WORK_DIR [--outside-only] [--tools a,b] [--json OUT] [--markdown OUT]
       [--timeout S] [--jobs N]
Exit status 0 when every case passes, 1 otherwise (the failing cases are listed).
"""
import argparse
import concurrent.futures
import functools
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "data"
MEMORY_LIMIT = 6 << 30
OPTION_LINE = re.compile(r"^  (?:(?P<short>-\w),)?(?P<name>--[A-Za-z0-9][A-Za-z0-9-]*|-\w)\s+(?P<type>INT|UINT|FLOAT|DOUBLE)(?P<rest>.*?)(?:\s{2,}|$)")
RANGE = re.compile(r"\[(?P<lo>[^\]\s]+) - (?P<hi>[^\]\s]+)\]")

# Options whose largest value asks for work in proportion to it (frames to write, trees to grow):
# they are tried at their largest value only when the tool refuses it or finishes within the limit;
# a timeout there is the work the user asked for, and is reported as such, not as a hang.
PROPORTIONAL = {
    ("make-sequence", "--frames"): "writes that many frames",
    ("make-sequence", "--montage-frames"): "draws that many montage rows",
    ("segment-cloud", "--make-tabletop"): "writes that many points",
    ("train-forest", "-M"): "grows that many trees",
    ("forest-peers", "-M"): "grows that many trees",
    ("forest-peers", "--repeat"): "fits that many times",
    ("add-context", "--folds"): "trains that many fold forests",
    ("learn-textons", "--samples"): "clusters that many pixels of each frame",
}


def tool_options(bin_dir, tool):
    """(name, type, lo, hi) of each numeric option in the tool's --help; lo/hi None when undeclared."""
    text = help_of(bin_dir, tool)
    options = []
    for line in text.splitlines():
        m = OPTION_LINE.match(line)
        if not m or m["name"] in ("-h", "--help"):
            continue
        r = RANGE.search(m["rest"])
        lo, hi = (r["lo"], r["hi"]) if r else (None, None)
        aliases = [m["name"]] + ([m["short"]] if m["short"] else [])
        options.append({"name": m["name"], "aliases": aliases, "type": m["type"], "lo": lo, "hi": hi})
    return options


def step_outside(text, up, integer):
    x = float(text)
    if integer:
        whole = int(text) if re.fullmatch(r"-?\d+", text) else int(float(text))
        return str(whole + (1 if up else -1))
    d = max(abs(x) * 1e-3, 1e-9)
    return repr(x + d if up else x - d)


def cases_of(opt, outside_only):
    """(kind, value, expectation) for one option: expectation 'refused' or 'runs'."""
    integer = opt["type"] in ("INT", "UINT")
    out = []
    if opt["lo"] is not None:
        if not outside_only:
            out += [("min", opt["lo"], "runs"), ("max", opt["hi"], "runs")]
        out += [("below", step_outside(opt["lo"], False, integer), "refused"),
                ("above", step_outside(opt["hi"], True, integer), "refused")]
    if not integer:
        out += [("nan", "nan", "refused"), ("inf", "inf", "refused"), ("-inf", "-inf", "refused")]
    return out


def limits():
    # AddressSanitizer reserves terabytes of shadow address space: under it (tests/run-sanitized.sh sets
    # ASAN_OPTIONS) there is no address-space limit, the time limit alone.
    if "ASAN_OPTIONS" not in os.environ:
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    os.setsid()


def run(argv, timeout, cwd):
    start = time.monotonic()
    p = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, errors="replace",
                         preexec_fn=limits, cwd=cwd)
    try:
        _, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.communicate()
        return {"status": "timeout", "seconds": round(time.monotonic() - start, 1), "stderr": ""}
    return {"status": p.returncode, "seconds": round(time.monotonic() - start, 1), "stderr": err.strip()}


def judge(tool, opt, kind, expect, result):
    """None when the case passes, else what is wrong."""
    status, err = result["status"], result["stderr"]
    lines = [l for l in err.splitlines() if l.strip()]
    if status == "timeout":
        if expect == "runs" and (tool, opt["name"]) in PROPORTIONAL and kind == "max":
            return None
        return "hang (no exit within the time limit)"
    if status < 0 or status > 2:
        return f"crash (exit {status}): {lines[-1] if lines else ''}"
    if expect == "refused":
        if status != 2:
            return f"accepted (exit {status})" if status == 0 else f"refused as a data error (exit {status}): {lines[-1] if lines else ''}"
        return None if lines and tool in lines[-1] else f"refusal without the tool's line: {lines[-1] if lines else ''}"
    if status == 2 and not (lines and lines[-1].startswith(tool + ":")):
        return f"a value inside the declared range refused without the tool's one line: {lines[-1] if lines else ''}"
    if status == 1 and not (lines and lines[-1].startswith(tool + ":")):
        return f"failure without the tool's one line: {lines[-1] if lines else '(nothing)'}"
    return None


def sh(argv, cwd):
    r = subprocess.run([str(a) for a in argv], cwd=cwd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"option_ranges: fixture step failed: {' '.join(map(str, argv))}\n{r.stderr}")


def make_fixture(bin_dir, work):
    """The small real inputs every tool's base command reads; made once per WORK_DIR."""
    done = work / "fixture.done"
    if done.exists():
        return
    b = lambda t: bin_dir / t
    sh([b("make-sequence"), "-o", "seq", "--frames", "8", "--label-every", "2", "--size", "96x72", "-q"], work)
    sh([b("extract-features"), "seq", "-o", "w", "-q"], work)
    sh([b("extract-features"), "seq", "-o", "wc", "--causal", "-q"], work)
    sh([b("train-forest"), "w", "-o", "forest.json", "-M", "2", "-K", "40", "-q", "--export-corpus", "corpus.csv"], work)
    sh([b("train-forest"), "wc", "-o", "forest_causal.json", "-M", "2", "-K", "40", "-q"], work)
    sh([b("segment-cloud"), "--make-tabletop", "3000", "-o", "cloud.pcd"], work)
    sh([b("learn-textons"), "w", "--textons", "4", "--samples", "200", "-o", "textons.json", "-q"], work)
    sh([b("learn-hog-classes"), "w", "--channels", "wall,person", "--window", "32x64", "--epochs", "1", "-o", "hog.json", "-q"],
       work)
    sh([b("make-sequence"), "--scene", "tabletop", "-o", "table", "--frames", "10", "--label-every", "5", "--size", "160x120",
        "-q"], work)
    sh([b("extract-features"), "table", "-o", "tw", "-q"], work)
    (work / "experiment.json").write_text(json.dumps({
        "format": "smseg-experiment", "version": 1, "name": "sweep",
        "sequences": {"s": {"synthetic": {"frames": 12, "label_every": 2, "width": 64, "height": 48}}},
        "fixed": {"train": "s", "train_frames": "0:6", "test_frames": "6:", "M": 2, "K": 30}}))
    sh([b("run-experiment"), "experiment.json", "-o", "results/sweep", "-q"], work)
    done.write_text("ok\n")


def base_command(tool, option_help, aliases):
    """The valid command a case adds its option to, without the option itself; {out} is a fresh output
    path per case."""
    base = tool_base(tool, option_help)
    if option_help.startswith("with --slurm"):
        base += ["--slurm", "--slurm-dry-run"]  # prints the job scripts, submits nothing
    for alias in aliases:
        if alias in base:
            i = base.index(alias)
            del base[i:i + 2]
    return base


def tool_base(tool, option_help):
    camvid, kitti = SHARED / "camvid", SHARED / "kitti-stereo" / "seq1"
    if tool == "segment-cloud":
        if option_help.startswith("mrf saliency"):
            return ["--method", "mrf", "--seeds", "saliency", "--sequence", "table", "--work", "tw", "--frame", "5", "-o",
                    "{out}.pcd"]
        if "grabcut-sfm" in option_help:
            return ["--method", "grabcut-sfm", "--sequence", "table", "--work", "tw", "--frame", "5", "-o", "{out}.png"]
        if "mrf" in option_help or option_help.startswith("RANSAC"):
            return ["cloud.pcd", "--method", "mrf", "--seeds", "plane", "-o", "{out}.pcd"]
        return ["cloud.pcd", "--method", "centroid-mincut", "--radius", "0.3", "-o", "{out}.pcd"]
    return {
        "add-context": ["forest.json", "w", "-o", "{out}", "-q"],
        "add-textons": ["textons.json", "w", "-o", "{out}", "-q"],
        "add-people": ["w", "-o", "{out}", "-q"],
        "add-hog-classes": ["hog.json", "w", "-o", "{out}", "-q"],
        "learn-hog-classes": ["w", "--channels", "wall,person", "--window", "32x64", "--epochs", "1", "-o", "{out}.json", "-q"],
        "learn-textons": ["w", "-o", "{out}.json", "-q"],
        "check-sequence": ["seq"],
        "eval-forest": ["forest.json", "w", "-o", "{out}", "-q"],
        "eval-stereo": ["--data", str(SHARED / "middlebury-q"), "-o", "{out}.json"],
        "eval-stereo-path": ["seq", "w", "-o", "{out}.json"],
        "export-notebooks": ["results", "-o", "{out}", "--no-png", "-q"],
        "extract-features": ["seq", "-o", "{out}", "-q"],
        "forest-peers": ["corpus.csv", "corpus.csv", "-M", "2", "--repeat", "1", "-o", "{out}.json"],
        "import-camvid": [str(camvid), "-o", "{out}", "--split", "val"],
        "import-kitti": [str(kitti), "-o", "{out}"],
        "label-stream": ["seq", "forest_causal.json", "-o", "{out}", "-q"],
        "make-sequence": ["-o", "{out}", "--frames", "3", "--size", "64x48", "-q"],
        "run-experiment": ["experiment.json", "-o", "{out}", "-q"],
        "train-forest": ["w", "-o", "{out}.json", "-M", "2", "-K", "40", "-q"],
    }[tool]


@functools.lru_cache(maxsize=None)
def help_of(bin_dir, tool):
    return subprocess.run([str(bin_dir / tool), "--help"], capture_output=True, text=True, check=True).stdout


def option_help_text(bin_dir, tool, name):
    text = help_of(bin_dir, tool).splitlines()
    for i, line in enumerate(text):
        m = OPTION_LINE.match(line)
        if m and m["name"] == name:
            rest = line[m.end():].strip()
            following = text[i + 1].strip() if i + 1 < len(text) else ""
            return (rest.split(" ", 1)[1] if " " in rest else following) if rest else following
    return ""


def tools_in(bin_dir):
    names = []
    for p in sorted(bin_dir.iterdir()):
        if p.is_file() and os.access(p, os.X_OK) and not p.name.startswith(("test_", "bench_", "fuzz_")) and "-" in p.name:
            names.append(p.name)
    return names


def all_cases(bin_dir, tools, outside_only):
    cases, unranged = [], []
    for tool in tools:
        for opt in tool_options(bin_dir, tool):
            if opt["lo"] is None:
                unranged.append({"tool": tool, "option": opt["name"], "type": opt["type"]})
            help_text = option_help_text(bin_dir, tool, opt["name"])
            for kind, value, expect in cases_of(opt, outside_only):
                cases.append({"tool": tool, "option": opt, "kind": kind, "value": value, "expect": expect,
                              "base": base_command(tool, help_text, opt["aliases"])})
    return cases, unranged


def run_case(bin_dir, work, timeout, i, case):
    out = work / "out" / f"case{i}"
    argv = [str(bin_dir / case["tool"])] + [a.replace("{out}", str(out)) for a in case["base"]]
    name = case["option"]["name"]
    # --name=value so a negative value is not read as an option; short options take the next argument.
    argv += [f"{name}={case['value']}"] if name.startswith("--") else [name, case["value"]]
    result = run(argv, timeout, work)
    for p in out.parent.glob(out.name + "*"):
        shutil.rmtree(p, ignore_errors=True) if p.is_dir() else p.unlink(missing_ok=True)
    problem = judge(case["tool"], case["option"], case["kind"], case["expect"], result)
    return {"tool": case["tool"], "option": case["option"]["name"], "kind": case["kind"], "value": case["value"],
            "expect": case["expect"], "status": result["status"], "seconds": result["seconds"], "problem": problem,
            "command": " ".join(argv[1:])}


def markdown(results, unranged):
    rows = {}
    for r in results:
        row = rows.setdefault(r["tool"], {"options": set(), "cases": 0, "refused": 0, "ran": 0, "crash": 0, "hang": 0,
                                          "nonfinite": 0, "other": 0, "in_range_refused": 0})
        row["options"].add(r["option"])
        row["cases"] += 1
        p = r["problem"] or ""
        row["crash"] += p.startswith("crash")
        row["hang"] += p.startswith("hang")
        row["nonfinite"] += r["kind"] in ("nan", "inf", "-inf") and r["status"] == 0
        row["other"] += bool(p) and not p.startswith(("crash", "hang"))
        row["refused"] += r["status"] == 2 and r["expect"] == "refused"
        row["in_range_refused"] += r["status"] == 2 and r["expect"] == "runs"
        row["ran"] += r["status"] in (0, 1)
    lines = ["| tool | numeric options | cases | outside or non-finite: refused (exit 2) | inside: ran (exit 0/1) | inside: "
             "refused by another option's rule (exit 2) | crashes | hangs | non-finite accepted | other failures | unranged |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for tool, row in sorted(rows.items()):
        n_unranged = sum(1 for u in unranged if u["tool"] == tool)
        lines.append(f"| {tool} | {len(row['options'])} | {row['cases']} | {row['refused']} | {row['ran']} | "
                     f"{row['in_range_refused']} | {row['crash']} | "
                     f"{row['hang']} | {row['nonfinite']} | {row['other']} | {n_unranged} |")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("bin_dir", type=Path)
    ap.add_argument("work_dir", type=Path)
    ap.add_argument("--outside-only", action="store_true", help="only the values that must be refused (fast)")
    ap.add_argument("--tools", help="comma-separated tools (default: every tool in BIN_DIR)")
    ap.add_argument("--timeout", type=float, default=60)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json")
    ap.add_argument("--markdown")
    a = ap.parse_args()
    bin_dir, work = a.bin_dir.resolve(), a.work_dir.resolve()
    work.mkdir(parents=True, exist_ok=True)
    (work / "out").mkdir(exist_ok=True)
    tools = a.tools.split(",") if a.tools else tools_in(bin_dir)
    if not a.outside_only:
        make_fixture(bin_dir, work)
    cases, unranged = all_cases(bin_dir, tools, a.outside_only)
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        results = list(pool.map(lambda ic: run_case(bin_dir, work, a.timeout, *ic), enumerate(cases)))
    failures = [r for r in results if r["problem"]]
    if a.json:
        Path(a.json).write_text(json.dumps({"results": results, "unranged": unranged}, indent=1))
    if a.markdown:
        Path(a.markdown).write_text(markdown(results, unranged))
    print(markdown(results, unranged))
    for u in unranged:
        print(f"unranged: {u['tool']} {u['option']} ({u['type']})")
    for r in failures:
        print(f"FAIL {r['tool']} {r['option']}={r['value']} ({r['kind']}): {r['problem']}")
    print(f"{len(results)} cases, {len(failures)} failures, {len(unranged)} unranged options")
    return 1 if failures or unranged else 0


if __name__ == "__main__":
    sys.exit(main())
