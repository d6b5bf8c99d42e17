// kill -9 tests of the two tools that resume instead of replacing their output: extract-features keeps
// every complete stack of a killed run and computes only the missing ones; run-experiment keeps every
// complete line of experiment.jsonl and runs only the points left. After a kill no file is partial
// (each equals the uninterrupted run's, or for the records its complete lines do); the rerun reuses
// what is there, ends with the uninterrupted run's bytes (timing fields aside) and removes the
// temporaries.
#include <gtest/gtest.h>

#include <cstdlib>

#include <regex>

#include "kill_harness.hpp"
#include "kill_points.hpp"
#include "run_tool.hpp"
#include "temp_dir.hpp"

namespace {

using namespace smseg::test;

const fs::path kSmallCorridor(SMSEG_SMALL_CORRIDOR);

std::string shell(const Command& cmd) {
  std::string s;
  for (const auto& a : cmd) s += (s.empty() ? "'" : " '") + a + "'";
  return s;
}

/// How many stacks a rerun of extract-features reports as already done ("N frames written, M already
/// done"); -1 when it does not say.
int frames_already_done(const std::string& out) {
  std::smatch m;
  if (!std::regex_search(out, m, std::regex(R"((\d+) frames written, (\d+) already done)"))) return -1;
  return std::stoi(m[2]);
}

/// The frames of a work folder whose stack file (one values file a frame) is there.
int complete_stacks(const Files& now, const Files& fresh) {
  int n = 0;
  for (const auto& [name, bytes] : fresh) n += name.ends_with(".values.bin") && now.count(name);
  return n;
}

/// After a kill, a work folder holds only complete files: each equals the uninterrupted run's, except
/// stacks.json, which a killed run leaves with the frames of before it (written first: it lists fewer).
void expect_complete_work_files(const Files& raw_now, const Files& fresh, const Files& fresh_raw, const std::string& at) {
  for (const auto& [name, bytes] : raw_now) {
    if (is_temporary_name(fs::path(name).filename().string())) continue;  // the rerun must remove it
    ASSERT_TRUE(fresh.count(name)) << name << " is not a file of the uninterrupted run, killed " << at;
    if (name.ends_with("stacks.json")) {
      const auto now = nlohmann::json::parse(bytes, nullptr, false);
      ASSERT_FALSE(now.is_discarded()) << name << " is not whole JSON, killed " << at;
      const auto want = nlohmann::json::parse(fresh_raw.at(name));
      EXPECT_EQ(now["options"], want["options"]) << "killed " << at;
      for (const auto& f : now["frames"])
        EXPECT_NE(std::find(want["frames"].begin(), want["frames"].end(), f), want["frames"].end()) << f;
      continue;
    }
    EXPECT_EQ(comparable(name, bytes), fresh.at(name)) << name << " is partial or not the run's, killed " << at;
  }
}

/// experiment.jsonl's lines without timing fields, and a last line without its end (a torn append).
struct Records {
  std::vector<std::string> complete;
  std::string torn;
};

Records records(const fs::path& jsonl) {
  Records r;
  const std::string text = fs::exists(jsonl) ? read_bytes(jsonl) : "";
  std::size_t pos = 0;
  for (std::size_t nl; (nl = text.find('\n', pos)) != std::string::npos; pos = nl + 1)
    r.complete.push_back(comparable(".json", text.substr(pos, nl - pos)));
  r.torn = text.substr(pos);
  return r;
}

}  // namespace

TEST(Kill, ExtractFeaturesResumesFromTheCompleteStacks) {
  const fs::path dir = temp_dir("kill_extract"), work = dir / "work";
  const Command extract = {tool("extract-features"), "-q", (kSmallCorridor / "data" / "corridor").string(), "-o",
                           work.string(), "--future-frames", "10"};
  const Measured m = measured_run(extract, dir);
  ASSERT_GT(m.seconds, 0);
  const Files fresh_raw = snapshot(dir, {work}), fresh = comparable(fresh_raw);

  // Nothing there before: a kill leaves complete files only; the rerun keeps every complete stack.
  int resumed = 0;
  for (const KillPoint& p : kill_points(1901, 2, m.seconds, 3, m.peak_new_entries)) {
    fs::remove_all(work);
    run_and_kill(extract, p, dir);
    const Files now = snapshot(dir, {work});
    expect_complete_work_files(now, fresh, fresh_raw, p.str());
    const int complete = complete_stacks(now, fresh);
    const Outcome r = run(shell(extract));
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_EQ(frames_already_done(r.out), complete) << "killed " << p.str() << ": " << r.out;
    resumed += complete;
    const Files after = comparable(snapshot(dir, {work}));
    EXPECT_EQ(after, fresh) << "rerun after a kill " << p.str() << ":" << difference(fresh, after);
    const auto left = leftover_temporaries(dir);
    EXPECT_TRUE(left.empty()) << "after the rerun (kill " << p.str() << "): " << left.front();
  }
  EXPECT_GT(resumed, 0) << "no kill landed after a stack was written: the resume was not tried";

  // A complete work folder of the same options there: a killed run leaves it as it was (it rewrites
  // the same bytes), and the rerun writes no stack.
  // One kill lands while a temporary is there for certain (the timed ones only by chance).
  auto points = kill_points(1902, 3, m.seconds, 0, 0);
  points.push_back({-1, 0, "tracks.json.tmp."});
  for (const KillPoint& p : points) {
    restore(dir, {work}, fresh_raw);
    if (p.appears.empty()) {
      run_and_kill(extract, p, dir);
    } else {
      // The poller walks the whole test folder between two looks (slower still under the sanitizers
      // and a loaded machine), so the 5 ms pause of a write can pass unseen: these runs pause 200 ms
      // in every write, and the kill is tried again (up to 5 runs) until it lands.
      ::setenv("SMSEG_TEST_WRITE_PAUSE_MS", "200", 1);
      bool landed = false;
      for (int attempt = 0; attempt < 5 && !landed; ++attempt) {
        restore(dir, {work}, fresh_raw);
        landed = run_and_kill(extract, p, dir);
      }
      ::unsetenv("SMSEG_TEST_WRITE_PAUSE_MS");
      EXPECT_TRUE(landed) << "five runs ended before " << p.str();
    }
    // A temporary may be there (a kill between write and rename); the rerun below must remove it.
    const Files now = comparable(without_temporaries(snapshot(dir, {work})));
    EXPECT_EQ(now, fresh) << "killed " << p.str() << ":" << difference(fresh, now);
    const Outcome r = run(shell(extract));
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("0 frames written"), std::string::npos) << r.out;
    EXPECT_TRUE(leftover_temporaries(dir).empty());
  }
  fs::remove_all(dir);
}

TEST(Kill, RunExperimentKeepsItsCompleteLinesAndResumes) {
  const fs::path dir = temp_dir("kill_experiment"), out = dir / "results";
  const nlohmann::json cfg = {
      {"format", "smseg-experiment"},
      {"version", 1},
      {"name", "kill"},
      {"sequences", {{"c", {{"work", (kSmallCorridor / "work" / "corridor").string()}}}}},
      {"fixed", {{"train", "c"}, {"train_frames", "0:13"}, {"test_frames", "13:"}, {"M", 2}}},
      {"sweep", {{"K", {10, 20, 30, 40}}}}};
  const fs::path config = dir / "kill.json";
  std::ofstream(config) << cfg.dump(1) << "\n";
  const Command experiment = {tool("run-experiment"), "-q", config.string(), "-o", out.string()};
  const Measured m = measured_run(experiment, dir);
  ASSERT_GT(m.seconds, 0);
  const Records fresh = records(out / "experiment.jsonl");
  ASSERT_EQ(fresh.complete.size(), 4u);
  const std::string fresh_config = comparable("config.json", read_bytes(out / "config.json"));

  // Both ways: no results before, and a results folder with its first point done (--max-points 1),
  // whose line must stay byte for byte.
  for (const bool partial_before : {false, true}) {
    fs::remove_all(out);
    if (partial_before) {
      ASSERT_EQ(run(shell(experiment) + " --max-points 1").status, 0);
    }
    const std::string before = fs::exists(out) ? read_bytes(out / "experiment.jsonl") : "";
    const Files previous = snapshot(dir, {out});
    for (const KillPoint& p : kill_points(partial_before ? 2002 : 2001, 3, m.seconds, 2, m.peak_new_entries)) {
      restore(dir, {out}, previous);
      run_and_kill(experiment, p, dir);
      if (fs::exists(out / "config.json")) {
        EXPECT_EQ(comparable("config.json", read_bytes(out / "config.json")), fresh_config);
      }
      const std::string text = fs::exists(out / "experiment.jsonl") ? read_bytes(out / "experiment.jsonl") : "";
      EXPECT_EQ(text.substr(0, before.size()), before) << "killed " << p.str() << ": the earlier lines changed";
      const Records now = records(out / "experiment.jsonl");
      ASSERT_LE(now.complete.size(), fresh.complete.size());
      for (std::size_t i = 0; i < now.complete.size(); ++i)
        EXPECT_EQ(now.complete[i], fresh.complete[i]) << "line " << i + 1 << ", killed " << p.str();
      const Outcome r = run(shell(experiment));
      ASSERT_EQ(r.status, 0) << "rerun after a kill " << p.str() << ": " << r.out;
      const Records after = records(out / "experiment.jsonl");
      EXPECT_EQ(after.complete, fresh.complete) << "rerun after a kill " << p.str();
      EXPECT_TRUE(after.torn.empty());
      const auto left = leftover_temporaries(dir);
      EXPECT_TRUE(left.empty()) << "after the rerun (kill " << p.str() << "): " << left.front();
    }
  }
  // A line torn by a kill in the middle of its append (rare: a record is one write) is cut by the rerun,
  // which then runs that point again.
  fs::remove_all(out);
  ASSERT_EQ(run(shell(experiment) + " --max-points 1").status, 0);
  const std::string second = read_bytes(out / "experiment.jsonl");
  std::ofstream(out / "experiment.jsonl", std::ios::app) << second.substr(0, second.size() / 2);
  const Outcome r = run(shell(experiment));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(records(out / "experiment.jsonl").complete, fresh.complete);
  fs::remove_all(dir);
}
