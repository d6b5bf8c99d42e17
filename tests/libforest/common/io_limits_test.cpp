// issue 19, defect 1: every reader bounds what it reads. read_file refuses a regular file larger than
// its limit before reading it, and stops an endless stream (/dev/zero, a FIFO) at the limit.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <fstream>
#include <functional>
#include <thread>

#include "smseg/common/io.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;

namespace {

std::string error_of(const std::function<void()>& read) {
  try {
    read();
  } catch (const smseg::Error& e) {
    return e.what();
  }
  return "(accepted)";
}

long max_rss_kb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

}  // namespace

TEST(ReadLimits, SparseFileOverTheLimitIsRefusedBeforeReading) {
  const fs::path dir = smseg::test::temp_dir("io-limits");
  const fs::path file = dir / "manifest.json";
  { std::ofstream(file) << "{"; }
  fs::resize_file(file, 40 * smseg::kMiB + 1);  // sparse: no disk, no page cache
  const long rss_before = max_rss_kb();
  EXPECT_EQ(error_of([&] { smseg::read_json(file, 40 * smseg::kMiB); }),
            file.string() + ": is larger than the 40 MiB this reader accepts");
  EXPECT_LT(max_rss_kb() - rss_before, 8 * 1024) << "the file was read into memory";
  fs::resize_file(file, 40 * smseg::kMiB);  // at the limit: read (and refused as JSON)
  EXPECT_NE(error_of([&] { smseg::read_json(file, 40 * smseg::kMiB); }).find("malformed JSON"), std::string::npos);
  fs::remove_all(dir);
}

TEST(ReadLimits, EndlessDeviceStopsAtTheLimit) {
  const long rss_before = max_rss_kb();
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(error_of([] { smseg::read_file("/dev/zero", 4 * smseg::kMiB); }),
            "/dev/zero: is larger than the 4 MiB this reader accepts");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0);
  EXPECT_LT(max_rss_kb() - rss_before, 32 * 1024);
}

TEST(ReadLimits, FifoIsReadToItsEndOrToTheLimit) {
  const fs::path dir = smseg::test::temp_dir("io-fifo");
  const fs::path fifo = dir / "stream.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::signal(SIGPIPE, SIG_IGN);  // the writer finds the reader gone: an error, not a killed test
  // A writer that sends more than the limit: the reader stops at the limit and says so.
  std::thread writer([&] {
    std::ofstream out(fifo, std::ios::binary);
    const std::string block(64 * 1024, ' ');
    for (int i = 0; i < 64 && out; ++i) out << block;  // 4 MiB, or until the reader closes
  });
  EXPECT_EQ(error_of([&] { smseg::read_file(fifo, 1 * smseg::kMiB); }),
            fifo.string() + ": is larger than the 1 MiB this reader accepts");
  writer.join();
  // A writer that sends a small document: read whole.
  std::thread small([&] { std::ofstream(fifo) << "{\"a\": 1}"; });
  EXPECT_EQ(smseg::read_json(fifo, 1 * smseg::kMiB)["a"], 1);
  small.join();
  fs::remove_all(dir);
}

TEST(ReadLimits, NumberBeyondADoubleNamesTheFile) {
  const fs::path dir = smseg::test::temp_dir("io-overflow");
  const fs::path file = dir / "big.json";
  { std::ofstream(file) << "{\"x\": 1e999}"; }
  EXPECT_EQ(error_of([&] { smseg::read_json(file); }),
            file.string() + ": a number is too large for a double (beyond 1.8e308)");
  fs::remove_all(dir);
}
