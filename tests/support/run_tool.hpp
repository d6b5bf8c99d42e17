#pragma once
// Running the command-line tools from tests: exit status and everything printed (stdout + stderr).
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

namespace smseg::test {

struct Outcome {
  int status = -1;  ///< exit status; -1 when the command could not run or was killed by a signal
  std::string out;  ///< stdout and stderr together
};

/// Runs `command` through the shell with stderr joined to stdout.
inline Outcome run(const std::string& command) {
  Outcome r;
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  while (std::fgets(buf.data(), buf.size(), p)) r.out += buf.data();
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

/// The path of a tool of this build (SMSEG_BIN_DIR).
inline std::string tool(const std::string& name) { return (std::filesystem::path(SMSEG_BIN_DIR) / name).string(); }

}  // namespace smseg::test
