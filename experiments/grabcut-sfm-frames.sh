#!/usr/bin/env bash
# GrabCutSFM (paper 001) and its two baselines on several frames of one work folder, and the mean F1 of
# each method: runs `segment-cloud --method grabcut-sfm` per frame and averages the summaries' F1.
# Usage: bash experiments/grabcut-sfm-frames.sh SEQ WORK OUT "F1 F2 ..." [segment-cloud options...]
#   e.g. the CamVid val run of docs/graphcuts.md (the 10 labelled frames with the largest car):
#   bash experiments/grabcut-sfm-frames.sh ../shared/camvid-seq/0016E5_07959-08159 work/0016E5_07959-08159 \
#       out/gcsfm "45 43 44 42 46 41 4 5 3 47" --truth-label Car --plane-distance 0.25 --max-distance 30
#   or the tabletop sequence with the tabletop options of docs/graphcuts.md:
#   bash experiments/grabcut-sfm-frames.sh tab/seq tab/work out/tab "$(seq -s ' ' 0 10 290)" --truth-instance nearest \
#       --window 10 --frustum-only --max-distance 3 --plane-distance 0.02 --height-band 0.35 --support-radius 0.15 \
#       --cluster euclidean --cluster-tolerance 0.06 --min-cluster-size 8 --box-margin 0.3 --max-tilt 20
#   or, best on that scene (0.88; docs/graphcuts.md "H"), its dense depth clustered and the table from the tracks
#   of a work folder made with extract-features --gravity estimate:
#   ... --truth-instance nearest --dense-cloud 2 --plane-window 10 --frustum-only --max-distance 3 \
#       --plane-distance 0.02 --height-band 0.35 --support-radius 0.15 --max-tilt 5 --plane-up world --box-to-plane \
#       --box-margin 0.1 --cluster euclidean --cluster-tolerance 0.02 --min-cluster-size 80 --nearest depth
# env BIN: the folder holding segment-cloud (default build/bin).
set -euo pipefail
if [ $# -lt 4 ]; then sed -n 2,17p "$0"; exit 2; fi
seq="$1"; work="$2"; out="$3"; frames="$4"; shift 4
bin="${BIN:-build/bin}"
mkdir -p "$out"
for f in $frames; do
  "$bin/segment-cloud" --method grabcut-sfm --sequence "$seq" --work "$work" --frame "$f" -o "$out/f$f.png" "$@"
done
python3 - "$out" $frames <<'PY'
import json, sys
out, frames = sys.argv[1], sys.argv[2:]
keys = ["grabcut_sfm", "kmeans2", "kmeans2_best_of_both", "grabcut_truth_box"]
rows = [json.load(open(f"{out}/f{f}.png.json")) for f in frames]
if any("f1" not in r for r in rows):
    sys.exit("no F1 in the summaries: give --truth-label or --truth-mask")
print("mean F1 over %d frames:" % len(rows))
for k in keys:
    v = [r["f1"][k] for r in rows if r["f1"][k] is not None]
    print("  %-22s %.3f  (min %.3f, max %.3f)" % (k, sum(v) / len(v), min(v), max(v)))
t = [r["seconds"]["total"] for r in rows]
print("  grabcut-sfm seconds per frame: mean %.2f (grabCut alone %.2f)" %
      (sum(t) / len(t), sum(r["seconds"]["grabcut"] for r in rows) / len(rows)))
PY
