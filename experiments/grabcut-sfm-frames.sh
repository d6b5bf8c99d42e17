#!/usr/bin/env bash
# GrabCutSFM (paper 001) and its two baselines (2D k-means on colour, GrabCut on the truth's box) on
# several frames, and the mean F1 of each: runs `segment-cloud --method grabcut-sfm` per frame and
# averages the summaries' F1.
#
# Frames of one work folder:
#   bash experiments/grabcut-sfm-frames.sh SEQ WORK OUT "F1 F2 ..." [segment-cloud options...]
#   e.g. the CamVid val run of docs/graphcuts.md (the 10 labelled frames with the largest car):
#   bash experiments/grabcut-sfm-frames.sh ../shared/camvid-seq/0016E5_07959-08159 work/0016E5_07959-08159 \
#       out/gcsfm "45 43 44 42 46 41 4 5 3 47" --truth-label Car
#
# Scenes: synthetic tabletop videos (make-sequence --scene tabletop), every labelled frame, the truth the
# nearest object, one table of mean F1 per scene and over all, and seconds per frame:
#   bash experiments/grabcut-sfm-frames.sh scenes OUT "SCENE ..." [segment-cloud options...]
#   SCENE = SEED or SEED@HEIGHT (make-sequence --seed SEED [--camera-height HEIGHT]); the sequences and
#   work folders (extract-features, default options) are made under OUT/scenes/ unless already there.
#   e.g. bash experiments/grabcut-sfm-frames.sh scenes out/gcsfm-scenes "1 2 3 4 5 6 1@1.4"
# The defaults need no option (docs/graphcuts.md); any segment-cloud option given is passed on to every run.
# env BIN: the folder holding segment-cloud, make-sequence and extract-features (default build/bin).
set -euo pipefail
usage() { sed -n 2,20p "$0"; exit 2; }
bin="${BIN:-build/bin}"

# run_frames SEQ WORK OUT "FRAMES" [options...]: one segment-cloud run per frame.
run_frames() {
  local seq="$1" work="$2" out="$3" frames="$4"; shift 4
  mkdir -p "$out"
  for f in $frames; do
    "$bin/segment-cloud" --method grabcut-sfm --sequence "$seq" --work "$work" --frame "$f" -o "$out/f$f.png" "$@" \
      > "$out/f$f.log" 2>&1 || echo "frame $f: $(tail -1 "$out/f$f.log")" >&2
  done
}

# summarise NAME=OUT:FRAMES ...: mean F1 per method and seconds per frame, one row per argument and
# one over all. A frame whose run failed counts as F1 0 for GrabCutSFM (it gave no mask).
summarise() {
  /usr/bin/python3 - "$@" <<'PY'
import json, os, sys
keys = ["grabcut_sfm", "kmeans2", "kmeans2_best_of_both", "grabcut_truth_box"]
print("| scene | frames | GrabCutSFM | 2D k-means | k-means, best of both (oracle) | GrabCut on the truth box | "
      "GrabCutSFM frames >= 0.9 / at 0 | failed runs | s / frame: cloud + GrabCutSFM |")
print("|---|---|---|---|---|---|---|---|---|")
total = {k: [] for k in keys}; total_t = []; total_failed = 0
for arg in sys.argv[1:]:
    name, rest = arg.split("=", 1)
    out, frames = rest.split(":", 1)
    vals = {k: [] for k in keys}; t = []; failed = 0
    for f in frames.split():
        path = f"{out}/f{f}.png.json"
        if not os.path.exists(path):
            failed += 1
            vals["grabcut_sfm"].append(0.0)
            continue
        r = json.load(open(path))
        if "f1" not in r:
            sys.exit(f"{path}: no F1 in the summary: give --truth-label, --truth-instance or --truth-mask")
        for k in keys:
            if r["f1"][k] is not None: vals[k].append(r["f1"][k])
        t.append(r["seconds"].get("cloud", 0) + r["seconds"]["total"])
    for k in keys: total[k] += vals[k]
    total_t += t; total_failed += failed
    mean = lambda v: "%.3f" % (sum(v) / len(v)) if v else "n/a"
    g = vals["grabcut_sfm"]
    print("| %s | %d | %s | %s | %s | %s | %d / %d | %d | %s |" % (
        name, len(g), mean(g), mean(vals["kmeans2"]), mean(vals["kmeans2_best_of_both"]),
        mean(vals["grabcut_truth_box"]), sum(v >= 0.9 for v in g), sum(v == 0 for v in g), failed,
        "%.2f" % (sum(t) / len(t)) if t else "n/a"))
if len(sys.argv) > 2:
    mean = lambda v: "%.3f" % (sum(v) / len(v)) if v else "n/a"
    g = total["grabcut_sfm"]
    print("| **all** | %d | **%s** | %s | %s | %s | %d / %d | %d | %s |" % (
        len(g), mean(g), mean(total["kmeans2"]), mean(total["kmeans2_best_of_both"]),
        mean(total["grabcut_truth_box"]), sum(v >= 0.9 for v in g), sum(v == 0 for v in g), total_failed,
        "%.2f" % (sum(total_t) / len(total_t)) if total_t else "n/a"))
PY
}

# labelled_frames SEQ: the frames with an instance image.
labelled_frames() {
  /usr/bin/python3 -c '
import json, sys
frames = json.load(open(sys.argv[1] + "/sequence.json"))["frames"]
print(" ".join(str(i) for i, f in enumerate(frames) if "instances" in f))' "$1"
}

if [ "${1:-}" = scenes ]; then
  [ $# -ge 3 ] || usage
  out="$2"; scenes="$3"; shift 3
  rows=()
  for scene in $scenes; do
    seed="${scene%@*}"; height=""; [ "$scene" != "$seed" ] && height="${scene#*@}"
    dir="$out/scenes/tabletop-$seed${height:+-h$height}"
    if [ ! -f "$dir/seq/sequence.json" ]; then
      "$bin/make-sequence" --scene tabletop --seed "$seed" ${height:+--camera-height "$height"} -q -o "$dir/seq"
    fi
    [ -f "$dir/work/tracks.json" ] || "$bin/extract-features" -q "$dir/seq" -o "$dir/work"
    frames="$(labelled_frames "$dir/seq")"
    run_frames "$dir/seq" "$dir/work" "$dir/gcsfm" "$frames" --truth-instance nearest "$@"
    rows+=("$scene=$dir/gcsfm:$frames")
  done
  summarise "${rows[@]}" | tee "$out/scenes.md"
  exit 0
fi

[ $# -ge 4 ] || usage
seq="$1"; work="$2"; out="$3"; frames="$4"; shift 4
run_frames "$seq" "$work" "$out" "$frames" "$@"
summarise "frames=$out:$frames"
