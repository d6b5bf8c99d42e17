// The kill -9 safety of output (smseg/common/output.hpp): which temporaries a later run removes, and a
// folder swapped in whole. The tools under kill -9 are in tests/faults.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <fstream>

#include "temp_dir.hpp"
#include "smseg/common/io.hpp"
#include "smseg/common/output.hpp"

namespace fs = std::filesystem;

namespace {

/// The pid of a process that has ended (a child that exited and was reaped).
long dead_pid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return pid;
}

void touch(const fs::path& p, const std::string& text = "x") { std::ofstream(p) << text; }

std::string tmp_name(const std::string& base, const std::string& host, long pid, const std::string& rest = ".0") {
  return base + ".tmp." + host + "." + std::to_string(pid) + rest;
}

}  // namespace

TEST(Output, StaleTemporariesOfDeadProcessesOfThisHostGo) {
  const fs::path dir = smseg::test::temp_dir("output_stale");
  const std::string host = smseg::host_name();
  const long dead = dead_pid(), live = ::getppid();
  touch(dir / "forest.json");
  touch(dir / tmp_name("forest.json", host, dead));                  // killed between write and rename
  touch(dir / tmp_name("cloud.pcd", host, dead, ".3.pcd"));          // PCL's, with the extension
  fs::create_directories(dir / tmp_name("eval", host, dead, ""));   // a killed folder replacement
  touch(dir / tmp_name("part.json", host, live));                    // a live writer's
  touch(dir / tmp_name("part.json", "another-host", dead));          // another machine's: its pid means nothing here
  touch(dir / "notes.tmp.txt");                                      // not a temporary of ours
  EXPECT_EQ(smseg::remove_stale_temporaries(dir), 3);
  EXPECT_TRUE(fs::exists(dir / "forest.json"));
  EXPECT_FALSE(fs::exists(dir / tmp_name("forest.json", host, dead)));
  EXPECT_FALSE(fs::exists(dir / tmp_name("cloud.pcd", host, dead, ".3.pcd")));
  EXPECT_FALSE(fs::exists(dir / tmp_name("eval", host, dead, "")));
  EXPECT_TRUE(fs::exists(dir / tmp_name("part.json", host, live)));
  EXPECT_TRUE(fs::exists(dir / tmp_name("part.json", "another-host", dead)));
  EXPECT_TRUE(fs::exists(dir / "notes.tmp.txt"));
  EXPECT_EQ(smseg::remove_stale_temporaries(dir / "missing"), 0);
  fs::remove_all(dir);
}

TEST(Output, AFolderMovedAsideByAKilledSwapGoesBack) {
  const fs::path dir = smseg::test::temp_dir("output_old");
  const long dead = dead_pid();
  const fs::path old = dir / ("eval.old." + smseg::host_name() + "." + std::to_string(dead));
  fs::create_directories(old);
  touch(old / "results.json", "previous");
  EXPECT_EQ(smseg::remove_stale_temporaries(dir), 1);
  EXPECT_EQ(smseg::read_file(dir / "eval" / "results.json"), "previous");
  EXPECT_FALSE(fs::exists(old));
  fs::remove_all(dir);
}

TEST(Output, WriteFileAtomicLeavesOnlyTheFile) {
  const fs::path dir = smseg::test::temp_dir("output_atomic");
  smseg::write_file_atomic(dir / "a.json", "{}\n");
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 1);
  const std::string name = smseg::temporary_beside(dir / "a.json", ".pcd").filename().string();
  EXPECT_EQ(name.rfind("a.json.tmp." + smseg::host_name() + "." + std::to_string(::getpid()) + ".", 0), 0u) << name;
  EXPECT_TRUE(name.ends_with(".pcd")) << name;
  fs::remove_all(dir);
}

TEST(Output, AFolderIsReplacedWholeKeepingFilesTheNewContentLacks) {
  const fs::path dir = smseg::test::temp_dir("output_replace"), out = dir / "eval";
  fs::create_directories(out / "frames");
  touch(out / "results.json", "old");
  touch(out / "frames" / "000001.png", "old picture");
  touch(out / "sweep.jsonl", "kept");
  {
    smseg::FolderReplacement r(out);
    fs::create_directories(r.staging() / "frames");
    touch(r.staging() / "results.json", "new");
    touch(r.staging() / "frames" / "000002.png", "new picture");
    EXPECT_EQ(smseg::read_file(out / "results.json"), "old");  // untouched until the commit
    r.commit();
  }
  EXPECT_EQ(smseg::read_file(out / "results.json"), "new");
  EXPECT_TRUE(fs::exists(out / "frames" / "000002.png"));
  EXPECT_FALSE(fs::exists(out / "frames" / "000001.png"));  // frames/ is the new run's, whole
  EXPECT_EQ(smseg::read_file(out / "sweep.jsonl"), "kept");
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 1) << "the staging folder and the old content must be gone";
  fs::remove_all(dir);
}

TEST(Output, AFolderReplacementNotCommittedLeavesTheFolderAsItWas) {
  const fs::path dir = smseg::test::temp_dir("output_abandon"), out = dir / "eval";
  fs::create_directories(out);
  touch(out / "results.json", "old");
  {
    smseg::FolderReplacement r(out);
    touch(r.staging() / "results.json", "half");
  }  // an error before the commit
  EXPECT_EQ(smseg::read_file(out / "results.json"), "old");
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 1);
  fs::remove_all(dir);
}
