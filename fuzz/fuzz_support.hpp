#pragma once
// What every fuzzer shares: a per-process temporary folder for readers that take a path, and the rule
// that our documented "bad input" exception (smseg::Error) is a normal outcome. Anything else (another
// exception, a crash, a sanitizer report, a leak, a timeout) escapes to libFuzzer and is a finding.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "smseg/common/error.hpp"

namespace smseg::fuzz {

namespace fs = std::filesystem;

/// $TMPDIR (or /tmp)/smseg-fuzz-<pid>, made on first use and removed when the process exits normally.
class TempDir {
 public:
  TempDir() {
    const char* base = std::getenv("TMPDIR");
    path_ = fs::path(base && *base ? base : "/tmp") / ("smseg-fuzz-" + std::to_string(::getpid()));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

inline const fs::path& temp_dir() {
  static const TempDir dir;
  return dir.path();
}

/// Writes bytes to temp_dir()/name (replacing it) and returns the path.
inline fs::path write_temp(const std::string& name, std::string_view bytes) {
  const fs::path path = temp_dir() / name;
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path;
}

inline std::string_view as_bytes(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

/// Runs one reader on one input: smseg::Error is the reader refusing bad input, as documented. With
/// SMSEG_FUZZ_VERBOSE=1 in the environment it prints what the user would see ("bin/fuzz_forest FILE"
/// runs one file), or "accepted".
template <class Reader>
int run_reader(Reader&& reader) {
  static const bool verbose = std::getenv("SMSEG_FUZZ_VERBOSE") != nullptr;
  try {
    reader();
    if (verbose) std::fprintf(stderr, "smseg-fuzz: accepted\n");
  } catch (const smseg::Error& e) {
    if (verbose) std::fprintf(stderr, "smseg-fuzz: error: %s\n", e.what());
  }
  return 0;
}

}  // namespace smseg::fuzz
