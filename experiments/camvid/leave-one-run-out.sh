#!/usr/bin/env bash
# Leave one 1 Hz run out: for each of the five CamVid train runs, train a structure-and-motion forest on
# val and the other four and test on it (docs/camvid.md, "Heights from the ground under the camera").
# The 1 Hz runs are the closest we have to the test split (also 1 Hz); val is 15 Hz.
#   experiments/camvid/leave-one-run-out.sh WORKS OUT [train-forest options...]
# WORKS holds one work folder per run, named as the runs (extract-features SEQ -o WORKS/NAME
# --require-label); OUT gets the forests and eval-forest results, and prints one line per run. Tools from
# ${SMSEG_BIN:-build/bin}. Default forest options: the six S+M features, -K 400 --Kt 20000 -M 7 --seed 1.
set -euo pipefail
[[ $# -ge 2 ]] || { echo "usage: $0 WORKS OUT [train-forest options...]" >&2; exit 2; }
works=$1 out=$2
shift 2
bin=${SMSEG_BIN:-build/bin}
options=("$@")
[[ ${#options[@]} -gt 0 ]] || options=(--features fH,fC,fOx,fOy,fD,fR -K 400 --Kt 20000 -M 7 --seed 1)
runs=(0001TP_006690-008520 0006R0_f00930-f03930 0016E5_00390-02400 0016E5_04350-07920 0016E5_08190-08640)
val=0016E5_07959-08159
for r in "${runs[@]}" "$val"; do
  [[ -f $works/$r/stacks.json ]] || { echo "$works/$r: no work folder (stacks.json)" >&2; exit 1; }
done
mkdir -p "$out"
for held in "${runs[@]}"; do
  train=("$works/$val")
  for r in "${runs[@]}"; do [[ $r == "$held" ]] || train+=("$works/$r"); done
  "$bin/train-forest" "${train[@]}" "${options[@]}" -q -o "$out/forest-$held.json" >/dev/null
  "$bin/eval-forest" "$out/forest-$held.json" "$works/$held" --no-pictures -q -o "$out/eval-$held" | sed "s|^|$held: |"
done
