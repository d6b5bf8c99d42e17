#!/usr/bin/env bash
# One-command CamVid benchmark (docs/camvid.md, "Benchmark").
# Usage: experiments/camvid/benchmark.sh CAMVID_DIR OUT
#   CAMVID_DIR  a CamVid folder in the layout of ../shared/data/camvid: frames.csv, classes.csv and the
#               image / label folders it names (train, trainannot, val, valannot, and optionally test,
#               testannot). With test rows in frames.csv it trains on train + val and tests on test;
#               without, it trains on train and tests on val.
#   OUT         output folder: sequences/, work/, people/, hog-classes.json, hog/, forests/, context/, eval/,
#               measure/ and summary.json
# Runs, all with Ks = 400, Kt = 20000, M = 7 (the headline appearance forest M = 20, Kt = 60000, --lightness 0.45), seed 1 and every
# other option at its default. The two headline runs are the ones the leave-one-run-out cross-validation
# chose (docs/camvid.md, "Choosing by cross-validation", cross-validate.sh):
#   sm               structure and motion (no image appearance): the six point features fH fC fOx fOy fD fR
#                    and five of the six dense geometry channels of --dense (a plane sweep over the SfM poses:
#                    fZV fZI fZH fZU fZE, not fZC: see sm_path; runs filmed faster than 2 Hz sweep 4 m
#                    baselines, like the 1 Hz runs' one second), --balance sqrt, evaluated with --smooth graphcut
#                    --smooth-contrast off --lambda 3 (plain Potts: the smoothing reads nothing of the image)
#   combined         S+M + appearance: the six, the nine image channels fL fA fB fG0..fG3 fRow fCol, the two
#                    people-detector channels fHogD fHogI of add-people (OUT/people/), the five HOG class
#                    channels fHgPole fHgSignSymbol fHgFence fHgPedestrian fHgBicyclist (learn-hog-classes on
#                    the training runs, OUT/hog-classes.json; add-hog-classes, OUT/hog/) and the texton tests,
#                    --balance sqrt, M = 20, Kt = 60000, --lightness 0.45 (every frame brought to one mean
#                    lightness), evaluated with --smooth graphcut --prior-power 0.25 (each class's posterior
#                    divided by its training prior to the power 0.25)
# and one row per lever on its own (the ablation):
#   sm_six           the six point features only
#   sm_dense         the six and the five dense geometry channels (no balance, no smoothing)
#   sm_path          sm with the sixth dense channel, fZC (each pixel's distance to the camera path)
#   sm_context       auto-context on sm_six: add-context writes the sm_six forest's class posteriors as 11
#                    more channels (out of 4 folds on the training runs, from the forest on the test runs),
#                    and a second forest, with sm_six's options, trains on the six features and them
#   combined_forest  the S+M + appearance forest with M = 7 alone (no auto-context, no smoothing)
#   combined_smooth  that forest evaluated with --smooth graphcut
#   combined_context auto-context on it (its features, textons and --balance sqrt), not smoothed
#   combined_context_smooth  the same, smoothed (the headline before the cross-validation)
#   combined_forest_m20      the headline's forest (M = 20, Kt = 60000, --lightness 0.45, people, HOG classes),
#                            not smoothed
#   combined_smooth_m20      that forest smoothed, without the prior correction (the headline at P = 0)
# Prints one table (global, class-average, mean IoU, per class, training time, peak RSS) and writes
# OUT/summary.json: {"runs": {"sm": {...}, "combined": {...}, "sm_six": {...}, "sm_dense": {...}, "sm_path": {...},
# "sm_context": {...},
# "combined_forest": {...}, "combined_smooth": {...}, "combined_context": {...}, "combined_context_smooth": {...},
# "combined_forest_m20": {...}, "combined_smooth_m20": {...}}}, each with global_accuracy, class_average_accuracy, mean_iou, per_class, trees, kt,
# train_seconds, train_peak_rss_mb (auto-context runs: the first forest's training, then the fold
# forests', the context channels' and the second forest's).
# Training frames are extracted with --require-label (the training filters); test frames without it,
# so no test label reaches the test features.
# Environment: SMSEG_BIN (the tools; default build/bin, built with CMake when a tool is missing there),
# SMSEG_KT, SMSEG_M (smaller values for a quick check), SMSEG_JOBS (extractions at once; default: cores),
# SMSEG_CROSS_VALIDATION (a cross-validate.sh record, OUT/cross-validation.json: each run's fold means are
# printed beside its figures and kept in summary.json as "fold_means").
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"

fail() { echo "benchmark.sh: $*" >&2; exit 2; }
[[ $# -eq 2 ]] || fail "usage: experiments/camvid/benchmark.sh CAMVID_DIR OUT"
camvid="$(cd "$1" 2>/dev/null && pwd)" || fail "$1: no such folder"
[[ -f "$camvid/frames.csv" ]] || fail "$camvid/frames.csv: missing (not a CamVid folder in the layout of ../shared/data/camvid)"
[[ -f "$camvid/classes.csv" ]] || fail "$camvid/classes.csv: missing"
mkdir -p "$2" || fail "$2: cannot be created"
out="$(cd "$2" && pwd)"
kt="${SMSEG_KT:-20000}"
trees="${SMSEG_M:-7}"
# The headline appearance forest's trees: 20, chosen by the cross-validation (M = 7 -> 20: +2.7 global,
# +2.4 class average on the fold means, docs/camvid.md); SMSEG_M, when set, shrinks it as every forest.
headline_trees="${SMSEG_M:-20}"
# ... and its tests per tree: 60 000, chosen by the cross-validation (Kt = 20 000 -> 60 000 at M = 20,
# smoothed: +0.5 global, +1.1 class average, +1.0 mIoU on the fold means, class average higher on every
# fold; docs/camvid.md); SMSEG_KT, when set, is every forest's.
headline_kt="${SMSEG_KT:-60000}"
# The headline's class prior power: the point of the cross-validation's curve with the highest fold-mean
# mean IoU (the headline's forest, P = 0 / 0.25 / 0.5 / 0.75 / 1: 42.2 / 42.5 / 41.8 / 40.5 / 38.8;
# docs/camvid.md, "Class prior correction"), which trades 1.0 point of global accuracy for 2.8 of class
# average.
headline_prior_power=0.25
# ... and every frame of its forest brought to mean lightness fL = 0.45 (train-forest --lightness: the
# exposure map of the Lab and gradient channels, in training and evaluation alike; about the middle of the
# daylight runs' frame means, 0.34-0.54, the dusk run's 0.23), chosen by the cross-validation (+1.7 global,
# +1.8 class average, +1.5 mIoU on the fold means at P = 0.25, nearly all of it on the dusk run;
# docs/camvid.md, "Lightness normalisation").
headline_lightness=0.45
# ... and the two people-detector channels of add-people (fHogD, fHogI: OpenCV's pretrained HOG people
# detectors, Ladicky et al.'s detector potentials), chosen by the cross-validation (docs/camvid.md,
# "People detectors"); and the five HOG class channels (a softmax regression of the HOG window around each
# pixel, learned on the training runs: docs/camvid.md, "HOG classes"), chosen by the cross-validation. 22
# channels at Kt = 60 000 need more than the default 2 GB budget.
headline_memory_mb=4000
hog_channels=fHgPole,fHgSignSymbol,fHgFence,fHgPedestrian,fHgBicyclist
jobs="${SMSEG_JOBS:-$(nproc)}"
tools=(import-camvid extract-features train-forest eval-forest add-context add-people learn-hog-classes add-hog-classes)

# The tools: SMSEG_BIN as given, or build/bin (built when a tool is missing).
if [[ -n "${SMSEG_BIN:-}" ]]; then
  bin="$(cd "$SMSEG_BIN" 2>/dev/null && pwd)" || fail "SMSEG_BIN=$SMSEG_BIN: no such folder"
  for t in "${tools[@]}"; do [[ -x "$bin/$t" ]] || fail "$bin/$t: missing (SMSEG_BIN must hold ${tools[*]})"; done
else
  bin="$here/build/bin"
  missing=0
  for t in "${tools[@]}"; do [[ -x "$bin/$t" ]] || missing=1; done
  if ((missing)); then
    echo "== building ${tools[*]} into $here/build" >&2
    bash "$here/.ci/install-deps.sh"
    cmake -S "$here" -B "$here/build" -DCMAKE_BUILD_TYPE=Release >/dev/null
    cmake --build "$here/build" -j"$(nproc)" --target "${tools[@]}" >/dev/null
  fi
fi
summary_py="$here/experiments/camvid/benchmark_summary.py"

# Which splits train and which one tests.
if awk -F, 'NR > 1 && $3 == "test" { found = 1 } END { exit !found }' "$camvid/frames.csv"; then
  train_splits=train,val test_split=test
else
  train_splits=train test_split=val
fi
echo "== CamVid $camvid: training on $train_splits, testing on $test_split (Kt = $kt, M = $trees)"

echo "== 1/5 import-camvid"
rm -rf "$out/sequences"
"$bin/import-camvid" "$camvid" --split "$train_splits" -o "$out/sequences/train" >/dev/null
"$bin/import-camvid" "$camvid" --split "$test_split" -o "$out/sequences/test" >/dev/null

echo "== 2/5 extract-features --appearance --dense ($jobs at once; resumes what is on disk)"
extract() {  # SIDE SEQUENCE_FOLDER [extra options]
  local side=$1 seq=$2
  shift 2
  local name
  name="$(basename "$seq")"
  mkdir -p "$out/work/$side" "$out/logs"
  if ! "$bin/extract-features" "$seq" -o "$out/work/$side/$name" --appearance --dense -q "$@" \
      >"$out/logs/extract-$side-$name.txt" 2>&1; then
    cat "$out/logs/extract-$side-$name.txt" >&2
    return 1
  fi
}
export -f extract
export bin out
# The plane sweep of a run filmed faster than 2 Hz (val, CamSeq01 at 15 Hz) reads neighbours 4 m away
# (within 24 frames) instead of the nearest 0.5 m away, so that its dense depth is measured as the 1 Hz
# runs' is, one second (2.8 m median) apart: on val S+M 59.1 / 32.7 -> 61.8 / 33.4 (docs/camvid.md,
# "A plane sweep at the training runs' baseline").
sweep_options() {  # SEQUENCE_FOLDER: extract-features options for its plane sweep
  python3 "$here/experiments/camvid/sweep_options.py" "$1"
}
frame_count() {  # SEQUENCE_FOLDER
  python3 -c 'import json, sys; print(len(json.load(open(sys.argv[1] + "/sequence.json"))["frames"]))' "$1"
}
# One line per extraction, without trailing blanks (xargs -L joins a line ending in one to the next), the
# longest runs first so that the short ones fill in at the end. Each run may use every core (its plane
# sweep is parallel over frames): when the other runs are done, the last one's frames take them all.
{
  for s in "$out"/sequences/train/*/; do echo "$(frame_count "$s")" train "${s%/}" --require-label $(sweep_options "$s"); done
  for s in "$out"/sequences/test/*/; do echo "$(frame_count "$s")" test "${s%/}" $(sweep_options "$s"); done
} | sort -k1,1nr -s | cut -d' ' -f2- \
  | xargs -P "$jobs" -L 1 bash -c 'extract "$@"' _ || fail "extract-features failed (see $out/logs/)"
works_of() {  # SIDE: the work folders of this run's sequences of that side
  local s
  for s in "$out"/sequences/"$1"/*/; do printf '%s\n' "$out/work/$1/$(basename "$s")"; done
}
mapfile -t train_works < <(works_of train)
mapfile -t test_works < <(works_of test)
under() {  # FOLDER WORK...: FOLDER/<name of each WORK>, one a line (add-people's, add-hog-classes' and add-context's
  # output folders)
  local folder=$1 w
  shift
  for w in "$@"; do printf '%s\n' "$folder/$(basename "$w")"; done
}
# The headline's folders: the work folders with the people detectors' two channels.
"$bin/add-people" "${train_works[@]}" -q -o "$out/people/train" >/dev/null
"$bin/add-people" "${test_works[@]}" -q -o "$out/people/test" >/dev/null
mapfile -t train_people < <(under "$out/people/train" "${train_works[@]}")
mapfile -t test_people < <(under "$out/people/test" "${test_works[@]}")
# ... and then the HOG class channels, of a model learned on the training runs only.
"$bin/learn-hog-classes" "${train_works[@]}" -q -o "$out/hog-classes.json" >/dev/null
"$bin/add-hog-classes" "$out/hog-classes.json" "${train_people[@]}" -q -o "$out/hog/train" >/dev/null
"$bin/add-hog-classes" "$out/hog-classes.json" "${test_people[@]}" -q -o "$out/hog/test" >/dev/null
mapfile -t train_headline < <(under "$out/hog/train" "${train_works[@]}")
mapfile -t test_headline < <(under "$out/hog/test" "${test_works[@]}")

echo "== 3/5 train-forest: sm (six S+M features + dense geometry, --balance sqrt), sm_six (the six), sm_dense (six + dense), sm_path (sm + fZC), combined (+ appearance channels and textons, --balance sqrt; M = 7 and the headline's M = $headline_trees, Kt = $headline_kt, --lightness $headline_lightness, + add-people's fHogD fHogI and the HOG classes)"
mkdir -p "$out/forests" "$out/measure"
common=(-K 400 --Kt "$kt" -M "$trees" --seed 1 -q)
headline=(-K 400 --Kt "$headline_kt" -M "$headline_trees" --lightness "$headline_lightness" --memory-mb "$headline_memory_mb"
  --seed 1 -q)
six=fH,fC,fOx,fOy,fD,fR
dense=fZV,fZI,fZH,fZU,fZE
appearance=fL,fA,fB,fG0,fG1,fG2,fG3,fRow,fCol
python3 "$summary_py" measure "$out/measure/sm.json" -- \
  "$bin/train-forest" "${train_works[@]}" --features $six,$dense --balance sqrt "${common[@]}" -o "$out/forests/sm.json"
python3 "$summary_py" measure "$out/measure/sm_six.json" -- \
  "$bin/train-forest" "${train_works[@]}" --features $six "${common[@]}" -o "$out/forests/sm_six.json"
python3 "$summary_py" measure "$out/measure/sm_dense.json" -- \
  "$bin/train-forest" "${train_works[@]}" --features $six,$dense "${common[@]}" -o "$out/forests/sm_dense.json"
python3 "$summary_py" measure "$out/measure/sm_path.json" -- \
  "$bin/train-forest" "${train_works[@]}" --features $six,$dense,fZC --balance sqrt "${common[@]}" -o "$out/forests/sm_path.json"
python3 "$summary_py" measure "$out/measure/combined.json" -- \
  "$bin/train-forest" "${train_works[@]}" --features $six,$appearance --textons --balance sqrt "${common[@]}" \
  -o "$out/forests/combined.json"
python3 "$summary_py" measure "$out/measure/combined_m20.json" -- \
  "$bin/train-forest" "${train_headline[@]}" --features $six,$appearance,fHogD,fHogI,$hog_channels --textons --balance sqrt \
  "${headline[@]}" -o "$out/forests/combined_m20.json"

echo "== 4/5 auto-context: the sm_six and combined forests' posteriors (out of 4 folds on the training runs), second forests"
context() {  # FIRST NAME [train-forest options of the second forest...]: OUT/context/FIRST-{train,test},
  # OUT/forests/NAME.json, OUT/eval/NAME
  local first=$1 name=$2
  shift 2
  local ctx_train ctx_test
  mapfile -t ctx_train < <(under "$out/context/$first-train" "${train_works[@]}")
  mapfile -t ctx_test < <(under "$out/context/$first-test" "${test_works[@]}")
  python3 "$summary_py" measure "$out/measure/$name.json" -- \
    "$bin/add-context" "$out/forests/$first.json" "${train_works[@]}" --folds 4 -q -o "$out/context/$first-train" \
    --then "$bin/train-forest" "${ctx_train[@]}" "$@" "${common[@]}" -o "$out/forests/$name.json"
  "$bin/add-context" "$out/forests/$first.json" "${test_works[@]}" -q -o "$out/context/$first-test" >/dev/null
  "$bin/eval-forest" "$out/forests/$name.json" "${ctx_test[@]}" --no-pictures -q -o "$out/eval/$name"
}
context sm_six sm_context
context combined combined_context --textons --balance sqrt
mapfile -t combined_context_test < <(under "$out/context/combined-test" "${test_works[@]}")

echo "== 5/5 eval-forest on $test_split"
"$bin/eval-forest" "$out/forests/sm.json" "${test_works[@]}" --smooth graphcut --smooth-contrast off --lambda 3 \
  --no-pictures -q -o "$out/eval/sm"
"$bin/eval-forest" "$out/forests/sm_path.json" "${test_works[@]}" --smooth graphcut --smooth-contrast off --lambda 3 \
  --no-pictures -q -o "$out/eval/sm_path"
"$bin/eval-forest" "$out/forests/sm_six.json" "${test_works[@]}" --no-pictures -q -o "$out/eval/sm_six"
"$bin/eval-forest" "$out/forests/sm_dense.json" "${test_works[@]}" --no-pictures -q -o "$out/eval/sm_dense"
"$bin/eval-forest" "$out/forests/combined.json" "${test_works[@]}" --no-pictures -q -o "$out/eval/combined_forest"
"$bin/eval-forest" "$out/forests/combined.json" "${test_works[@]}" --smooth graphcut --no-pictures -q \
  -o "$out/eval/combined_smooth"
"$bin/eval-forest" "$out/forests/combined_context.json" "${combined_context_test[@]}" --smooth graphcut --no-pictures \
  -q -o "$out/eval/combined_context_smooth"
"$bin/eval-forest" "$out/forests/combined_m20.json" "${test_headline[@]}" --no-pictures -q -o "$out/eval/combined_forest_m20"
"$bin/eval-forest" "$out/forests/combined_m20.json" "${test_headline[@]}" --smooth graphcut \
  --prior-power "$headline_prior_power" --no-pictures -q \
  -o "$out/eval/combined"
"$bin/eval-forest" "$out/forests/combined_m20.json" "${test_headline[@]}" --smooth graphcut --no-pictures -q \
  -o "$out/eval/combined_smooth_m20"

cv=()
[[ -n "${SMSEG_CROSS_VALIDATION:-}" ]] && cv=(--cross-validation "$SMSEG_CROSS_VALIDATION")
python3 "$summary_py" summary "$out" --train "$train_splits" --test "$test_split" --kt "$kt" --trees "$trees" "${cv[@]}"
