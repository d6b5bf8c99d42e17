#pragma once
// A fresh, empty folder for one test: under the system's temporary folder, named after the test and
// this process (so parallel ctest runs do not share it).
#include <unistd.h>

#include <filesystem>
#include <string>

namespace smseg::test {

inline std::filesystem::path temp_dir(const std::string& name) {
  namespace fs = std::filesystem;
  fs::path d = fs::temp_directory_path() / ("smseg_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

/// Removes its folder when it goes out of scope, so that a test leaves nothing behind (also when an
/// ASSERT returns early).
struct RemovedAtEnd {
  std::filesystem::path path;
  ~RemovedAtEnd() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
};

}  // namespace smseg::test
