#!/usr/bin/env bash
# Runs every fuzzer of a SMSEG_FUZZ=ON build for SECONDS each (default 30), two at a time (one per
# core), each on a copy of its committed seed corpus (fuzz/corpus/<fuzzer>/, the repository is not
# changed) with its dictionary (fuzz/dict/<fuzzer>.dict) when there is one. Prints one line per fuzzer
# (executions, seconds, final corpus size, coverage edges, crashes) and exits 1 if any fuzzer reported a
# crash, a leak, a timeout or an out-of-memory, or did not run; the findings stay in the work folder.
#   fuzz/run-all.sh [SECONDS] [BUILD_DIR]      (BUILD_DIR default: build-fuzz)
#   JOBS=N to run N at a time; FUZZERS="fuzz_npy fuzz_forest" to run only those; RUNS=N to stop each
#   fuzzer after N executions (SECONDS is then only a cap: the issue's campaign is RUNS=1000000).
set -euo pipefail

seconds=${1:-30}
build=${2:-build-fuzz}
here=$(cd "$(dirname "$0")" && pwd)
bin=$(cd "$build" && pwd)/bin
jobs=${JOBS:-2}
work=$(mktemp -d "${TMPDIR:-/tmp}/smseg-fuzz-run.XXXXXX")
# The readers take paths: the fuzzers write each input to a file under TMPDIR, on tmpfs when there is one.
fuzz_tmp=${TMPDIR:-/tmp}
[[ -d /dev/shm && -w /dev/shm ]] && fuzz_tmp=/dev/shm

fuzzers=${FUZZERS:-$(cd "$here" && ls fuzz_*.cpp | sed 's/\.cpp$//')}
for f in $fuzzers; do
  [[ -x $bin/$f ]] || { echo "run-all: $bin/$f is missing (cmake --build $build --target smseg_fuzzers)" >&2; exit 1; }
done

# One fuzzer: its corpus copied into WORK/<fuzzer>/corpus, its log in WORK/<fuzzer>/log, crash files in
# WORK/<fuzzer>/. The exit status is libFuzzer's (0: nothing found).
run_one() {
  local f=$1 dir=$work/$1
  mkdir -p "$dir/corpus"
  [[ -d $here/corpus/$f ]] && cp -r "$here/corpus/$f/." "$dir/corpus/"
  local dict=() runs=()
  [[ -f $here/dict/$f.dict ]] && dict=(-dict="$here/dict/$f.dict")
  [[ -n ${RUNS:-} ]] && runs=(-runs="$RUNS")
  local start=$SECONDS status=0
  (cd "$dir" && TMPDIR=$fuzz_tmp "$bin/$f" "${dict[@]}" "${runs[@]}" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
     -print_final_stats=1 -artifact_prefix="$dir/" corpus > log 2>&1) || status=$?
  echo "$status $((SECONDS - start))" > "$dir/status"
}
export -f run_one
export work here bin seconds fuzz_tmp

printf '%s\n' $fuzzers | xargs -P "$jobs" -I{} bash -c 'run_one {}'

failed=0
printf '%-26s %12s %8s %8s %8s %8s\n' fuzzer executions seconds corpus cov crashes
for f in $fuzzers; do
  dir=$work/$f
  read -r status took < "$dir/status"
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$dir/log" | grep -o '[0-9]*$' || echo 0)
  # The last status line of libFuzzer: "#N DONE cov: E ft: F corp: C/..." (or pulse/NEW lines).
  cov=$(grep -o 'cov: [0-9]*' "$dir/log" | tail -1 | grep -o '[0-9]*' || echo 0)
  corpus=$(find "$dir/corpus" -type f | wc -l)
  crashes=$(find "$dir" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' \) | wc -l)
  printf '%-26s %12s %8s %8s %8s %8s\n' "$f" "${execs:-0}" "$took" "$corpus" "${cov:-0}" "$crashes"
  if [[ $status != 0 || $crashes != 0 || ${execs:-0} == 0 ]]; then
    failed=1
    echo "run-all: $f failed (exit $status): see $dir/log" >&2
    grep -m3 -E 'ERROR|SUMMARY|runtime error|uncaught' "$dir/log" >&2 || true
  fi
done
if [[ $failed == 0 ]]; then rm -rf "$work"; else echo "run-all: findings kept in $work" >&2; fi
exit $failed
