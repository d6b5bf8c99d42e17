#!/usr/bin/env python3
"""Function sizes of the library and tool sources, from Universal Ctags (its `end` field), as issue 36
measures them: the longest functions, how many are over 60 / 80 / 100 / 150 lines, and every tool's
main. With limits it is a ratchet: it fails (exit 1) when the code is worse than the limits, which are
set at today's figures so that no function grows past them unnoticed (docs/architecture.md, "Sizes").

Usage: function_sizes.py SOURCE_DIR [--top N] [--max-lines L] [--max-over-80 K] [--max-main M] [--json]
       function_sizes.py --self-test
"""
import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

# What counts: the modules' sources and the tools, not tests, fuzzers, benchmarks or the build.
SKIP_PARTS = {"tests", "fuzz", "bench", "build", ".git", "notebooks"}
SUFFIXES = {".cpp", ".hpp", ".h", ".cc"}


def sources(root):
    for path in sorted(root.rglob("*")):
        rel = path.relative_to(root)
        if path.suffix in SUFFIXES and path.is_file() and not (set(rel.parts[:-1]) & SKIP_PARTS) \
                and not rel.parts[0].startswith("build"):
            yield rel


def functions(root):
    """[(lines, "path:line name")] of every function definition ctags finds with an end line."""
    ctags = shutil.which("ctags")
    if ctags is None:
        sys.exit("function_sizes.py: ctags not found (Debian: apt-get install universal-ctags)")
    files = [str(p) for p in sources(root)]
    if not files:
        sys.exit(f"function_sizes.py: {root}: no C++ sources")
    out = subprocess.run([ctags, "--fields=+ne", "--output-format=json", "--languages=C++", "--kinds-C++=f",
                          "-f", "-", *files], cwd=root, capture_output=True, text=True, check=True).stdout
    found = []
    for line in out.splitlines():
        tag = json.loads(line)
        if tag.get("_type") != "tag" or tag.get("kind") != "function" or "end" not in tag:
            continue
        scope = f"{tag['scope']}::" if tag.get("scope") and "__anon" not in tag["scope"] else ""
        found.append((tag["end"] - tag["line"] + 1, f"{tag['path']}:{tag['line']} {scope}{tag['name']}"))
    return found


def is_tool_main(where):
    """main() of a tool: a file in a tools/ folder, or in train/ (whose folder is its tools')."""
    path, rest = where.split(":", 1)
    in_tools = "/tools/" in f"/{path}" or path.startswith("train/")
    return in_tools and rest.split(" ", 1)[1] == "main"


def report(found, top):
    sizes = sorted(found, reverse=True)
    mains = sorted((n, w) for n, w in found if is_tool_main(w))
    figures = {
        "functions": len(found),
        "longest": sizes[0][0] if sizes else 0,
        "over_60": sum(n > 60 for n, _ in found),
        "over_80": sum(n > 80 for n, _ in found),
        "over_100": sum(n > 100 for n, _ in found),
        "over_150": sum(n > 150 for n, _ in found),
        "tool_mains": len(mains),
        "longest_main": mains[-1][0] if mains else 0,
        "mains_over_80": sum(n > 80 for n, _ in mains),
    }
    return figures, sizes[:top], mains[::-1][:top]


def self_test():
    """A source with a 3-line and a 90-line function, and a tool main of 85 lines."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / "mod" / "src").mkdir(parents=True)
        (root / "mod" / "tools").mkdir()
        (root / "tests").mkdir()
        body = "\n".join(f"  x += {i};" for i in range(88))
        (root / "mod" / "src" / "a.cpp").write_text(f"int small() {{\n  return 1;\n}}\nint big(int x) {{\n{body}\n}}\n")
        (root / "mod" / "tools" / "t.cpp").write_text("int main() {\n" + "\n".join(["  ;"] * 83) + "\n}\n")
        (root / "tests" / "skip.cpp").write_text("int skipped() {\n" + "\n".join(["  ;"] * 500) + "\n}\n")
        figures, _, mains = report(functions(root), 5)
        expected = {"functions": 3, "longest": 90, "over_80": 2, "tool_mains": 1, "longest_main": 85}
        wrong = {k: (figures[k], v) for k, v in expected.items() if figures[k] != v}
        if wrong:
            sys.exit(f"self-test: (found, expected): {wrong}")
    print("self-test: ok")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source", nargs="?", type=Path)
    ap.add_argument("--top", type=int, default=10)
    ap.add_argument("--max-lines", type=int, help="fail when a function is longer")
    ap.add_argument("--max-over-80", type=int, help="fail when more functions are over 80 lines")
    ap.add_argument("--max-main", type=int, help="fail when a tool's main is longer")
    ap.add_argument("--json", action="store_true", help="the figures as JSON")
    ap.add_argument("--self-test", action="store_true")
    a = ap.parse_args()
    if a.self_test:
        return self_test()
    if a.source is None:
        ap.error("SOURCE_DIR is required")
    figures, longest, mains = report(functions(a.source.resolve()), a.top)
    if a.json:
        print(json.dumps(figures, indent=2))
    else:
        print(" ".join(f"{k}={v}" for k, v in figures.items()))
        print("longest functions:")
        for n, w in longest:
            print(f"  {n:5d}  {w}")
        print("longest tool mains:")
        for n, w in mains:
            print(f"  {n:5d}  {w}")
    failures = []
    if a.max_lines is not None and figures["longest"] > a.max_lines:
        failures.append(f"a function of {figures['longest']} lines (limit {a.max_lines}): {longest[0][1]}")
    if a.max_over_80 is not None and figures["over_80"] > a.max_over_80:
        failures.append(f"{figures['over_80']} functions over 80 lines (limit {a.max_over_80})")
    if a.max_main is not None and figures["longest_main"] > a.max_main:
        failures.append(f"a tool main of {figures['longest_main']} lines (limit {a.max_main}): {mains[0][1]}")
    for f in failures:
        print(f"function_sizes.py: {f}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
