// Every reader bounds what it reads: read_file refuses a regular file larger than its limit before
// reading it, takes nothing but regular files (a FIFO, a device or a socket is refused at once), names
// the file when the process has no room for it (an address-space limit), and JSON nested beyond any
// format of ours is refused before a recursive copy of it could overflow the stack.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fcntl.h>
#include <future>
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

TEST(ReadLimits, FifoDeviceAndSocketAreRefusedAtOnce) {
  const fs::path dir = smseg::test::temp_dir("io-kinds");
  // A FIFO with no writer: opening it used to wait for one, forever.
  const fs::path fifo = dir / "sequence.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  auto reading = std::async(std::launch::async, [&] { return error_of([&] { smseg::read_json(fifo); }); });
  if (reading.wait_for(std::chrono::seconds(5)) != std::future_status::ready) {
    const int writer = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);  // lets the blocked reader go on
    if (writer >= 0) ::close(writer);
    ADD_FAILURE() << "reading a FIFO with no writer did not return within 5 s";
  }
  EXPECT_EQ(reading.get(), fifo.string() + ": is a FIFO (named pipe), expected a regular file");
  // A device: endless (/dev/zero) or empty (/dev/null), neither is a file someone wrote.
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(error_of([] { smseg::read_file("/dev/zero", 4 * smseg::kMiB); }),
            "/dev/zero: is a device, expected a regular file");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0);
  EXPECT_EQ(error_of([] { smseg::read_json("/dev/null"); }), "/dev/null: is a device, expected a regular file");
  EXPECT_EQ(smseg::why_not_a_file(fifo), "is a FIFO (named pipe), expected a regular file");
  // A socket.
  const fs::path socket_path = dir / "stacks.json";
  const int sock = ::socket(AF_UNIX, SOCK_STREAM, 0);
  ASSERT_GE(sock, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::snprintf(address.sun_path, sizeof address.sun_path, "%s", socket_path.c_str());
  ASSERT_EQ(::bind(sock, reinterpret_cast<const sockaddr*>(&address), sizeof address), 0);
  EXPECT_EQ(error_of([&] { smseg::read_json(socket_path); }),
            socket_path.string() + ": is a socket, expected a regular file");
  ::close(sock);
  fs::remove_all(dir);
}

TEST(ReadLimits, JsonNestedTooDeeplyIsRefusedNamingTheFileAndThePlace) {
  const fs::path dir = smseg::test::temp_dir("io-depth");
  const fs::path file = dir / "config.json";
  // 600,000 levels in a 1.2 MB file: parsed, then copied or printed by recursion, it overflows the stack.
  { std::ofstream(file) << std::string(600000, '[') << std::string(600000, ']'); }
  EXPECT_EQ(error_of([&] { smseg::read_json(file); }),
            file.string() + ": nested deeper than 256 levels of arrays and objects at line 1, column 257 "
                            "(no file of this toolkit nests so deep)");
  // Brackets inside strings are text, and 256 levels are read.
  { std::ofstream(file) << "{\"a\": \"" << std::string(1000, '[') << "\", \"b\": " << std::string(255, '[')
                        << std::string(255, ']') << "}"; }
  const smseg::Json doc = smseg::read_json(file);
  EXPECT_EQ(doc["a"].get<std::string>().size(), 1000u);
  fs::remove_all(dir);
}

namespace {

/// Runs read in a child process whose address space may grow by only `room` bytes beyond what it maps
/// now, and returns the error line it gave ("(accepted)", or what else escaped from it).
std::string error_under_address_limit(std::uintmax_t room, const std::function<void()>& read) {
  int out[2];
  if (::pipe(out) != 0) return "(no pipe)";
  const pid_t child = ::fork();
  if (child == 0) {
    ::close(out[0]);
    std::string said;
    try {
      std::uintmax_t pages = 0;
      FILE* statm = std::fopen("/proc/self/statm", "r");
      if (!statm || std::fscanf(statm, "%ju", &pages) != 1) _exit(3);
      std::fclose(statm);
      const rlim_t limit = pages * static_cast<std::uintmax_t>(::sysconf(_SC_PAGESIZE)) + room;
      const rlimit as{limit, limit};
      if (::setrlimit(RLIMIT_AS, &as) != 0) _exit(3);
      said = error_of(read);
    } catch (const std::bad_alloc&) {
      said = "(std::bad_alloc escaped)";
    } catch (const std::exception& e) {
      said = std::string("(escaped: ") + e.what() + ")";
    }
    const ssize_t written = ::write(out[1], said.data(), said.size());
    _exit(written == static_cast<ssize_t>(said.size()) ? 0 : 3);
  }
  ::close(out[1]);
  std::string said;
  char buffer[4096];
  for (ssize_t n; (n = ::read(out[0], buffer, sizeof buffer)) > 0;) said.append(buffer, static_cast<std::size_t>(n));
  ::close(out[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  return said;
}

}  // namespace

TEST(ReadLimits, NoRoomForAFileIsSaidNamingTheFileBeforeItIsRead) {
  const fs::path dir = smseg::test::temp_dir("io-room");
  // A file within the reader's limit that the process has no room for: refused before the buffer.
  const fs::path sparse = dir / "forest.json";
  { std::ofstream(sparse) << "{"; }
  fs::resize_file(sparse, 200 * smseg::kMiB);
  const std::string big = error_under_address_limit(64 * smseg::kMiB, [&] { smseg::read_json(sparse, smseg::kMaxLargeFileBytes); });
  EXPECT_EQ(big.rfind(sparse.string() + ": is 200 MiB; reading it needs about 200 MiB of memory, and this process may take only ", 0), 0u)
      << big;
  EXPECT_NE(big.find("(its address-space limit, ulimit -v)"), std::string::npos) << big;
  // A file that fits, but whose parsed document does not: 8 MiB of object members parse into ~60 MiB,
  // and 8 MiB of small numbers in one array into 64 MiB (128 MiB while the array grows). Counted as
  // they are read, and refused before the allocation that would fail (which, in nlohmann's destructor
  // of the document cut short, could end the process).
  const fs::path members = dir / "stacks.json", numbers = dir / "tracks.json";
  {
    std::ofstream out(members);
    out << "{\"k0\":0";
    for (int i = 1; out.tellp() < 8 * std::streamoff(smseg::kMiB); ++i) out << ",\"k" << i << "\":0";
    out << "}";
  }
  {
    std::ofstream out(numbers);
    out << "[0";
    for (int i = 0; i < 4 * 1024 * 1024 - 1; ++i) out << ",0";
    out << "]";
  }
  for (const fs::path& file : {members, numbers}) {
    const std::string parsed = error_under_address_limit(48 * smseg::kMiB, [&] { smseg::read_json(file); });
    EXPECT_EQ(parsed.rfind(file.string() + ": is 8 MiB of JSON; parsing it would take more than the ", 0), 0u) << parsed;
  }
  // With room enough, both are read.
  EXPECT_EQ(error_under_address_limit(1024 * smseg::kMiB, [&] { smseg::read_json(members); }), "(accepted)");
  EXPECT_EQ(error_under_address_limit(1024 * smseg::kMiB, [&] { smseg::read_json(numbers); }), "(accepted)");
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
