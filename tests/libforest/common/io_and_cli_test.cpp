// What every tool shares: reading and writing files with errors that name the file and say the real
// problem, and the command-line conventions (--threads, unsigned options, exit status 2 for bad usage).
#include <gtest/gtest.h>

#include <fstream>
#include <algorithm>
#include <functional>
#include <string>
#include <vector>

#include <oneapi/tbb/task_arena.h>

#include "smseg/common/cli.hpp"
#include "smseg/common/io.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;

namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const smseg::Error& e) {
    return e.what();
  }
  return "(no error)";
}

/// run_tool with a --threads option on argv (the program name first); the body records how many
/// threads it runs on.
int exit_status(std::vector<std::string> args, int& threads_seen) {
  CLI::App app{"t", "t"};
  int threads = 0;
  smseg::add_threads_option(app, threads);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  return smseg::run_tool(app, static_cast<int>(argv.size()), argv.data(), threads, [&] {
    threads_seen = tbb::this_task_arena::max_concurrency();
    return 0;
  });
}

}  // namespace

TEST(Files, AFolderWhereAFileIsExpectedIsCalledAFolder) {
  const fs::path dir = smseg::test::temp_dir("io_folder");
  fs::create_directories(dir / "sub");
  EXPECT_EQ(smseg::why_not_a_file(dir / "sub"), "is a folder, expected a file");
  EXPECT_EQ(smseg::why_not_a_file(dir / "missing"), "does not exist");
  EXPECT_EQ(smseg::why_not_a_file("/dev/null"), "is a device, expected a regular file");
  EXPECT_EQ(error_of([&] { smseg::read_file(dir / "sub"); }), (dir / "sub").string() + ": is a folder, expected a file");
  // Writing over a folder: the folder is named, the reason is the real one (not "Success"), and no
  // temporary file is left beside it.
  fs::create_directories(dir / "out.json" / "x");
  EXPECT_EQ(error_of([&] { smseg::write_json_atomic(dir / "out.json", smseg::Json::object()); }),
            (dir / "out.json").string() + ": is a folder, expected a file");
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 2);  // sub, out.json
  fs::remove_all(dir);
}

TEST(Files, AJsonNumberOutOfRangeNamesTheFile) {
  const fs::path dir = smseg::test::temp_dir("io_json_overflow");
  std::ofstream(dir / "big.json") << "{\"K\": 1e999}";
  const std::string e = error_of([&] { smseg::read_json(dir / "big.json"); });
  EXPECT_EQ(e, (dir / "big.json").string() + ": a number is too large for a double (beyond 1.8e308)");
  EXPECT_EQ(e.find("[json.exception"), std::string::npos) << e;
  fs::remove_all(dir);
}

TEST(Cli, SeedsTakeOnlyDecimalDigits) {
  for (const std::string bad : {"-1", "010", "0x10", "1e3", "", "18446744073709551616000"}) {
    std::string v = bad;
    EXPECT_FALSE(smseg::kDecimalDigits(v).empty()) << bad;
  }
  for (const std::string good : {"0", "7", "18446744073709551615"}) {
    std::string v = good;
    EXPECT_TRUE(smseg::kDecimalDigits(v).empty()) << good;
  }
}

TEST(Cli, ThreadsOutsideTheirRangeAreBadUsageAndEightMeansEight) {
  for (const std::string bad : {"-3", "-1", "1025", "many"}) {
    int seen = 0;
    testing::internal::CaptureStderr();
    EXPECT_EQ(exit_status({"t", "--threads", bad}, seen), 2) << bad;
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_NE(err.find("--threads"), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  }
  // More threads than this machine has cores are really there (an arena of that many).
  for (int n : {1, 2, 8}) {
    int seen = 0;
    EXPECT_EQ(exit_status({"t", "--threads", std::to_string(n)}, seen), 0);
    EXPECT_EQ(seen, n);
  }
}
