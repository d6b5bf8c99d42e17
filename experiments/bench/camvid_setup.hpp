#pragma once
// The CamVid-size benchmark cases' setup (bench_eval, bench_forest): the CamVid val run
// (SMSEG_SHARED_DIR/data/camvid, 101 frames of 480x360) imported and extracted, and a forest trained
// on it (Ks = 400, Kt = 20 000, M = 7, seed 1: ~2 700 nodes per tree), both cached in the build tree
// (SMSEG_BENCH_CACHE/camvid-val). The first run extracts (~2 minutes on 2 cores) and trains (~40 s);
// later runs read the cache. Without CamVid the cases are skipped with a message.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <benchmark/benchmark.h>

#include "smseg/sequence/camvid.hpp"
#include "smseg/stacks/extract.hpp"
#include "smseg/stacks/stack.hpp"
#include "smseg/forest/train.hpp"

namespace camvid_bench {

namespace fs = std::filesystem;
using namespace smseg;

inline const fs::path kCamVid = fs::path(SMSEG_SHARED_DIR) / "data" / "camvid";
inline const fs::path kCache = fs::path(SMSEG_BENCH_CACHE) / "camvid-val";
inline constexpr const char* kValRun = "0016E5_07959-08159";

/// The val run's work folder (feature stacks), extracted into the cache if it is not there yet.
inline fs::path val_work() {
  const fs::path work = kCache / "work";
  if (fs::exists(work / "stacks.json")) return work;
  sequence::CamvidImportOptions opt;
  opt.splits = {"val"};
  sequence::import_camvid(kCamVid, kCache / "sequences", opt);
  stacks::ExtractOptions ex;
  ex.progress = false;
  stacks::extract_features(sequence::load_sequence(kCache / "sequences" / kValRun), work, ex);
  return work;
}

/// The forest trained on every labelled frame of the val run (cached as forest.json).
inline forest::Forest val_forest() {
  const fs::path file = kCache / "forest.json";
  if (fs::exists(file)) return forest::load_forest(file);
  const stacks::StackSet set = stacks::open_stacks({val_work()}, stacks::FrameRange{}, true, true, {});
  forest::TrainParams p;
  p.K = 400;
  p.Kt = 20000;
  p.M = 7;
  const forest::Forest f = forest::train_forest(set.dataset, p);
  forest::save_forest(f, file);
  return f;
}

/// Why the CamVid cases cannot run, or nothing when they can.
inline std::optional<std::string> unavailable() {
  if (!fs::exists(kCamVid / "frames.csv")) return "CamVid not found at " + kCamVid.string();
  return std::nullopt;
}

/// Marks a CamVid case skipped, with the reason.
inline void skip(benchmark::State& state) {
  static const std::string why = unavailable().value_or("the CamVid setup is missing");
  state.SkipWithError(why.c_str());
}

}  // namespace camvid_bench
