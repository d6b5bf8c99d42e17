#!/usr/bin/env bash
# extract-features's verbosity over the solver libraries, on monocular SfM (Ceres, glog, CHOLMOD) of a
# 40-frame synthetic corridor: with -q nothing on stderr; with -v one summary per bundle adjustment
# (which shows that the solver's output is there to be silenced). Only frame 0's stack is written (the
# front end still runs over every frame). Usage: quiet_logs.sh BIN_DIR
set -euo pipefail
bin="$1"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$bin/make-sequence" --scene corridor --frames 40 -o "$tmp/seq" -q > /dev/null
"$bin/extract-features" "$tmp/seq" -o "$tmp/quiet" --motion sfm --frames 0:1 -q > /dev/null 2> "$tmp/quiet.err"
if [[ -s "$tmp/quiet.err" ]]; then
  echo "extract-features -q printed on stderr:"; head -20 "$tmp/quiet.err"; exit 1
fi
"$bin/extract-features" "$tmp/seq" -o "$tmp/verbose" --motion sfm --frames 0:1 -v > /dev/null 2> "$tmp/verbose.err"
grep -q "^bundle adjustment: " "$tmp/verbose.err" || { echo "-v printed no solver summary:"; head "$tmp/verbose.err"; exit 1; }
echo "-q: stderr empty; -v: $(grep -c '^bundle adjustment: ' "$tmp/verbose.err") solver summaries"
