#!/usr/bin/env bash
# The S+M levers measured against benchmark.sh's sm run (docs/camvid.md, "The camera path for every
# pixel, and the forest's own options"): sm's set (six + five dense channels, --balance sqrt, Potts
# smoothing lambda 3), then one change at a time: + fZC, -M 15, --n-min 20, --score information-gain,
# --windows thesis-biased, -K 1000. Prints one markdown row per run (global, class-average, mean IoU,
# per-class accuracy, training seconds).
# Usage: experiments/camvid/sm-levers.sh OUT TEST_WORK TRAIN_WORK...
#   e.g. on val, with the benchmark's work folders:
#   experiments/camvid/sm-levers.sh /tmp/levers B/work/test/0016E5_07959-08159 B/work/train/*
# Environment: SMSEG_BIN (default build/bin).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
[[ $# -ge 3 ]] || { echo "usage: experiments/camvid/sm-levers.sh OUT TEST_WORK TRAIN_WORK..." >&2; exit 2; }
out=$1 test=$2
shift 2
bin="${SMSEG_BIN:-$here/build/bin}"
for t in train-forest eval-forest; do [[ -x "$bin/$t" ]] || { echo "sm-levers.sh: $bin/$t: missing" >&2; exit 2; }; done
mkdir -p "$out/forests" "$out/eval"
six=fH,fC,fOx,fOy,fD,fR dense=fZV,fZI,fZH,fZU,fZE
run() {  # NAME FEATURES K M [train-forest options]
  local name=$1 features=$2 k=$3 m=$4 t0
  shift 4
  t0=$(date +%s.%N)
  "$bin/train-forest" "${train[@]}" "$@" --features "$features" --balance sqrt -K "$k" --Kt 20000 -M "$m" --seed 1 \
    -q -o "$out/forests/$name.json" >/dev/null
  local seconds
  seconds=$(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.0f}')" "$t0" "$(date +%s.%N)")
  "$bin/eval-forest" "$out/forests/$name.json" "$test" --smooth graphcut --smooth-contrast off --lambda 3 \
    --no-pictures -q -o "$out/eval/$name" >/dev/null
  python3 - "$out/eval/$name/results.json" "$name" "$seconds" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
per_class = " | ".join(f"{100 * c['accuracy']:.1f}" for c in r["per_class"])
print(f"| {sys.argv[2]} | {100 * r['global_accuracy']:.1f} | {100 * r['class_average_accuracy']:.1f} | "
      f"{100 * r['mean_iou']:.1f} | {per_class} | {sys.argv[3]} |")
PY
}
train=("$@")
run sm "$six,$dense" 400 7
run sm_path "$six,$dense,fZC" 400 7
run sm_m15 "$six,$dense" 400 15
run sm_nmin20 "$six,$dense" 400 7 --n-min 20
run sm_information_gain "$six,$dense" 400 7 --score information-gain
run sm_thesis_windows "$six,$dense" 400 7 --windows thesis-biased
run sm_k1000 "$six,$dense" 1000 7
