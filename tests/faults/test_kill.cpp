// kill -9 at seeded points of a run of each tool that writes results (issue 19, part 3). After each
// kill the output holds its complete previous content or nothing (never a partial file, never a mix of
// two runs); a rerun then ends with the bytes of an uninterrupted run (timing fields aside) and leaves
// no temporaries. Each tool runs both ways: nothing at the output path before, and an older complete
// result there. The kill points are seeded: moments spread over the measured run, and counts of new
// files polled in the output folder (so that kills land while files are being written).
#include <gtest/gtest.h>

#include <fstream>

#include "kill_harness.hpp"
#include "kill_points.hpp"
#include "run_tool.hpp"
#include "temp_dir.hpp"

namespace {

using namespace smseg::test;

const fs::path kSmallCorridor(SMSEG_SMALL_CORRIDOR);
fs::path small_work() { return kSmallCorridor / "work" / "corridor"; }

/// One tool's run that the test kills, and what it writes.
struct Scenario {
  Command command;
  std::vector<fs::path> outputs;  ///< files or folders the run writes
  fs::path base;                  ///< the test's folder: names are relative to it; no temporary may stay in it
  std::string summary;            ///< segment-cloud: the file (relative) that marks a complete set of outputs
  std::vector<std::string> kill_when_named = {};  ///< also kill as soon as a file named so (prefix) appears
};

/// After a kill the outputs hold what they held before the run or what an uninterrupted run leaves.
/// With a summary marker, outputs without their summary may hold complete files of either run.
void expect_previous_or_fresh(const Files& now, const Files& previous, const Files& fresh, const Scenario& s,
                              const std::string& at) {
  if (now == previous || now == fresh) return;
  if (!s.summary.empty() && !now.count(s.summary)) {
    for (const auto& [name, bytes] : now) {
      const bool old_file = previous.count(name) && previous.at(name) == bytes;
      const bool new_file = fresh.count(name) && fresh.at(name) == bytes;
      EXPECT_TRUE(old_file || new_file) << name << " is neither the previous nor the new file, killed " << at;
    }
    return;
  }
  ADD_FAILURE() << "killed " << at << ": the output is neither the previous content (" << difference(previous, now)
                << ") nor the new one (" << difference(fresh, now) << ")";
}

/// The rerun after a kill: it succeeds, ends with the uninterrupted run's output and removes every
/// temporary the killed run left.
void expect_clean_rerun(const Scenario& s, const Files& fresh, const std::string& at) {
  ASSERT_GT(measured_run(s.command, s.base).seconds, 0) << "the rerun after a kill " << at << " failed";
  const Files after = comparable(snapshot(s.base, s.outputs));
  EXPECT_EQ(after, fresh) << "rerun after a kill " << at << ":" << difference(fresh, after);
  const auto left = leftover_temporaries(s.base);
  EXPECT_TRUE(left.empty()) << "after the rerun (kill " << at << "): " << left.front();
}

/// Kills s.command at seeded points (`by_time` moments, `by_files` counts of new files), each time
/// starting from `previous`; checks each kill and rerun.
void kill_and_rerun(const Scenario& s, const Files& previous, std::uint32_t seed, int by_time = 3, int by_files = 2) {
  restore(s.base, s.outputs, previous);
  const Measured m = measured_run(s.command, s.base);
  ASSERT_GT(m.seconds, 0) << "the uninterrupted run failed: " << s.command[0];
  const Files fresh = comparable(snapshot(s.base, s.outputs));
  ASSERT_FALSE(fresh.empty());
  ASSERT_NE(fresh, comparable(previous)) << "the previous content must differ from the new, or a mix would not show";
  auto points = kill_points(seed, by_time, m.seconds, by_files, m.peak_new_entries);
  for (const auto& name : s.kill_when_named) points.push_back({-1, 0, name});
  int landed = 0;
  for (const KillPoint& p : points) {
    restore(s.base, s.outputs, previous);
    landed += run_and_kill(s.command, p, s.base);
    EXPECT_TRUE(no_process_outlives_in(s.base)) << "a child of " << s.command[0] << " still runs, killed " << p.str();
    expect_previous_or_fresh(comparable(snapshot(s.base, s.outputs)), comparable(previous), fresh, s, p.str());
    expect_clean_rerun(s, fresh, p.str());
  }
  EXPECT_GE(landed, static_cast<int>(points.size()) / 2) << "too few kills landed while " << s.command[0] << " ran";
}

/// Runs a command to its end (for the inputs and older results the scenarios need).
void must_run(const std::string& command) {
  const Outcome r = run(command);
  ASSERT_EQ(r.status, 0) << command << "\n" << r.out;
}

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

/// A forest of the small corridor, for eval-forest.
fs::path train_small_forest(const fs::path& dir) {
  const fs::path forest = dir / "input-forest.json";
  must_run(tool("train-forest") + " -q " + q(small_work()) + " --train-frames 0:13 -K 20 -M 3 -o " + q(forest));
  return forest;
}

/// A two-point experiment on the small corridor's work folder, with one figure, written to dir/NAME.json.
fs::path write_small_experiment(const fs::path& dir) {
  const nlohmann::json cfg = {
      {"format", "smseg-experiment"},
      {"version", 1},
      {"name", "kill"},
      {"sequences", {{"c", {{"work", small_work().string()}}}}},
      {"fixed", {{"train", "c"}, {"train_frames", "0:13"}, {"test_frames", "13:"}, {"M", 2}}},
      {"sweep", {{"K", {10, 20, 30}}}},
      {"figures", {{{"id", "acc"}, {"title", "Accuracy"}, {"x", "K"}, {"y", "global_accuracy"}}}}};
  const fs::path file = dir / "kill.json";
  std::ofstream(file) << cfg.dump(1) << "\n";
  return file;
}

}  // namespace

TEST(Kill, TrainForestLeavesTheOldForestOrNone) {
  const fs::path dir = temp_dir("kill_train");
  const fs::path forest = dir / "forest.json", part = dir / "part.json";
  const Command train = {tool("train-forest"), "-q", small_work().string(), "--train-frames", "0:13", "-K", "30",
                         "-M", "4", "--seed", "5", "-o", forest.string()};
  kill_and_rerun({train, {forest}, dir, ""}, {}, 101);
  must_run(tool("train-forest") + " -q " + q(small_work()) + " --train-frames 0:13 -K 30 -M 4 --seed 6 -o " + q(forest));
  kill_and_rerun({train, {forest}, dir, ""}, snapshot(dir, {forest}), 102);
  // A part of the trees (--trees A:B, one Slurm task's work) is written the same way.
  fs::remove(forest);
  const Command train_part = {tool("train-forest"), "-q", small_work().string(), "--train-frames", "0:13", "-K", "30",
                              "-M", "4", "--seed", "5", "--trees", "1:3", "-o", part.string()};
  kill_and_rerun({train_part, {part}, dir, ""}, {}, 103);
  fs::remove_all(dir);
}

TEST(Kill, EvalForestLeavesTheOldFolderOrNone) {
  const fs::path dir = temp_dir("kill_eval");
  const fs::path forest = train_small_forest(dir), out = dir / "eval";
  const Command eval = {tool("eval-forest"), "-q", forest.string(), small_work().string(), "--test-frames", "13:",
                        "-o", out.string()};
  kill_and_rerun({eval, {out}, dir, ""}, {}, 201);
  // An older result of other options (other pictures, other scores), and a file of the user's that
  // every run keeps: a mix of the two runs, or a lost file, would show.
  must_run(tool("eval-forest") + " -q " + q(forest) + " " + q(small_work()) + " --test-frames 13: --grid 10 --votes 3 -o " +
           q(out));
  std::ofstream(out / "notes.txt") << "the user's own file\n";
  kill_and_rerun({eval, {out}, dir, ""}, snapshot(dir, {out}), 202);
  EXPECT_TRUE(fs::exists(out / "notes.txt"));
  fs::remove_all(dir);
}

TEST(Kill, LabelStreamLeavesTheOldFolderOrNone) {
  const fs::path dir = temp_dir("kill_stream");
  const fs::path forest = train_small_forest(dir), out = dir / "stream";
  const fs::path seq = kSmallCorridor / "data" / "corridor";
  const Command stream = {tool("label-stream"), "-q", seq.string(), forest.string(), "--overlays", "-o", out.string()};
  kill_and_rerun({stream, {out}, dir, ""}, {}, 501);
  // An older result of other options (grid labels, no overlays), and a file of the user's.
  must_run(tool("label-stream") + " -q " + q(seq) + " " + q(forest) + " --grid 10 --votes 3 -o " + q(out));
  std::ofstream(out / "notes.txt") << "the user's own file\n";
  kill_and_rerun({stream, {out}, dir, ""}, snapshot(dir, {out}), 502);
  EXPECT_TRUE(fs::exists(out / "notes.txt"));
  fs::remove_all(dir);
}

TEST(Kill, SegmentCloudLeavesNoSummaryBesideAnotherRunsFiles) {
  const fs::path dir = temp_dir("kill_cloud");
  const fs::path input = dir / "input-table.pcd", out = dir / "seg.pcd";
  must_run(tool("segment-cloud") + " --make-tabletop 6000 --objects 4 --seed 3 -o " + q(input));
  const Command segment = {tool("segment-cloud"), input.string(), "--method", "mrf", "-o", out.string()};
  const fs::path summary = dir / "seg.pcd.json";
  // Also killed while the summary is being written, the cloud done: the moment a new cloud stands
  // beside the old summary unless the old one was removed first.
  const Scenario s{segment, {out, summary}, dir, "seg.pcd.json", {"seg.pcd.json.tmp."}};
  kill_and_rerun(s, {}, 301, 2, 2);
  // An older result of another method: another cloud, another summary.
  must_run(tool("segment-cloud") + " " + q(input) + " --method centroid-mincut --radius 0.5 -o " + q(out));
  kill_and_rerun(s, snapshot(dir, {out, summary}), 302, 2, 2);
  fs::remove_all(dir);
}

TEST(Kill, ExportNotebooksLeavesTheOldFolderOrNone) {
  const fs::path dir = temp_dir("kill_notebooks");
  const fs::path results = dir / "input-results" / "kill", out = dir / "notebooks";
  must_run(tool("run-experiment") + " -q " + q(write_small_experiment(dir)) + " -o " + q(results));
  const Command export_nb = {tool("export-notebooks"), "-q", results.parent_path().string(), "-o", out.string()};
  // Drawing the figures (Python, matplotlib) takes most of a run: fewer kill points.
  kill_and_rerun({export_nb, {out}, dir, ""}, {}, 401, 2, 1);
  // An older export without figures, and a file of the user's.
  must_run(tool("export-notebooks") + " -q --no-png " + q(results.parent_path()) + " -o " + q(out));
  std::ofstream(out / "README.txt") << "the user's own file\n";
  kill_and_rerun({export_nb, {out}, dir, ""}, snapshot(dir, {out}), 402, 2, 1);
  fs::remove_all(dir);
}
