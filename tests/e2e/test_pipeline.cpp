// End to end through the command-line tools, as a user runs them: make-sequence -> extract-features
// -> train-forest -> eval-forest on a small synthetic corridor; plus the tools' answers to bad input.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "run_tool.hpp"
#include "smseg/common/io.hpp"

namespace fs = std::filesystem;

namespace {

using smseg::test::Outcome;
using smseg::test::run;
using smseg::test::tool;

class Pipeline : public ::testing::Test {
 protected:
  static fs::path dir;
  static void SetUpTestSuite() {
    dir = fs::temp_directory_path() / ("smseg_e2e_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  static void TearDownTestSuite() { fs::remove_all(dir); }
};
fs::path Pipeline::dir;

}  // namespace

TEST_F(Pipeline, SyntheticCorridorTrainsAndBeatsTheMajorityClass) {
  const fs::path seq = dir / "corridor", work = dir / "work", forest = dir / "forest.json", eval = dir / "eval";
  Outcome r = run(tool("make-sequence") + " --scene corridor --seed 3 --frames 120 -q -o " + seq.string());
  ASSERT_EQ(r.status, 0) << r.out;
  r = run(tool("extract-features") + " -q " + seq.string() + " -o " + work.string());
  ASSERT_EQ(r.status, 0) << r.out;
  r = run(tool("train-forest") + " -q " + work.string() + " --train-frames 0:71 -K 200 -M 5 -o " + forest.string());
  ASSERT_EQ(r.status, 0) << r.out;
  r = run(tool("eval-forest") + " -q " + forest.string() + " " + work.string() + " --test-frames 71: -o " + eval.string());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("global accuracy"), std::string::npos) << r.out;

  const smseg::Json res = smseg::read_json(eval / "results.json");
  EXPECT_EQ(res["per_frame"].size(), 4u);  // labelled frames at or after 71: 80, 90, 100, 110
  // The forest must beat labelling everything with the most common class of the test frames.
  const auto& counts = res["confusion"]["counts"];
  double total = 0, largest = 0;
  for (const auto& row : counts) {
    double s = 0;
    for (const auto& v : row) s += v.get<double>();
    total += s;
    largest = std::max(largest, s);
  }
  const double global = res["global_accuracy"].get<double>();
  EXPECT_GT(global, largest / total + 0.05) << "majority share " << largest / total;
  EXPECT_GT(res["class_average_accuracy"].get<double>(), 1.0 / 6.0 + 0.05);
  for (const char* pic : {"_labels.png", "_overlay.png", "_error.png", "_montage.png"})
    EXPECT_TRUE(fs::exists(eval / "frames" / (std::string("000080") + pic))) << pic;

  // Resumable: a second run skips every frame; the tracks file is there.
  r = run(tool("extract-features") + " -q " + seq.string() + " -o " + work.string());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("0 frames written, 120 already done"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(work / "tracks.json"));
  // Other options on the same work folder need --force.
  r = run(tool("extract-features") + " -q --causal " + seq.string() + " -o " + work.string());
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("--force"), std::string::npos) << r.out;
}

TEST_F(Pipeline, SameSeedSameStacksWhateverTheThreadCount) {
  const fs::path seq = dir / "small";
  Outcome r = run(tool("make-sequence") + " --scene lab --seed 5 --frames 30 --size 160x120 -q -o " + seq.string());
  ASSERT_EQ(r.status, 0) << r.out;
  for (const char* threads : {"1", "2"}) {
    r = run(tool("extract-features") + " -q --threads " + threads + " " + seq.string() + " -o " +
            (dir / (std::string("w") + threads)).string());
    ASSERT_EQ(r.status, 0) << r.out;
  }
  int compared = 0;
  for (const auto& e : fs::directory_iterator(dir / "w1" / "stacks")) {
    const fs::path other = dir / "w2" / "stacks" / e.path().filename();
    ASSERT_TRUE(fs::exists(other)) << other;
    EXPECT_EQ(smseg::read_file(e.path()), smseg::read_file(other)) << e.path().filename();
    ++compared;
  }
  EXPECT_EQ(compared, 30);  // one values file a frame (its channels, greyscale, labels)
  // The tracks and camera path agree too (the summary's timings aside).
  smseg::Json a = smseg::read_json(dir / "w1" / "tracks.json"), b = smseg::read_json(dir / "w2" / "tracks.json");
  a.erase("summary");
  b.erase("summary");
  EXPECT_EQ(a, b);
}

TEST_F(Pipeline, BadInputGetsOneClearLineAndNonZeroExit) {
  // Missing sequence.
  Outcome r = run(tool("extract-features") + " " + (dir / "nope").string() + " -o " + (dir / "w").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("nope"), std::string::npos) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  EXPECT_FALSE(fs::exists(dir / "w" / "stacks.json"));
  // Malformed forest JSON.
  std::ofstream(dir / "bad.json") << "{\"format\": \"smseg-forest\", ";
  r = run(tool("eval-forest") + " " + (dir / "bad.json").string() + " " + dir.string() + " -o " + (dir / "e").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("bad.json: malformed JSON"), std::string::npos) << r.out;
  // A foreign file as a forest.
  std::ofstream(dir / "foreign.json") << "{\"format\": \"smseg-sequence\", \"version\": 1}";
  r = run(tool("eval-forest") + " " + (dir / "foreign.json").string() + " " + dir.string() + " -o " + (dir / "e").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("foreign.json"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "e" / "results.json"));
  // Bad usage: exit 2.
  r = run(tool("train-forest") + " --train-frames 5:2 " + dir.string() + " -o x.json");
  EXPECT_EQ(r.status, 1) << r.out;  // parsed fine, then the range is refused
  EXPECT_NE(r.out.find("--train-frames"), std::string::npos) << r.out;
  r = run(tool("train-forest") + " --no-such-option");
  EXPECT_EQ(r.status, 2) << r.out;
  r = run(tool("make-sequence") + " --scene moon -o " + (dir / "m").string());
  EXPECT_EQ(r.status, 2) << r.out;
  // Every tool explains itself.
  // SMSEG_TOOLS: every tool the build makes (tests/CMakeLists.txt), so a new tool cannot skip this.
  std::vector<std::string> tools;
  std::stringstream names(SMSEG_TOOLS);
  for (std::string t; std::getline(names, t, ',');) tools.push_back(t);
  EXPECT_GE(tools.size(), 9U);
  for (const std::string& t : tools) {
    r = run(tool(t) + " --help");
    EXPECT_EQ(r.status, 0) << t;
    EXPECT_NE(r.out.find("Usage"), std::string::npos) << t;
  }
}
