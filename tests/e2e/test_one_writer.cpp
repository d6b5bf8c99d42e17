// One writer per output, and outputs never over inputs (docs/reliability.md, "One writer per output"):
// a second process writing the same output is refused in one line; an output that is an input of the
// run, or holds one, is refused before anything is written; a dry run writes nothing; a control
// character in a path never reaches a Slurm job script. Each case failed on the commit before these
// checks (a second run-experiment wrote every point again; train-forest -o WORK/stacks.json replaced its
// own input; --slurm-dry-run wrote config.json; a newline in --slurm-dir became a line of job.sh).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "run_tool.hpp"
#include "smseg/common/io.hpp"
#include "smseg/common/output.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;

namespace {

using smseg::test::Outcome;
using smseg::test::run;
using smseg::test::tool;

int lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

class OneWriter : public ::testing::Test {
 protected:
  static fs::path dir;
  static void SetUpTestSuite() {
    dir = smseg::test::temp_dir("one_writer");
    Outcome r = run(tool("make-sequence") + " --frames 12 --label-every 2 --size 96x72 -q -o " + (dir / "seq").string());
    ASSERT_EQ(r.status, 0) << r.out;
    r = run(tool("extract-features") + " -q " + (dir / "seq").string() + " -o " + (dir / "work").string());
    ASSERT_EQ(r.status, 0) << r.out;
    r = run(tool("train-forest") + " -q " + (dir / "work").string() + " -K 40 -M 2 -o " + (dir / "forest.json").string());
    ASSERT_EQ(r.status, 0) << r.out;
    smseg::write_file_atomic(dir / "config.json", R"({
      "format": "smseg-experiment", "version": 1, "name": "tiny",
      "sequences": {"s": {"synthetic": {"frames": 12, "label_every": 2, "width": 64, "height": 48}}},
      "fixed": {"train": "s", "train_frames": "0:6", "test_frames": "6:", "M": 2, "K": 30}})");
  }
  static void TearDownTestSuite() { fs::remove_all(dir); }
  static std::string p(const char* name) { return (dir / name).string(); }
};
fs::path OneWriter::dir;

}  // namespace

TEST_F(OneWriter, ASecondWriterOfTheSameOutputIsRefused) {
  const std::vector<std::pair<std::string, std::string>> writers = {
      {"run-experiment", p("config.json") + " -q --cache " + p("cache") + " -o " + p("out")},
      {"eval-forest", p("forest.json") + " " + p("work") + " -q -o " + p("out")},
      {"extract-features", p("seq") + " -q -o " + p("out")},
      {"train-forest", p("work") + " -q -K 40 -M 2 -o " + p("out")},
      {"make-sequence", "--frames 3 --size 64x48 -q -o " + p("out")}};
  for (const auto& [name, args] : writers) {
    {
      const smseg::OutputLock other(dir / "out");  // the first writer, still at work
      const Outcome r = run(tool(name) + " " + args);
      EXPECT_EQ(r.status, 1) << name << ": " << r.out;
      EXPECT_EQ(lines(r.out), 1) << name << ": " << r.out;
      EXPECT_NE(r.out.find("is being written by pid"), std::string::npos) << name << ": " << r.out;
      EXPECT_FALSE(fs::exists(dir / "out")) << name;
    }
    const Outcome r = run(tool(name) + " " + args);  // the first is done: the output is free
    EXPECT_EQ(r.status, 0) << name << ": " << r.out;
    EXPECT_FALSE(fs::exists(dir / ".out.lock")) << name << ": the lock file is removed with the lock";
    fs::remove_all(dir / "out");
  }
}

TEST_F(OneWriter, AnOutputThatIsOrHoldsAnInputIsRefusedBeforeWriting) {
  const std::string stacks_before = smseg::read_file(dir / "work" / "stacks.json");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"train-forest", p("work") + " -q -K 40 -M 2 -o " + (dir / "work" / "stacks.json").string()},
      {"extract-features", p("seq") + " -q -o " + p("seq")},
      {"eval-forest", p("forest.json") + " " + p("work") + " -q -o " + p("work")},
      {"eval-forest", p("forest.json") + " " + p("work") + " -q -o " + dir.string()},
      {"eval-forest", p("forest.json") + " " + p("work") + " -q -o ''"}};
  for (const auto& [name, args] : cases) {
    const Outcome r = run(tool(name) + " " + args);
    EXPECT_EQ(r.status, 2) << name << " " << args << ": " << r.out;
    EXPECT_EQ(lines(r.out), 1) << r.out;
    EXPECT_NE(r.out.find("-o"), std::string::npos) << r.out;
  }
  EXPECT_EQ(smseg::read_file(dir / "work" / "stacks.json"), stacks_before);
}

// A second output inside the first is not an input: make-sequence's --montage inside OUT, run twice.
TEST_F(OneWriter, AMontageInsideItsOutputFolderIsNoInput) {
  const std::string args = " --frames 3 --size 64x48 -q -o " + p("m") + " --montage " + (dir / "m" / "montage.png").string();
  for (int run = 0; run < 2; ++run) {
    const Outcome r = smseg::test::run(tool("make-sequence") + args);
    EXPECT_EQ(r.status, 0) << "run " << run << ": " << r.out;
  }
  EXPECT_TRUE(fs::exists(dir / "m" / "montage.png"));
}

TEST_F(OneWriter, ASlurmDryRunWritesNothing) {
  const Outcome r = run(tool("run-experiment") + " " + p("config.json") + " --slurm --tasks 1 --slurm-dry-run --cache " +
                        p("cache") + " -o " + p("dry"));
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("dry run: nothing written"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "dry")) << "a dry run wrote its results folder";
}

TEST_F(OneWriter, AControlCharacterNeverReachesAJobScript) {
  const Outcome r = run(tool("train-forest") + " -q " + p("work") + " -K 40 -M 2 --slurm --tasks 1 --slurm-dry-run -o " +
                        p("f.json") + " --slurm-dir \"$(printf '" + p("jobs") + "\\nrm -rf x')\"");  // sh has no $'...'
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_EQ(lines(r.out), 1) << r.out;
  EXPECT_NE(r.out.find("control character"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("jobs\\nrm -rf x"), std::string::npos) << "the name is shown escaped, on one line: " << r.out;
  EXPECT_EQ(r.out.find("#SBATCH"), std::string::npos) << r.out;
}
