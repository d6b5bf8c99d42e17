#!/usr/bin/env bash
# Command 1 of the README, the toolkit's main job on its embedded default dataset:
#   installs what is missing, builds (Release), renders the synthetic corridor stereo video, extracts
#   point tracks, camera motion and features, trains a forest (K = 400, M = 7) on the first 101
#   frames, evaluates it on the labelled frames after them, prints the scores and the confusion
#   matrix, and writes coloured labels, overlays, error maps and montages.
# Usage: bash experiments/main-job.sh [OUT]     (OUT defaults to out/main; env BUILD_DIR, default build/)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
bash .ci/install-deps.sh
build="${BUILD_DIR:-build}"
out="${1:-out/main}"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j"$(nproc)" --target make-sequence extract-features train-forest eval-forest >/dev/null
bin="$build/bin"
start=$SECONDS

echo "== 1/4 make-sequence: synthetic corridor, 300 stereo frames (320x240), labels every 10th frame"
"$bin/make-sequence" --scene corridor --seed 1 -o "$out/corridor"

echo "== 2/4 extract-features: stereo matching, tracking, motion, features -> summed-area tables"
"$bin/extract-features" "$out/corridor" -o "$out/work"

echo "== 3/4 train-forest: K = 400, M = 7 on frames 0..100"
"$bin/train-forest" "$out/work" --train-frames 0:101 -K 400 -M 7 --seed 1 -o "$out/forest.json"

echo "== 4/4 eval-forest: labelled frames 110 and later, per pixel"
"$bin/eval-forest" "$out/forest.json" "$out/work" --test-frames 110: -o "$out/eval"

echo "done in $((SECONDS - start)) s. Pictures: $out/eval/frames/ (labels, overlay, error, montage); scores: $out/eval/results.json"
