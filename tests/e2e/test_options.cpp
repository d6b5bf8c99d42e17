// Options as promises (issue 19, part 5): an absurd value gets one clear line naming the option and a
// non-zero exit (2: bad usage, found by the parser or before any work; 1: a run that cannot be done with
// this data, e.g. a frame range outside the work folder or a memory budget one tree does not fit in),
// never a hang, a crash or an out-of-memory kill. The list is docs/reliability.md's "Options" table.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "run_tool.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;

namespace {

using smseg::test::Outcome;
using smseg::test::run;
using smseg::test::tool;

struct Absurd {
  std::string command;  ///< after the tool's path; {W} = a work folder, {S} = its sequence, {F} = a forest, {O} = an output
  int status;           ///< the exit status expected
  std::string named;    ///< the option (or file) the line must name
};

void expect_one_line(const Absurd& a, const Outcome& r);

class Options : public ::testing::Test {
 protected:
  static fs::path dir;
  static void SetUpTestSuite() {
    dir = smseg::test::temp_dir("options");
    Outcome r = run(tool("make-sequence") + " --scene corridor --frames 24 --size 160x120 -q -o " + (dir / "seq").string());
    ASSERT_EQ(r.status, 0) << r.out;
    r = run(tool("extract-features") + " -q " + (dir / "seq").string() + " -o " + (dir / "work").string());
    ASSERT_EQ(r.status, 0) << r.out;
    r = run(tool("train-forest") + " -q " + (dir / "work").string() + " --train-frames 0:11 -K 100 -M 2 -o " +
            (dir / "forest.json").string());
    ASSERT_EQ(r.status, 0) << r.out;
  }
  static void TearDownTestSuite() { fs::remove_all(dir); }

  /// Runs each (tool, case): one line naming the option, the expected status, nothing written.
  static void expect_each_refused(const std::vector<std::pair<std::string, Absurd>>& cases) {
    for (const auto& [name, a] : cases) {
      const Outcome r = run("timeout 120 " + tool(name) + " -q " + expand(a.command));
      expect_one_line(a, r);
      EXPECT_FALSE(fs::exists(dir / "out")) << a.command;
      EXPECT_FALSE(fs::exists(dir / "out.pcd")) << a.command;
    }
  }

  static std::string expand(std::string s) {
    const std::vector<std::pair<std::string, fs::path>> names = {
        {"{W}", dir / "work"}, {"{S}", dir / "seq"}, {"{F}", dir / "forest.json"}, {"{O}", dir / "out"}};
    for (const auto& [key, path] : names)
      for (std::size_t at; (at = s.find(key)) != std::string::npos;) s.replace(at, key.size(), path.string());
    return s;
  }
};
fs::path Options::dir;

void expect_one_line(const Absurd& a, const Outcome& r) {
  EXPECT_EQ(r.status, a.status) << a.command << "\n" << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << a.command << "\n" << r.out;
  EXPECT_NE(r.out.find(a.named), std::string::npos) << a.command << "\n" << r.out;
}

}  // namespace

TEST_F(Options, TrainForestRefusesAbsurdValues) {
  const std::vector<Absurd> cases = {
      {"{W} -K 0 -o {O}", 2, "-K"},
      {"{W} -M -1 -o {O}", 2, "-M"},
      {"{W} -M 0 -o {O}", 2, "-M"},
      {"{W} --Ks 0 -o {O}", 2, "--Ks"},
      {"{W} --Kt 0 -o {O}", 2, "--Kt"},
      {"{W} --Kt 1000000000 -o {O}", 2, "--Kt"},
      {"{W} --threads -3 -o {O}", 2, "--threads"},
      {"{W} --seed -1 -o {O}", 2, "--seed"},
      {"{W} --memory-mb 0 -o {O}", 2, "--memory-mb"},
      {"{W} --n-min 0 -o {O}", 2, "--n-min"},
      {"{W} --corpus-tree 9 --export-corpus {O}.csv -M 2 -o {O}", 2, "--corpus-tree"},
      {"{W} --train-frames 500:600 -o {O}", 1, "500:600"},
      {"{W} --memory-mb 1 -o {O}", 1, "--memory-mb"},
      {"{W} --Kt 100000000 --memory-mb 1024 -o {O}", 1, "--memory-mb"},
  };
  for (const Absurd& a : cases) {
    const Outcome r = run("timeout 120 " + tool("train-forest") + " -q " + expand(a.command));
    expect_one_line(a, r);
    EXPECT_FALSE(fs::exists(dir / "out")) << a.command;
    EXPECT_FALSE(fs::exists(dir / "out.pcd")) << a.command;
  }
}

// An unknown SIMD target in the environment is named before any work: train-forest says so before it
// reads the stacks (here a work folder that does not exist, whose error would otherwise come first).
TEST_F(Options, TrainForestNamesAnUnknownSimdTargetBeforeReadingTheStacks) {
  const Outcome r = run("SMSEG_SIMD=avx9 timeout 120 " + tool("train-forest") + " -q " + expand("{O}-missing -o {O}"));
  expect_one_line({"SMSEG_SIMD=avx9", 1, "SMSEG_SIMD"}, r);
  EXPECT_NE(r.out.find("avx9"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST_F(Options, EvalForestRefusesAbsurdValues) {
  const std::vector<Absurd> cases = {
      {"{F} {W} --grid -4 -o {O}", 2, "--grid"},
      {"{F} {W} --grid 100000 -o {O}", 2, "--grid"},
      {"{F} {W} --votes 0 --grid 8 -o {O}", 2, "--votes"},
      {"{F} {W} --votes 0 -o {O}", 2, "--votes"},
      {"{F} {W} --threads -3 -o {O}", 2, "--threads"},
      {"{F} {W} --seed -1 -o {O}", 2, "--seed"},
      {"{F} {W} --trees -1 -o {O}", 2, "--trees"},
      {"{F} {W} --tolerance -1 -o {O}", 2, "--tolerance"},
      {"{F} {W} --smooth graphcut --smooth-window -1 -o {O}", 2, "--smooth-window"},
      {"{F} {W} --smooth graphcut --smooth-window 5000 -o {O}", 2, "--smooth-window"},
      {"{F} {W} --smooth graphcut --smooth-bands 0 -o {O}", 2, "--smooth-bands"},
      {"{F} {W} --smooth graphcut --smooth-bands 65 -o {O}", 2, "--smooth-bands"},
      {"{F} {W} --smooth graphcut --smooth-contrast maybe -o {O}", 2, "--smooth-contrast"},
      {"{F} {W} --test-frames 500: -o {O}", 1, "500:"},
      {"{F} {W} --trees 3 -o {O}", 1, "--trees"},
  };
  for (const Absurd& a : cases) {
    const Outcome r = run("timeout 120 " + tool("eval-forest") + " -q " + expand(a.command));
    expect_one_line(a, r);
    EXPECT_FALSE(fs::exists(dir / "out")) << a.command;
    EXPECT_FALSE(fs::exists(dir / "out.pcd")) << a.command;
  }
}

TEST_F(Options, OtherToolsRefuseAbsurdValues) {
  const std::vector<std::pair<std::string, Absurd>> cases = {
      {"extract-features", {"{S} -o {O} --threads -1", 2, "--threads"}},
      {"extract-features", {"{S} -o {O} --seed -1", 2, "--seed"}},
      {"extract-features", {"{S} -o {O} --frames 500:", 1, "--frames"}},
      {"make-sequence", {"--frames 0 -o {O}", 2, "--frames"}},
      {"make-sequence", {"--frames -5 -o {O}", 2, "--frames"}},
      {"make-sequence", {"--size 0x0 -o {O}", 2, "--size"}},
      {"make-sequence", {"--seed -1 -o {O}", 2, "--seed"}},
      {"extract-features", {"{S} -o {O} --block-size 4", 2, "--block-size"}},
      {"extract-features", {"{S} -o {O} --num-disparities 0", 2, "--num-disparities"}},
      {"extract-features", {"{S} -o {O} --min-track-frames 0", 2, "--min-track-frames"}},
      {"extract-features", {"{S} -o {O} --gravity tilted", 2, "--gravity"}},
      {"extract-features", {"{S} -o {O} --dense --sweep-baseline 0", 2, "--sweep-baseline"}},
      {"extract-features", {"{S} -o {O} --dense --sweep-reach 0", 2, "--sweep-reach"}},
      {"label-stream", {"{S} {F} -o {O} --grid -1", 2, "--grid"}},
      {"label-stream", {"{S} {F} -o {O} --frames 500:", 1, "--frames"}},
      {"label-stream", {"{S} {F} -o {O} --cameras 0", 2, "--cameras"}},
      {"label-stream", {"{S} {F} -o {O} --stereo given", 2, "--stereo"}},
      {"label-stream", {"{S} {F} -o {O} --min-track-frames 0", 2, "--min-track-frames"}},
      {"label-stream", {"{S} {F} -o {O} --keypoints gftt --tracker descriptors", 2, "--keypoints"}},
      {"label-stream", {"{S} {F} -o {O} --overlay-video a/b.avi", 2, "--overlay-video"}},
      {"label-stream", {"{S} {F} -o {O} --side-by-side /nonexistent/rig.avi", 1, "rig.avi"}},
      {"label-stream", {"{S} {F} -o {O} --video-fps 0", 2, "--video-fps"}},
      {"segment-cloud", {"--make-tabletop -5 -o {O}.pcd", 2, "--make-tabletop"}},
      {"segment-cloud", {"--make-tabletop 1000000000 -o {O}.pcd", 2, "--make-tabletop"}},
      {"add-context", {"{F} {W} --folds 1 -o {O}", 2, "--folds"}},
      {"add-context", {"{F} {W} --folds -2 -o {O}", 2, "--folds"}},
      {"add-context", {"{F} {W} --folds 5000 -o {O}", 1, "--folds"}},
      {"add-context", {"{F} {W} --frames 500: -o {O}", 1, "500:"}},
      {"add-context", {"{F} {W} --memory-mb 0 -o {O}", 2, "--memory-mb"}},
      {"add-context", {"{F} {W} --features fNope -o {O}", 1, "fNope"}},
      {"learn-textons", {"{W} --textons 1 -o {O}.json", 2, "--textons"}},
      {"learn-textons", {"{W} --samples 0 -o {O}.json", 2, "--samples"}},
      {"learn-textons", {"{W} --frames 500: -o {O}.json", 1, "500:"}},
      {"add-textons", {"{F} {W} -o {O}", 1, "format"}},  // a forest given as the dictionary
      {"add-people", {"{W} --frames 500: -o {O}", 1, "500:"}},
      {"add-people", {"{F} -o {O}", 1, "no such work folder"}},  // a forest file given as the work folder
      {"learn-hog-classes", {"{W} --window 24x96 -o {O}.json", 2, "--window"}},
      {"learn-hog-classes", {"{W} --window 32 -o {O}.json", 2, "--window"}},
      {"learn-hog-classes", {"{W} --negatives 0 -o {O}.json", 2, "--negatives"}},
      {"learn-hog-classes", {"{W} --epochs 0 -o {O}.json", 2, "--epochs"}},
      {"learn-hog-classes", {"{W} --learning-rate 0 -o {O}.json", 2, "--learning-rate"}},
      {"learn-hog-classes", {"{W} -o {O}.json", 1, "Pole"}},  // the default classes are CamVid's
      {"learn-hog-classes", {"{W} --channels wall --frames 500: -o {O}.json", 1, "500:"}},
      {"add-hog-classes", {"{F} {W} -o {O}", 1, "format"}},  // a forest given as the model
      {"run-experiment", {SMSEG_SOURCE_DIR "/experiments/thesis/k-sweep.json --threads -3 -o {O}", 2, "--threads"}},
      {"run-experiment", {SMSEG_SOURCE_DIR "/experiments/thesis/k-sweep.json --memory-mb 0 -o {O}", 2, "--memory-mb"}},
      {"run-experiment", {SMSEG_SOURCE_DIR "/experiments/thesis/k-sweep.json --max-points -1 -o {O}", 2, "--max-points"}},
  };
  expect_each_refused(cases);
}

// Every option declared in an options table (smseg/common/options.hpp) is checked by the parser: a
// non-finite number or a name that is not one of the choices is bad usage, exit status 2, naming the
// option. (Before the tables, --camera-height inf was taken, and --motion, --vote,
// --smooth and an empty --test-frames range exited 1.)
TEST_F(Options, NonFiniteNumbersAndUnknownNamesAreBadUsage) {
  const std::vector<std::pair<std::string, Absurd>> cases = {
      {"extract-features", {"{S} -o {O} --camera-height inf", 2, "--camera-height"}},
      {"extract-features", {"{S} -o {O} --dense --sweep-baseline nan", 2, "--sweep-baseline"}},
      {"extract-features", {"{S} -o {O} --focal -inf", 2, "--focal"}},
      {"extract-features", {"{S} -o {O} --motion lidar", 2, "--motion"}},
      {"extract-features", {"{S} -o {O} --keypoints fast", 2, "--keypoints"}},
      {"label-stream", {"{S} {F} -o {O} --camera-height nan", 2, "--camera-height"}},
      {"eval-forest", {"{F} {W} -o {O} --smooth graphcut --lambda inf", 2, "--lambda"}},
      {"eval-forest", {"{F} {W} -o {O} --vote loudest", 2, "--vote"}},
      {"eval-forest", {"{F} {W} -o {O} --smooth blur", 2, "--smooth"}},
      {"eval-forest", {"{F} {W} -o {O} --test-frames 5:2", 2, "--test-frames"}},
      {"make-sequence", {"--fps inf -o {O}", 2, "--fps"}},
      {"make-sequence", {"--baseline nan -o {O}", 2, "--baseline"}},
      {"train-forest", {"{W} -o {O} -M nan", 2, "-M"}},
      {"train-forest", {"{W} -o {O} --balance most", 2, "--balance"}},
  };
  expect_each_refused(cases);
}
