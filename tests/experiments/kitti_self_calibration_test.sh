#!/usr/bin/env bash
# experiments/kitti/self_calibrate_offset.py on the real KITTI slice seq1 of ../shared/data: the
# disparity offset estimated from the sequence's own tracks (no ground truth) must be near zero for its
# correct calibration (~0.1 px; the ground-truth script gives +0.13), and the same total when the slice
# is imported 1 px off (--disparity-offset -1: the estimate must give the pixel back). The pipeline's
# own self-calibration (extract-features' default --disparity-offset auto, from the first 11 frames)
# must keep nothing for the right calibration and give the pixel back for the shifted one. Then a work
# folder without tracks.json, or with a malformed track, is one clear line and a non-zero exit.
# Usage: kitti_self_calibration_test.sh SOURCE_DIR BIN_DIR SHARED_DIR PYTHON     (exit 77: no KITTI, skipped)
set -euo pipefail
src=$1 bin=$2 shared=$3 python=$4
kitti="$shared/data/kitti-stereo/seq1"
[[ -f "$kitti/calib.txt" ]] || { echo "no KITTI slice under $shared/data: skipped"; exit 77; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

estimate() {  # OFFSET: the total the script estimates for seq1 imported with that offset
  "$bin/import-kitti" "$kitti" -o "$tmp/seq$1" --disparity-offset "$1" >/dev/null
  "$bin/extract-features" "$tmp/seq$1" -o "$tmp/work$1" -q --threads 2 --disparity-offset calibration >/dev/null
  "$python" "$src/experiments/kitti/self_calibrate_offset.py" "$tmp/seq$1" "$tmp/work$1" | tail -1 |
    sed -n 's/^disparity offset: \([-+0-9.]*\) px.*/\1/p'
}
plain=$(estimate 0)
shifted=$(estimate -1)
echo "estimated offset: $plain px (calibration 0), $shifted px (calibration -1)"
"$python" - "$plain" "$shifted" <<'PY'
import sys
plain, shifted = float(sys.argv[1]), float(sys.argv[2])
assert abs(plain) < 0.35, f"FAIL: seq1's own calibration should need ~0 px, estimated {plain}"
assert abs(shifted - plain) < 0.25, f"FAIL: 1 px off, the estimate should give the pixel back ({shifted} vs {plain})"
PY

for offset in 0 -1; do  # the pipeline's own estimate (tracks.json's summary), with the defaults
  "$bin/extract-features" "$tmp/seq$offset" -o "$tmp/auto$offset" -q --threads 2 >/dev/null
done
"$python" - "$tmp/auto0/tracks.json" "$tmp/auto-1/tracks.json" <<'PY'
import json, sys
right, shifted = (json.load(open(f))["summary"]["disparity_offset_px"] for f in sys.argv[1:3])
print(f"extract-features --disparity-offset auto: {right:+.3f} px (calibration 0), {shifted:+.3f} px (calibration -1)")
assert right == 0, f"FAIL: the right calibration should be kept as it is, got {right}"
assert abs(shifted) < 0.35, f"FAIL: 1 px off, the pipeline should give the pixel back, got a total of {shifted}"
PY

rm "$tmp/work0/tracks.json"
if "$python" "$src/experiments/kitti/self_calibrate_offset.py" "$tmp/seq0" "$tmp/work0" 2>"$tmp/err.txt"; then
  echo "FAIL: a work folder without tracks.json was accepted"; exit 1
fi
[[ $(wc -l <"$tmp/err.txt") -eq 1 ]] && grep -q "tracks.json" "$tmp/err.txt" || { cat "$tmp/err.txt"; echo "FAIL: not one line naming the file"; exit 1; }
# A track without its pixels: the same, not a traceback.
echo '{"tracks": [{"frames": [0, 1], "d": [10, 11]}]}' >"$tmp/work0/tracks.json"
if "$python" "$src/experiments/kitti/self_calibrate_offset.py" "$tmp/seq0" "$tmp/work0" 2>"$tmp/err.txt"; then
  echo "FAIL: a track without pixels was accepted"; exit 1
fi
[[ $(wc -l <"$tmp/err.txt") -eq 1 ]] && grep -q "tracks.json" "$tmp/err.txt" || { cat "$tmp/err.txt"; echo "FAIL: not one line naming the file"; exit 1; }
echo "ok"
