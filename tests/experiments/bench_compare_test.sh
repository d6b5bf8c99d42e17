#!/usr/bin/env bash
# experiments/bench/compare.py on a real benchmark program (bench_graphcut's one max-flow case, a few
# milliseconds a run): two binaries alternated, every repetition collected, the summary and the JSON
# (real and, with --cpu, CPU times);
# and the one-line refusals (a missing binary, a filter that matches nothing, zero rounds).
# Usage: bench_compare_test.sh SOURCE_DIR BIN_DIR
set -euo pipefail
src=$1 bin=$2
compare=("$src/experiments/bench/compare.py")
bench="$bin/bench_graphcut"
[[ -x "$bench" ]] || { echo "skipped: $bench not built (SMSEG_BUILD_BENCHMARKS=OFF)"; exit 77; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cp "$bench" "$tmp/bench_a"
cp "$bench" "$tmp/bench_b"
fail() { echo "FAIL: $*" >&2; exit 1; }

python3 "${compare[@]}" --filter 'BM_GridMaxFlow' --rounds 2 --repetitions 2 --json "$tmp/out.json" \
  "$tmp/bench_a" "$tmp/bench_b" > "$tmp/table.txt"
cat "$tmp/table.txt"
[[ $(grep -c 'BM_GridMaxFlow/real_time' "$tmp/table.txt") -eq 2 ]] || fail "expected one row per binary"
python3 - "$tmp/out.json" <<'PY' || fail "summary JSON"
import json, sys
d = json.load(open(sys.argv[1]))
rows = d["summary"]
assert len(rows) == 2, rows
assert all(r["n"] == 4 for r in rows), rows  # 2 rounds x 2 repetitions, each kept
assert rows[0]["min_vs_reference"] == 1.0, rows
assert all(0 < r["min_ms"] <= r["median_ms"] for r in rows), rows
times = d["times_ms"]
assert set(times) == {r["binary"] for r in rows}
assert all(min(ts) == r["min_ms"] for r in rows for ts in [times[r["binary"]][r["case"]]])
PY

# --cpu: the CPU times, named so in the JSON.
python3 "${compare[@]}" --filter 'BM_GridMaxFlow' --rounds 1 --repetitions 2 --cpu --json "$tmp/cpu.json" \
  "$tmp/bench_a" > /dev/null
python3 - "$tmp/cpu.json" <<'PY' || fail "--cpu JSON"
import json, sys
d = json.load(open(sys.argv[1]))
assert d["clock"] == "cpu_time", d["clock"]
assert len(d["summary"]) == 1 and d["summary"][0]["n"] == 2, d["summary"]
PY

refuses() {  # EXPECTED_TEXT ARGS...: a non-zero exit and one line naming the problem
  local want=$1
  shift
  if python3 "${compare[@]}" "$@" > "$tmp/out" 2> "$tmp/err"; then fail "accepted: $*"; fi
  [[ $(wc -l < "$tmp/err") -eq 1 ]] || { cat "$tmp/err"; fail "not one line: $*"; }
  grep -q -- "$want" "$tmp/err" || { cat "$tmp/err"; fail "does not say '$want': $*"; }
}
refuses "$tmp/missing: no such file" --rounds 1 "$tmp/missing"
printf 'not a program\n' > "$tmp/text"
refuses "$tmp/text: cannot be run" --rounds 1 "$tmp/text"
refuses "no benchmark matches" --filter 'NoSuchCase' --rounds 1 --repetitions 1 "$tmp/bench_a"
refuses "must be at least 1" --rounds 0 "$tmp/bench_a"
echo "bench_compare: ok"
