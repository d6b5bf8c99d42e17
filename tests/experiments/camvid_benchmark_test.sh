#!/usr/bin/env bash
# experiments/camvid/benchmark.sh end to end on a small CamVid folder cut from ../shared/data/camvid:
# one 1 Hz train run (16 frames), val frames 0-11 as val and frames 12-21 as a test split, so the
# script must train on train + val and test on test; tiny forests (Kt = 1000, M = 2). Checks the
# summary's shape and ranges, then that a folder without frames.csv is one clear line and exit 2.
# Usage: camvid_benchmark_test.sh SOURCE_DIR BIN_DIR SHARED_DIR     (exit 77: no CamVid, skipped)
set -euo pipefail
src=$1 bin=$2 shared=$3
# shellcheck source=mini_camvid.sh
source "$(dirname "${BASH_SOURCE[0]}")/mini_camvid.sh"
mini_camvid "$shared"
{
  header_and_short_run
  awk -F, 'BEGIN { OFS = "," } $3 == "val" { n++; if (n <= 12) print; else if (n <= 22) { $3 = "test"; print } }' "$camvid/frames.csv"
} >"$mini/frames.csv"
[[ $(grep -c ',train,' "$mini/frames.csv") -eq 16 ]] || { echo "FAIL: the train run should have 16 frames"; exit 1; }

SMSEG_BIN="$bin" SMSEG_KT=1000 SMSEG_M=2 SMSEG_JOBS=2 bash "$src/experiments/camvid/benchmark.sh" "$mini" "$tmp/out" \
  >"$tmp/stdout.txt"
cat "$tmp/stdout.txt"
grep -q "training on train,val, testing on test" "$tmp/stdout.txt" || { echo "FAIL: splits not chosen from frames.csv"; exit 1; }
python3 - "$tmp/out/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
assert s["train"] == ["train", "val"] and s["test"] == "test", s
assert set(s["runs"]) == {"sm", "combined", "sm_six", "sm_dense", "sm_path", "sm_context", "combined_forest", "combined_smooth",
                          "combined_context", "combined_context_smooth", "combined_forest_m20",
                          "combined_smooth_m20"}, s["runs"].keys()
# The headline is evaluated at the cross-validation's class prior power; its twin without it at 0.
assert s["runs"]["combined"]["prior_power"] == 0.25 and s["runs"]["combined_smooth_m20"]["prior_power"] == 0, s["runs"]
assert s["runs"]["sm_context"]["train_seconds"] > s["runs"]["sm_six"]["train_seconds"], s["runs"]  # first forest + folds + second
assert s["runs"]["combined_context"]["train_seconds"] > s["runs"]["combined_forest"]["train_seconds"], s["runs"]
# SMSEG_M shrinks every forest, the headline's too; each run records the trees it used.
assert all(r["trees"] == 2 for r in s["runs"].values()), {n: r["trees"] for n, r in s["runs"].items()}
# SMSEG_KT likewise, the headline's Kt (60 000 by default) too; each run records its forest's.
assert all(r["kt"] == 1000 for r in s["runs"].values()), {n: r["kt"] for n, r in s["runs"].items()}
for name, r in s["runs"].items():
    for k in ("global_accuracy", "class_average_accuracy", "mean_iou"):
        assert 0.0 <= r[k] <= 1.0, (name, k, r[k])
    assert len(r["per_class"]) == 11, (name, r["per_class"].keys())
    assert all(0.0 <= c["accuracy"] <= 1.0 for c in r["per_class"].values()), name
    assert r["test_frames"] == 10, (name, r["test_frames"])
    assert r["train_seconds"] > 0 and r["train_peak_rss_mb"] > 10, (name, r)
for name in ("sm", "sm_path", "combined", "combined_smooth", "combined_context_smooth", "combined_smooth_m20"):  # smoothed
    assert s["runs"][name]["smooth_ms_per_frame"] > 0, name
for name in ("sm_six", "sm_dense", "sm_context", "combined_forest", "combined_context", "combined_forest_m20"):
    assert s["runs"][name]["smooth_ms_per_frame"] == 0, name
print("summary.json: ok")
PY
# The 15 Hz runs (val in training, the test split here) sweep 4 m baselines; the 1 Hz run the default.
python3 - "$tmp/out/work" <<'PY'
import glob, json, os, sys
found = glob.glob(os.path.join(sys.argv[1], "*", "*", "stacks.json"))
assert len(found) == 3, found
for stacks in found:
    features = json.load(open(stacks))["options"]["features"]
    fast = "0016E5_08190" not in stacks
    assert (features.get("sweep_baseline"), features.get("sweep_reach")) == ((4.0, 24) if fast else (None, None)), (stacks, features)
print("sweep baselines: ok")
PY
# The headline's forest reads the people detectors' channels and the HOG classes', from add-people's
# folders beside the work folders and add-hog-classes' beside those (a model learned on the training runs
# alone); the M = 7 appearance forest reads neither.
python3 - "$tmp/out" <<'PY'
import json, os, sys
out = sys.argv[1]
hog = ["fHgPole", "fHgSignSymbol", "fHgFence", "fHgPedestrian", "fHgBicyclist"]
assert json.load(open(os.path.join(out, "forests", "combined_m20.json")))["features"][-7:] == ["fHogD", "fHogI"] + hog
combined = json.load(open(os.path.join(out, "forests", "combined.json")))["features"]
assert "fHogD" not in combined and "fHgPole" not in combined, combined
model = json.load(open(os.path.join(out, "hog-classes.json")))
assert model["channels"] == [c[3:] for c in hog], model["channels"]
assert all("/work/train/" in f["work"] for f in model["provenance"]["work_folders"]), model["provenance"]
for side in ("train", "test"):
    for name in os.listdir(os.path.join(out, "work", side)):
        m = json.load(open(os.path.join(out, "people", side, name, "stacks.json")))
        assert m["features"][-2:] == ["fHogD", "fHogI"] and m["base"]["work"].endswith(f"work/{side}/{name}"), m["base"]
        h = json.load(open(os.path.join(out, "hog", side, name, "stacks.json")))
        assert h["features"][-5:] == hog and h["base"]["work"].endswith(f"people/{side}/{name}"), h["base"]
print("people detectors and HOG classes: ok")
PY

# Bad input: one line naming the file, exit 2, nothing half-made.
set +e
SMSEG_BIN="$bin" bash "$src/experiments/camvid/benchmark.sh" "$tmp" "$tmp/out2" 2>"$tmp/err.txt"
code=$?
set -e
[[ $code -eq 2 ]] || { echo "FAIL: exit $code for a folder without frames.csv"; exit 1; }
[[ $(wc -l <"$tmp/err.txt") -eq 1 ]] && grep -q "$tmp/frames.csv: missing" "$tmp/err.txt" ||
  { echo "FAIL: error was:"; cat "$tmp/err.txt"; exit 1; }
echo "bad input: ok"
