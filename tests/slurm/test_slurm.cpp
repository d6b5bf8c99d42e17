// train-forest and run-experiment on a one-node Slurm cluster (experiments/slurm/local-cluster.sh): the
// merged forest and the collected records are those of a local run for the same seed, timing aside;
// reruns submit only what is missing; failures name the task, its state and its log; bad usage is
// one line and exit status 2. The cluster-free tests need no Slurm (usage, --merge, sbatch missing).
#include <gtest/gtest.h>

#include <cstdlib>
#include <chrono>
#include <fstream>
#include <map>
#include <thread>

#include "jsonl.hpp"
#include "run_tool.hpp"
#include "smseg/experiments/runner.hpp"
#include "smseg/common/io.hpp"
#include "smseg/common/slurm.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using smseg::test::run;
using smseg::test::tool;
namespace ex = smseg::experiments;

namespace {

const fs::path kRoot = SMSEG_SLURM_TEST_DIR;  // cluster/, cache/, one folder per test
const fs::path kCluster = kRoot / "cluster";

/// A fresh folder for one test.
fs::path test_dir(const std::string& name) {
  const fs::path d = kRoot / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

/// A tiny corridor's work folder, made once into the shared cache (run-experiment's).
fs::path tiny_work() {
  ex::SequenceSource src;
  src.synth.scene = "corridor";
  src.synth.seed = 2;
  src.synth.frames = 40;
  src.synth.width = 160;
  src.synth.height = 120;
  return ex::prepare_work("c", src, ex::FrontEnd{}, kRoot / "cache", false);
}

json tiny_config() {
  return json::parse(R"({
    "format": "smseg-experiment", "version": 1, "name": "tiny",
    "sequences": {"c": {"synthetic": {"scene": "corridor", "seed": 2, "frames": 40, "width": 160, "height": 120}}},
    "fixed": {"train": "c", "train_frames": "0:21", "test_frames": "30:", "M": 3, "votes": 4},
    "sweep": {"K": [20, 30], "grid": [0, 10]}
  })");
}

/// A forest file without its timing fields (stats.seconds, stats.trees[i].seconds), as bytes.
std::string forest_bytes_without_timing(const fs::path& file) {
  json j = smseg::read_json(file);
  j["stats"]["seconds"] = 0;
  for (auto& t : j["stats"]["trees"]) t["seconds"] = 0;
  return j.dump(-1);
}

/// A run-experiment record without its timing fields.
json record_without_timing(json rec) {
  for (const char* k : {"train_seconds", "pilot_seconds", "eval_seconds", "seconds_per_frame",
                        "superpixel_seconds_per_frame"})
    rec.erase(k);
  return rec;
}

std::string q(const fs::path& p) { return smseg::slurm::shell_quote(p.string()); }

std::string train_command(const fs::path& work, const std::string& extra, const fs::path& out) {
  return tool("train-forest") + " " + q(work) + " --train-frames 0:21 -K 30 -M 5 --seed 3 " + extra + " -o " + q(out);
}

/// Whether `file` appears within a minute (a gather job's output).
bool eventually_exists(const fs::path& file) {
  for (int i = 0; i < 600 && !fs::exists(file); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  return fs::exists(file);
}

/// The id after `prefix` in a tool's output ("array job 12 (" -> "12").
std::string job_id_after(const std::string& out, const std::string& prefix) {
  const auto at = out.find(prefix);
  if (at == std::string::npos) return "";
  const auto begin = at + prefix.size();
  return out.substr(begin, out.find(' ', begin) - begin);
}

int count_lines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

class SlurmCluster : public ::testing::Test {
 protected:
  static std::string unavailable;  // why the cluster is not up; empty when it is

  static void SetUpTestSuite() {
    const auto r = run("bash " + q(fs::path(SMSEG_SOURCE_DIR) / "experiments/slurm/local-cluster.sh") + " start " + q(kCluster));
    if (r.status != 0) {
      unavailable = r.out.empty() ? "local-cluster.sh start failed" : r.out;
      return;
    }
    ::setenv("SLURM_CONF", (kCluster / "slurm.conf").c_str(), 1);  // the tools and their tasks inherit it
  }
  // Under ctest the cleanup fixture stops the cluster after the last test (SMSEG_SLURM_KEEP); run on
  // its own, the program stops it here.
  static void TearDownTestSuite() {
    if (!std::getenv("SMSEG_SLURM_KEEP"))
      run("bash " + q(fs::path(SMSEG_SOURCE_DIR) / "experiments/slurm/local-cluster.sh") + " stop " + q(kCluster));
  }
  void SetUp() override {
    if (!unavailable.empty()) GTEST_SKIP() << "Slurm cluster unavailable: " << unavailable;
  }
};
std::string SlurmCluster::unavailable;

}  // namespace

TEST_F(SlurmCluster, TrainForestOnSlurmIsTheLocalForestAndResumes) {
  const fs::path work = tiny_work();
  const fs::path d = test_dir("train");
  const auto local = run(train_command(work, "-q", d / "local.json"));
  ASSERT_EQ(local.status, 0) << local.out;
  const auto slurm = run(train_command(work, "--slurm --tasks 3 --poll 0.2", d / "slurm.json"));
  ASSERT_EQ(slurm.status, 0) << slurm.out;
  EXPECT_NE(slurm.out.find("(3 tasks, logs"), std::string::npos) << slurm.out;
  EXPECT_EQ(forest_bytes_without_timing(d / "slurm.json"), forest_bytes_without_timing(d / "local.json"));
  // Three parts of 2, 2 and 1 trees, each from its own task, each with its log.
  const fs::path job = d / "slurm.json.slurm";
  const json part1 = smseg::read_json(job / "parts/part-1.json");
  EXPECT_EQ(part1["trees"], json({{"begin", 2}, {"end", 4}}));
  for (int t = 0; t < 3; ++t) EXPECT_TRUE(fs::exists(job / "logs" / ("task-" + std::to_string(t) + ".log"))) << t;

  // A rerun submits only the missing part and gives the same forest.
  fs::remove(job / "parts/part-1.json");
  fs::remove(d / "slurm.json");
  const auto again = run(train_command(work, "--slurm --tasks 3 --poll 0.2", d / "slurm.json"));
  ASSERT_EQ(again.status, 0) << again.out;
  EXPECT_NE(again.out.find("(1 tasks, logs"), std::string::npos) << again.out;
  EXPECT_EQ(forest_bytes_without_timing(d / "slurm.json"), forest_bytes_without_timing(d / "local.json"));

  // --no-wait returns once submitted; the gather job writes the forest.
  fs::remove_all(job / "parts");
  fs::remove(d / "slurm.json");
  const auto no_wait = run(train_command(work, "--slurm --tasks 3 --no-wait", d / "slurm.json"));
  ASSERT_EQ(no_wait.status, 0) << no_wait.out;
  EXPECT_NE(no_wait.out.find("and gather job"), std::string::npos) << no_wait.out;
  EXPECT_TRUE(eventually_exists(d / "slurm.json")) << smseg::read_file(smseg::slurm::gather_log(job));
  EXPECT_EQ(forest_bytes_without_timing(d / "slurm.json"), forest_bytes_without_timing(d / "local.json"));

  // Parts of another training in the job folder are refused, not merged.
  const auto other = run(tool("train-forest") + " " + q(work) + " --train-frames 0:21 -K 30 -M 5 --seed 4" +
                         " --slurm --tasks 3 --slurm-dir " + q(job) + " -o " + q(d / "other.json"));
  EXPECT_EQ(other.status, 1) << other.out;
  EXPECT_NE(other.out.find("part-0.json: params: this part comes from another training"), std::string::npos)
      << other.out;
  EXPECT_FALSE(fs::exists(d / "other.json"));
}

// --mirror on Slurm: the tasks mirror their own frames (the submitter only checks the channels) and the
// merged forest is the local mirrored one.
TEST_F(SlurmCluster, MirroredTrainingOnSlurmIsTheLocalMirroredForest) {
  const fs::path work = tiny_work();
  const fs::path d = test_dir("train-mirror");
  ASSERT_EQ(run(train_command(work, "-q --mirror", d / "local.json")).status, 0);
  const auto slurm = run(train_command(work, "--mirror --slurm --tasks 2 --poll 0.2", d / "slurm.json"));
  ASSERT_EQ(slurm.status, 0) << slurm.out;
  EXPECT_EQ(forest_bytes_without_timing(d / "slurm.json"), forest_bytes_without_timing(d / "local.json"));
  EXPECT_EQ(smseg::read_json(d / "slurm.json.slurm/parts/part-0.json")["training_data"]["mirrored"], true);
}

TEST_F(SlurmCluster, RunExperimentOnSlurmWritesTheLocalRecords) {
  const fs::path d = test_dir("experiment");
  smseg::write_json_atomic(d / "tiny.json", tiny_config());
  const std::string base = tool("run-experiment") + " " + q(d / "tiny.json") + " --cache " + q(kRoot / "cache");
  const auto local = run(base + " -q -o " + q(d / "local"));
  ASSERT_EQ(local.status, 0) << local.out;
  // --tasks 3 for a sweep of two forests: two tasks, said.
  const auto slurm = run(base + " --slurm --tasks 3 --poll 0.2 -o " + q(d / "slurm"));
  ASSERT_EQ(slurm.status, 0) << slurm.out;
  EXPECT_NE(slurm.out.find("submitting 2 tasks"), std::string::npos) << slurm.out;
  EXPECT_NE(slurm.out.find("4 points evaluated"), std::string::npos) << slurm.out;
  const auto a = smseg::test::read_jsonl(d / "local/experiment.jsonl");
  const auto b = smseg::test::read_jsonl(d / "slurm/experiment.jsonl");
  ASSERT_EQ(a.size(), 4u);
  ASSERT_EQ(b.size(), 4u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(b[i]["index"], static_cast<int>(i));
    EXPECT_EQ(record_without_timing(b[i]), record_without_timing(a[i])) << "point " << i;
  }
  // Points sharing a forest (the grid sizes of one K) ran in one task: two tasks, two points each.
  EXPECT_EQ(smseg::test::read_jsonl(d / "slurm/slurm/tasks/task-0/experiment.jsonl").size(), 2u);
  EXPECT_EQ(smseg::test::read_jsonl(d / "slurm/slurm/tasks/task-1/experiment.jsonl").size(), 2u);
  // Nothing left: a rerun submits nothing.
  const auto again = run(base + " --slurm --tasks 2 -o " + q(d / "slurm"));
  EXPECT_EQ(again.status, 0) << again.out;
  EXPECT_NE(again.out.find("0 points evaluated, 4 already done"), std::string::npos) << again.out;
  // More tasks than forests to train: as many tasks as forests, said (the array of the dry run: 0-1).
  const auto more = run(base + " --slurm --tasks 3 --slurm-dry-run -o " + q(d / "more"));
  EXPECT_EQ(more.status, 0) << more.out;
  EXPECT_NE(more.out.find("need 2 forests"), std::string::npos) << more.out;
  EXPECT_NE(more.out.find("--array=0-1"), std::string::npos) << more.out;
  const auto none = run(base + " --slurm --tasks 0 -o " + q(d / "none"));
  EXPECT_EQ(none.status, 2) << none.out;
}

// A sweep submitted held, one of its tasks killed (scancel) before it could run, the rest released:
// the gather job never runs, OUT has no record yet; submitting again runs only the killed task's
// points, and OUT ends with every point exactly once, equal to the local run's.
TEST_F(SlurmCluster, KilledTaskIsRerunAndNoPointIsLostOrRepeated) {
  const fs::path d = test_dir("killed");
  smseg::write_json_atomic(d / "tiny.json", tiny_config());
  const std::string base = tool("run-experiment") + " " + q(d / "tiny.json") + " --cache " + q(kRoot / "cache") +
                           " --slurm --tasks 2 --poll 0.2 -o " + q(d / "out");
  const auto held = run(base + " --no-wait --slurm-arg=--hold");
  ASSERT_EQ(held.status, 0) << held.out;
  const std::string array = job_id_after(held.out, "array job "), gather = job_id_after(held.out, "gather job ");
  ASSERT_FALSE(array.empty()) << held.out;
  ASSERT_FALSE(gather.empty()) << held.out;
  ASSERT_EQ(run("scancel " + array + "_1").status, 0);
  ASSERT_EQ(run("scontrol release " + array + "," + gather).status, 0);
  smseg::slurm::WaitOptions wait;
  wait.poll_seconds = 0.2;
  smseg::slurm::wait_for_job(array, wait);
  // The gather job can never run now; the waiting tool cancels it, as here, rather than wait for
  // Slurm's --kill-on-invalid-dep.
  smseg::slurm::cancel(gather);
  smseg::slurm::wait_for_job(gather, wait);
  EXPECT_FALSE(fs::exists(d / "out/experiment.jsonl"));
  EXPECT_EQ(smseg::test::read_jsonl(d / "out/slurm/tasks/task-0/experiment.jsonl").size(), 2u);

  const auto again = run(base);
  ASSERT_EQ(again.status, 0) << again.out;
  EXPECT_NE(again.out.find("(1 tasks, logs"), std::string::npos) << again.out;
  const auto records = smseg::test::read_jsonl(d / "out/experiment.jsonl");
  std::map<int, int> per_point;
  for (const auto& r : records) ++per_point[r["index"].get<int>()];
  EXPECT_EQ(per_point, (std::map<int, int>{{0, 1}, {1, 1}, {2, 1}, {3, 1}}));
}

TEST_F(SlurmCluster, FailedTasksAreNamedWithTheirStateAndLog) {
  const fs::path d = test_dir("failing");
  smseg::slurm::ArrayJob job;
  job.name = "smseg-test";
  job.dir = d / "job";
  job.commands = {{"true"}, {"sh", "-c", "echo boom >&2; exit 3"}};
  smseg::slurm::WaitOptions wait;
  wait.poll_seconds = 0.2;
  const std::string id = smseg::slurm::run_array_job(job, wait);
  const auto states = smseg::slurm::task_states(id);
  ASSERT_EQ(states.size(), 2u);
  EXPECT_EQ(states[0].state, "COMPLETED");
  EXPECT_EQ(states[1].state, "FAILED");
  EXPECT_EQ(states[1].exit_code, "3:0");
  EXPECT_NE(smseg::read_file(smseg::slurm::task_log(job.dir, 1)).find("boom"), std::string::npos);
  const std::string said = smseg::slurm::describe_failures(job.dir, {1}, states);
  EXPECT_NE(said.find("task 1 (FAILED, exit 3:0, log " + smseg::slurm::task_log(job.dir, 1).string() + ")"),
            std::string::npos)
      << said;
}

TEST_F(SlurmCluster, SbatchRefusingTheJobIsOneLine) {
  const fs::path d = test_dir("refused");
  const auto r = run(train_command(tiny_work(), "-q --slurm --slurm-arg=--no-such-option", d / "f.json"));
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_EQ(count_lines(r.out), 1) << r.out;
  EXPECT_NE(r.out.find("sbatch: refused the job"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(d / "f.json"));
}

// Without a cluster.

/// Trains the forest whole (d/whole.json) and as parts 3: and 0:3 (d/b.json, d/a.json) with the
/// train-forest options `extra`, merges the parts (given out of order) and checks the merged forest is
/// the whole one.
void expect_parts_merge_into_the_whole_forest(const fs::path& work, const fs::path& d, const std::string& extra) {
  ASSERT_EQ(run(train_command(work, "-q " + extra, d / "whole.json")).status, 0);
  ASSERT_EQ(run(train_command(work, "-q --trees 3: " + extra, d / "b.json")).status, 0);
  ASSERT_EQ(run(train_command(work, "-q --trees 0:3 " + extra, d / "a.json")).status, 0);
  const auto m = run(tool("train-forest") + " --merge " + q(d / "b.json") + " " + q(d / "a.json") + " -o " + q(d / "m.json"));
  ASSERT_EQ(m.status, 0) << m.out;
  EXPECT_EQ(forest_bytes_without_timing(d / "m.json"), forest_bytes_without_timing(d / "whole.json"));
}

TEST(SlurmUsage, TreeRangesAndMergeGiveTheLocalForest) {
  const fs::path work = tiny_work();
  const fs::path d = test_dir("merge");
  expect_parts_merge_into_the_whole_forest(work, d, "");
  const auto gap = run(tool("train-forest") + " --merge " + q(d / "a.json") + " -o " + q(d / "g.json"));
  EXPECT_EQ(gap.status, 1) << gap.out;
  EXPECT_EQ(count_lines(gap.out), 1) << gap.out;
  EXPECT_NE(gap.out.find("a.json: trees: trees 3..4 are in no part"), std::string::npos) << gap.out;
  EXPECT_FALSE(fs::exists(d / "g.json"));
  // A part of the same options trained on other frames is refused, not merged. (Before: merged.)
  const auto other_frames = run(tool("train-forest") + " " + q(work) + " --train-frames 0:11 -K 30 -M 5 --seed 3 -q " +
                                "--trees 3: -o " + q(d / "other.json"));
  ASSERT_EQ(other_frames.status, 0) << other_frames.out;
  const auto mixed = run(tool("train-forest") + " --merge " + q(d / "a.json") + " " + q(d / "other.json") + " -o " +
                         q(d / "mixed.json"));
  EXPECT_EQ(mixed.status, 1) << mixed.out;
  EXPECT_EQ(count_lines(mixed.out), 1) << mixed.out;
  EXPECT_NE(mixed.out.find("the parts were trained on other data"), std::string::npos) << mixed.out;
  EXPECT_FALSE(fs::exists(d / "mixed.json"));
}

// train-forest --mirror: parts of mirrored training merge into the mirrored forest, and the record
// keeps them apart from parts trained on the frames alone.
TEST(SlurmUsage, MirroredPartsMergeIntoTheMirroredForestAndOnlyWithEachOther) {
  const fs::path work = tiny_work();
  const fs::path d = test_dir("merge-mirror");
  const auto said = run(train_command(work, "--mirror", d / "said.json"));
  ASSERT_EQ(said.status, 0) << said.out;
  EXPECT_NE(said.out.find("on 3 frames and their mirrors"), std::string::npos) << said.out;
  expect_parts_merge_into_the_whole_forest(work, d, "--mirror");
  ASSERT_EQ(run(train_command(work, "", d / "plain.json")).status, 0);
  EXPECT_NE(forest_bytes_without_timing(d / "whole.json"), forest_bytes_without_timing(d / "plain.json"));
  ASSERT_EQ(run(train_command(work, "-q --trees 3:", d / "b-plain.json")).status, 0);
  const auto mixed = run(tool("train-forest") + " --merge " + q(d / "a.json") + " " + q(d / "b-plain.json") + " -o " +
                         q(d / "mixed.json"));
  EXPECT_EQ(mixed.status, 1) << mixed.out;
  EXPECT_NE(mixed.out.find("the parts were trained on other data"), std::string::npos) << mixed.out;
  EXPECT_FALSE(fs::exists(d / "mixed.json"));
}

// train-forest --exposures: darker copies of the frames (and mirrors), said and recorded, and a forest
// of their own (the tiny corridor's stacks have no appearance channel, but the texton tests read the
// darker greyscale images).
TEST(SlurmUsage, ExposuresAreSaidRecordedAndChangeTheForest) {
  const fs::path work = tiny_work();
  const fs::path d = test_dir("exposures");
  const auto said = run(train_command(work, "--textons --mirror --exposures 0.5,0.25", d / "said.json"));
  ASSERT_EQ(said.status, 0) << said.out;
  EXPECT_NE(said.out.find("on 3 frames and their mirrors at exposures 1, 0.5, 0.25"), std::string::npos) << said.out;
  ASSERT_EQ(run(train_command(work, "-q --textons --mirror --exposures 0.5,0.25 --trees 0:2", d / "part.json")).status, 0);
  EXPECT_EQ(smseg::read_json(d / "part.json")["training_data"]["exposures"], json::array({0.5, 0.25}));
  ASSERT_EQ(run(train_command(work, "-q --textons --mirror", d / "plain.json")).status, 0);
  EXPECT_NE(forest_bytes_without_timing(d / "said.json"), forest_bytes_without_timing(d / "plain.json"));
}

TEST(SlurmUsage, BadOptionsAreOneLineAndExitStatusTwo) {
  const fs::path d = test_dir("usage");
  const std::string tf = tool("train-forest") + " " + q(d) + " -M 5 -o " + q(d / "f.json") + " ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {tf + "--trees 5:3", "--trees: is 5:3, expected A:B with 0 <= A < B <= 5"},
      {tf + "--trees 4", "--trees: is \"4\", expected a range of tree indices A:B"},
      {tf + "--trees 0:9", "--trees: is 0:9"},
      {tf + "--slurm --tasks 6", "--tasks: is 6, expected 1..5"},
      {tf + "--slurm --tasks -1", "--tasks: must be in [0, 100000], got -1"},
      {tf + "--tasks 2", "only with --slurm"},
      {tf + "--exposures 1.5", "--exposures: must be in [0.01, 0.99], got 1.5"},
      {tf + "--exposures 0.5,0.5", "--exposures: exposure 0.5 is given twice"},
      {tf + "--slurm --trees 0:2", "--trees: not with --slurm"},
      {tool("train-forest") + " --merge " + q(d / "a.json") + " " + q(d) + " --trees 0:1 -o x.json", "--merge: not with"},
      {tool("run-experiment") + " " + q(d / "none.json") + " --tasks 2 -o " + q(d / "r"), "only with --slurm"}};
  for (const auto& [command, expected] : cases) {
    const auto r = run(command);
    EXPECT_EQ(r.status, 2) << command << "\n" << r.out;
    EXPECT_EQ(count_lines(r.out), 1) << command << "\n" << r.out;
    EXPECT_NE(r.out.find(expected), std::string::npos) << command << "\n" << r.out;
  }
  EXPECT_FALSE(fs::exists(d / "f.json"));
}

TEST(SlurmUsage, DryRunPrintsBothScriptsAndSubmitsNothing) {
  const fs::path d = test_dir("dry-run");
  smseg::write_json_atomic(d / "tiny.json", tiny_config());
  const auto r = run("PATH=/nonexistent " + tool("run-experiment") + " " + q(d / "tiny.json") +
                     " --slurm --tasks 2 --slurm-dry-run --slurm-arg=--partition=short -o " + q(d / "out") +
                     " --cache " + q(kRoot / "cache"));
  ASSERT_EQ(r.status, 0) << r.out;
  for (const char* expected : {"#SBATCH --array=0-1", "--points' '0,1'", "--points' '2,3'", "#SBATCH --partition=short",
                               "sbatch --parsable --dependency=afterok:<array job id>", "'--slurm-gather'",
                               "#SBATCH --kill-on-invalid-dep=yes"})
    EXPECT_NE(r.out.find(expected), std::string::npos) << expected << "\n" << r.out;
  EXPECT_FALSE(fs::exists(d / "out/slurm/job.sh"));
  EXPECT_FALSE(fs::exists(d / "out/slurm/gather.sh"));
}

TEST(SlurmUsage, SbatchMissingIsOneLine) {
  const fs::path d = test_dir("no-sbatch");
  smseg::write_json_atomic(d / "tiny.json", tiny_config());
  const auto r = run("PATH=/nonexistent " + tool("run-experiment") + " " + q(d / "tiny.json") + " --slurm --tasks 2 -o " +
                     q(d / "out") + " --cache " + q(kRoot / "cache"));
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_EQ(count_lines(r.out), 1) << r.out;
  EXPECT_NE(r.out.find("sbatch: not found on PATH"), std::string::npos) << r.out;
}
