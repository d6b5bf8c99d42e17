#!/usr/bin/env bash
# The small data the package and Python tests share (a CTest fixture): a 24-frame 160x120 synthetic
# corridor, every 4th frame labelled, and its work folder. Usage: make_small_corridor.sh BIN_DIR OUT_DIR
set -euo pipefail
bin="$1" out="$2"
rm -rf "$out"
mkdir -p "$out/data" "$out/work"
"$bin/make-sequence" --scene corridor --frames 24 --label-every 4 --size 160x120 -o "$out/data/corridor" -q
"$bin/extract-features" "$out/data/corridor" -o "$out/work/corridor" --future-frames 10 -q > /dev/null
echo "small corridor ready in $out"
