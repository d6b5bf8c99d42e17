#!/usr/bin/env bash
# Peers on the same data, side by side in one run: our extremely randomized trees (forest-peers, which
# grows trees with libforest's grow_tree), scikit-learn's ExtraTreesClassifier and ranger's extratrees,
# all trained on one exported corpus of the synthetic corridor (K = 400 windows x 6 features = 2400
# candidate columns, 400 rows from the first 101 frames) and scored on held-out rows with the same
# columns drawn from frames 110: (Kt = 4000). See docs/peers.md.
#
# Usage: bash experiments/peers/run.sh [OUT]          (default OUT: out/peers)
# Environment (defaults in brackets):
#   BUILD [build]            build folder; the targets make-sequence extract-features train-forest
#                            forest-peers are built there if missing (BUILD_J [2] jobs)
#   FOREST_PEERS [BUILD/bin/forest-peers]  our trainer's binary (docs/peers.md, "At CamVid scale": today's
#                            forest-peers refuses CSVs over 256 MiB, and a 20000-row corpus is ~350 MB)
#   WORK  [OUT/work]         work folder of extract-features; made from a fresh corridor if missing
#   SEEDS [1,2,3,4,5]        forest seeds (every trainer runs once per seed on the same corpus)
#   CORPUS_SEEDS [1,2,3]     one corpus pair per seed (train-forest --seed), every trainer runs on each
#   K [400]  KT_TRAIN [K]  KT_HELDOUT [4000]  TRAIN_FRAMES [0:101]  HELDOUT_FRAMES [110:]
#                            (K windows x 6 features are the columns; KT_TRAIN / KT_HELDOUT the rows)
#   M [7]  N_MIN [5]  REPEAT [3] (timed fits per seed, median)  THREADS [1] (every trainer; 0 = all cores)
#   RANGER_MIN_NODE [N_MIN]  ranger's min.node.size (a node of <= that many rows is a leaf in ranger
#                            0.14, so N_MIN - 1 is the exact equivalent of our n_min)
#   SCORE [wehenkel-pavella] our split score (forest-peers --score): wehenkel-pavella | information-gain;
#                            a comma-separated list runs ours once per score (rows "ours (SCORE)")
#   KEEP_CSV [0]             1 keeps the corpus CSVs (about 10 MB and 100 MB per corpus seed)
# Needs: Debian python3-sklearn and r-cran-ranger (PYTHON: the interpreter to use [/usr/bin/python3]).
# Writes per corpus seed S OUT/corpus-S/{ours,sklearn,ranger,ranger_prob}.json, then OUT/machine.json,
# OUT/peers.json (the table, machine-readable) and OUT/peers.md (the table), and prints the table.
# Peak RSS per trainer (whole process, and during the fits): measured inside sklearn_peer.py and
# ranger_peer.R, and from outside for forest-peers (rss_watch.py; its fit figure needs >= 2 SEEDS).
# CamVid scale (docs/peers.md, "At CamVid scale"), e.g.:
#   WORK=build/bench-cache/camvid-val/work TRAIN_FRAMES=0:80 HELDOUT_FRAMES=80: KT_TRAIN=20000 \
#   KT_HELDOUT=20000 CORPUS_SEEDS=1 SEEDS=1,2 REPEAT=1 FOREST_PEERS=... bash experiments/peers/run.sh OUT
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
OUT="${1:-out/peers}"
BUILD="${BUILD:-build}"
WORK="${WORK:-$OUT/work}"
SEEDS="${SEEDS:-1,2,3,4,5}"
CORPUS_SEEDS="${CORPUS_SEEDS:-1,2,3}"
KEEP_CSV="${KEEP_CSV:-0}"
SCORE="${SCORE:-wehenkel-pavella}"
IFS=',' read -r -a scores <<<"$SCORE"
K="${K:-400}"
KT_TRAIN="${KT_TRAIN:-$K}"
KT_HELDOUT="${KT_HELDOUT:-4000}"
TRAIN_FRAMES="${TRAIN_FRAMES:-0:101}"
HELDOUT_FRAMES="${HELDOUT_FRAMES:-110:}"
M="${M:-7}"
N_MIN="${N_MIN:-5}"
REPEAT="${REPEAT:-3}"
THREADS="${THREADS:-1}"
RANGER_MIN_NODE="${RANGER_MIN_NODE:-$N_MIN}"

die() { echo "peers: error: $*" >&2; exit 1; }
# Debian's python3 (where python3-sklearn lives), unless PYTHON names another interpreter.
PYTHON="${PYTHON:-}"
if [[ -z "$PYTHON" ]]; then
  for p in /usr/bin/python3 python3; do
    if "$p" -c 'import sklearn' 2>/dev/null; then PYTHON="$p"; break; fi
  done
fi
[[ -n "$PYTHON" ]] || die "scikit-learn missing: apt-get install -y python3-sklearn"
Rscript -e 'suppressPackageStartupMessages(library(ranger))' 2>/dev/null || die "ranger missing: apt-get install -y r-cran-ranger"

mkdir -p "$OUT"
bin="$BUILD/bin"
FOREST_PEERS="${FOREST_PEERS:-$bin/forest-peers}"
need=()
for t in make-sequence extract-features train-forest forest-peers; do [[ -x "$bin/$t" ]] || need+=("$t"); done
if ((${#need[@]})); then
  echo "peers: building ${need[*]} in $BUILD" >&2
  [[ -f "$BUILD/CMakeCache.txt" ]] || cmake -S "$repo" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$BUILD" -j"${BUILD_J:-2}" --target "${need[@]}" >/dev/null
fi
if [[ ! -d "$WORK" ]]; then
  echo "peers: making the corridor sequence and its features in $WORK" >&2
  "$bin/make-sequence" --scene corridor -o "$OUT/corridor" -q
  "$bin/extract-features" "$OUT/corridor" -o "$WORK" -q
fi

# 2. The machine and its load, before the timed part.
load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
n_jobs="$THREADS"; [[ "$THREADS" == 0 ]] && n_jobs=-1
dirs=()
IFS=',' read -r -a corpus_seeds <<<"$CORPUS_SEEDS"
for cs in "${corpus_seeds[@]}"; do
  d="$OUT/corpus-$cs"
  mkdir -p "$d"
  dirs+=("$d")
  # 1. The corpora. -M 1 --corpus-tree 0: tree 0's windows depend only on (seed, tree 0), and windows
  #    are drawn before tests, so both exports share their candidate columns; checked on the headers.
  echo "peers: corpus seed $cs: exporting (K=$K; Kt=$KT_TRAIN, frames $TRAIN_FRAMES; Kt=$KT_HELDOUT, frames $HELDOUT_FRAMES)" >&2
  "$bin/train-forest" "$WORK" --train-frames "$TRAIN_FRAMES" -K "$K" --Kt "$KT_TRAIN" -M 1 --seed "$cs" \
    --export-corpus "$d/train.csv" --corpus-tree 0 -o "$d/corpus-train-forest.json" -q >/dev/null
  "$bin/train-forest" "$WORK" --train-frames "$HELDOUT_FRAMES" -K "$K" --Kt "$KT_HELDOUT" -M 1 --seed "$cs" \
    --export-corpus "$d/heldout.csv" --corpus-tree 0 -o "$d/corpus-heldout-forest.json" -q >/dev/null
  cmp -s <(head -n1 "$d/train.csv") <(head -n1 "$d/heldout.csv") ||
    die "$d/heldout.csv: header differs from $d/train.csv's (different candidate columns)"
  rows_train=$(($(wc -l <"$d/train.csv") - 1))
  rows_held=$(($(wc -l <"$d/heldout.csv") - 1))
  cols=$(head -n1 "$d/train.csv" | tr -cd ',' | wc -c)
  echo "peers: corpora share their $cols columns; $rows_train training rows, $rows_held held-out rows" >&2

  # 3. The trainers one after the other: same corpus, same seeds, same thread count.
  for sc in "${scores[@]}"; do
    # The first score writes ours.json (the row the speed-ups refer to), others ours-SCORE.json.
    o="$d/ours.json"; [[ "$sc" == "${scores[0]}" ]] || o="$d/ours-$sc.json"
    echo "peers: ours (forest-peers --score $sc)" >&2
    # rss_watch.py measures its RSS from outside (line-buffered stdout marks the seeds' fits).
    "$PYTHON" "$here/rss_watch.py" --merge-into "$o" -- stdbuf -oL \
      "$FOREST_PEERS" "$d/train.csv" "$d/heldout.csv" -M "$M" --n-min "$N_MIN" --seeds "$SEEDS" \
      --repeat "$REPEAT" --threads "$THREADS" --score "$sc" -o "$o" >&2
  done
  echo "peers: scikit-learn ExtraTreesClassifier" >&2
  "$PYTHON" "$here/sklearn_peer.py" "$d/train.csv" "$d/heldout.csv" -M "$M" --min-samples-split "$N_MIN" \
    --seeds "$SEEDS" --repeat "$REPEAT" --n-jobs "$n_jobs" -o "$d/sklearn.json" >&2
  echo "peers: ranger extratrees (classification forest)" >&2
  Rscript "$here/ranger_peer.R" "$d/train.csv" "$d/heldout.csv" --trees "$M" --min-node-size "$RANGER_MIN_NODE" \
    --seeds "$SEEDS" --repeat "$REPEAT" --threads "$THREADS" -o "$d/ranger.json" >&2
  echo "peers: ranger extratrees (probability forest)" >&2
  Rscript "$here/ranger_peer.R" "$d/train.csv" "$d/heldout.csv" --trees "$M" --min-node-size "$RANGER_MIN_NODE" \
    --seeds "$SEEDS" --repeat "$REPEAT" --threads "$THREADS" --probability -o "$d/ranger_prob.json" >&2
  [[ "$KEEP_CSV" == 1 ]] || rm -f "$d/train.csv" "$d/heldout.csv"
done

load_after="$(cut -d' ' -f1-3 /proc/loadavg)"
cpu="$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')"
"$PYTHON" - "$OUT/machine.json" "$cpu" "$(nproc)" "$load_before" "$load_after" "$THREADS" <<'PY'
import json, sys, platform, datetime
out, cpu, nproc, before, after, threads = sys.argv[1:]
json.dump({"cpu": cpu, "cores": int(nproc), "threads_per_trainer": int(threads),
           "load_before": [float(x) for x in before.split()], "load_after": [float(x) for x in after.split()],
           "kernel": platform.release(), "date": datetime.datetime.now().isoformat(timespec="seconds")},
          open(out, "w"), indent=1)
PY
echo "peers: machine: $cpu, $(nproc) cores; load average before $load_before, after $load_after" >&2
"$PYTHON" "$here/summarise.py" "${dirs[@]}" --machine "$OUT/machine.json" -o "$OUT/peers.json" --markdown "$OUT/peers.md"
for sc in "${scores[@]:1}"; do  # the same table with ours grown with each further score
  echo
  "$PYTHON" "$here/summarise.py" "${dirs[@]}" --ours "ours-$sc" --machine "$OUT/machine.json" \
    -o "$OUT/peers-$sc.json" --markdown "$OUT/peers-$sc.md"
done
