// Same seed, same bytes, whatever the thread count (issue 19, part 4): train-forest at 1, 2 and 8
// threads writes the same forest, and eval-forest at 1, 2 and 8 threads the same results.json and the
// same pictures, timing fields aside (tests/support/without_timing.hpp). The tools really start 8
// threads on a 2-core machine (smseg/common/threads.hpp), so scheduling differs between the runs. On a
// synthetic corridor (stereo) and on CamVid's val sequence (monocular SfM, 480x360, real video).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "run_tool.hpp"
#include "smseg/common/io.hpp"
#include "temp_dir.hpp"
#include "without_timing.hpp"

namespace fs = std::filesystem;

namespace {

using smseg::test::Outcome;
using smseg::test::run;
using smseg::test::tool;

const std::vector<std::string> kThreadCounts = {"1", "2", "8"};

/// Every file under `dir`, as paths relative to it, sorted.
std::vector<fs::path> files_under(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) out.push_back(fs::relative(e.path(), dir));
  std::sort(out.begin(), out.end());
  return out;
}

/// Trains with `train_args` and evaluates with `eval_args` at every thread count into `dir`, then
/// holds every run against the one-thread run: forests, results.json and every picture.
void expect_same_whatever_the_threads(const fs::path& dir, const std::string& work, const std::string& train_args,
                                      const std::string& eval_args) {
  for (const std::string& t : kThreadCounts) {
    const std::string forest = (dir / ("forest-" + t + ".json")).string();
    Outcome r = run(tool("train-forest") + " -q --threads " + t + " " + work + " " + train_args + " -o " + forest);
    ASSERT_EQ(r.status, 0) << r.out;
    // Every evaluation uses the one-thread forest, so that only eval-forest's threads differ.
    r = run(tool("eval-forest") + " -q --threads " + t + " " + (dir / "forest-1.json").string() + " " + work + " " +
            eval_args + " -o " + (dir / ("eval-" + t)).string());
    ASSERT_EQ(r.status, 0) << r.out;
  }
  const auto forest_1 = smseg::test::without_timing(smseg::read_json(dir / "forest-1.json"));
  const auto results_1 = smseg::test::without_timing(smseg::read_json(dir / "eval-1" / "results.json"));
  const std::vector<fs::path> pictures = files_under(dir / "eval-1" / "frames");
  ASSERT_FALSE(pictures.empty());
  for (const std::string& t : kThreadCounts) {
    SCOPED_TRACE("--threads " + t);
    EXPECT_EQ(smseg::test::without_timing(smseg::read_json(dir / ("forest-" + t + ".json"))), forest_1);
    EXPECT_EQ(smseg::test::without_timing(smseg::read_json(dir / ("eval-" + t) / "results.json")), results_1);
    ASSERT_EQ(files_under(dir / ("eval-" + t) / "frames"), pictures);
    for (const fs::path& p : pictures)
      EXPECT_EQ(smseg::read_file(dir / ("eval-" + t) / "frames" / p), smseg::read_file(dir / "eval-1" / "frames" / p))
          << p;
  }
}

}  // namespace

TEST(Determinism, CorridorForestAndResultsWhateverTheThreadCount) {
  const fs::path dir = smseg::test::temp_dir("determinism_corridor");
  const fs::path seq = dir / "corridor", work = dir / "work";
  Outcome r = run(tool("make-sequence") + " --scene corridor --seed 7 --frames 60 --size 160x120 -q -o " + seq.string());
  ASSERT_EQ(r.status, 0) << r.out;
  r = run(tool("extract-features") + " -q " + seq.string() + " -o " + work.string());
  ASSERT_EQ(r.status, 0) << r.out;
  // Grid voting: its random voters are drawn per cell, the cells labelled in parallel.
  expect_same_whatever_the_threads(dir, work.string(), "--train-frames 0:31 -K 300 -M 8 --seed 11",
                                   "--test-frames 31: --grid 8 --votes 5 --seed 3");
  fs::remove_all(dir);
}

TEST(Determinism, CamVidValForestAndResultsWhateverTheThreadCount) {
  const fs::path camvid = fs::path(SMSEG_SHARED_DIR) / "data" / "camvid";
  if (!fs::exists(camvid / "frames.csv")) GTEST_SKIP() << "CamVid is not at " << camvid;
  const fs::path dir = smseg::test::temp_dir("determinism_camvid");
  Outcome r = run(tool("import-camvid") + " " + camvid.string() + " --split val -o " + (dir / "seq").string());
  ASSERT_EQ(r.status, 0) << r.out;
  // CamSeq01: the 101 frames of val, one run at 15 Hz; stacks of the first 40 (SfM sees all of them).
  std::string seq;
  for (const auto& e : fs::directory_iterator(dir / "seq"))
    if (fs::exists(e.path() / "sequence.json")) seq = e.path().string();
  ASSERT_FALSE(seq.empty()) << r.out;
  const fs::path work = dir / "work";
  r = run(tool("extract-features") + " -q --frames 0:40 " + seq + " -o " + work.string());
  ASSERT_EQ(r.status, 0) << r.out;
  // Graph-cut smoothing of the per-pixel output on real frames.
  expect_same_whatever_the_threads(dir, work.string(), "--train-frames 0:30 -K 2000 -M 6 --seed 5",
                                   "--test-frames 30:40 --smooth graphcut --lambda 1");
  fs::remove_all(dir);
}
