#pragma once
// Running a tool and killing it with SIGKILL at chosen moments, and looking at what it left: the
// helpers of the kill -9 tests (docs/reliability.md, "Interrupted runs (kill -9)").
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "without_timing.hpp"

namespace smseg::test {

namespace fs = std::filesystem;

/// A command line: the tool's path first.
using Command = std::vector<std::string>;

/// Starts `cmd` with its output thrown away; the child's pid.
inline pid_t spawn(const Command& cmd) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::setenv("SMSEG_TEST_WRITE_PAUSE_MS", "5", 0);  // every file write pauses half-way: kills land in it
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    ::dup2(null, 2);
    std::vector<char*> argv;
    for (const auto& a : cmd) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

inline int wait_for(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return status;
}

/// An uninterrupted run: its wall time (negative when it did not exit 0) and the most entries it
/// added at once under the watched folder (temporaries included), polled.
struct Measured {
  double seconds = -1;
  int peak_new_entries = 0;
};

/// Every entry (file or folder, temporaries included) at any depth under `dir`.
inline int count_entries(const fs::path& dir) {
  int n = 0;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) ++n;
  return n;
}

inline Measured measured_run(const Command& cmd, const fs::path& watch) {
  const int before = count_entries(watch);
  Measured m;
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = spawn(cmd);
  int status = 0;
  while (::waitpid(pid, &status, WNOHANG) != pid) {
    m.peak_new_entries = std::max(m.peak_new_entries, count_entries(watch) - before);
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  m.peak_new_entries = std::max(m.peak_new_entries, count_entries(watch) - before);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  m.seconds = WIFEXITED(status) && WEXITSTATUS(status) == 0 ? s : -1.0;
  return m;
}

/// Seeded kill moments within a run of `seconds`: `n` delays spread over (0, seconds), reproducible
/// (our own arithmetic over mt19937, not a library distribution, so every platform draws the same).
inline std::vector<double> kill_moments(std::uint32_t seed, int n, double seconds) {
  std::mt19937 gen(seed);
  std::vector<double> out;
  for (int i = 0; i < n; ++i) {
    const double u = (i + (gen() % 1000) / 1000.0) / n;  // one moment in each n-th of the run
    out.push_back(seconds * (0.02 + 0.96 * u));
  }
  return out;
}

inline std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The files under the output paths, each path relative to `base` -> its bytes. A missing path adds
/// nothing; a folder adds every file below it.
using Files = std::map<std::string, std::string>;

inline Files snapshot(const fs::path& base, const std::vector<fs::path>& outputs) {
  Files files;
  for (const auto& out : outputs) {
    if (fs::is_regular_file(out)) files[fs::relative(out, base).string()] = read_bytes(out);
    if (!fs::is_directory(out)) continue;
    for (const auto& e : fs::recursive_directory_iterator(out))
      if (e.is_regular_file()) files[fs::relative(e.path(), base).string()] = read_bytes(e.path());
  }
  return files;
}

/// Puts `files` back under `base` in place of whatever the outputs hold now.
inline void restore(const fs::path& base, const std::vector<fs::path>& outputs, const Files& files) {
  for (const auto& out : outputs) fs::remove_all(out);
  for (const auto& [rel, bytes] : files) {
    fs::create_directories((base / rel).parent_path());
    std::ofstream(base / rel, std::ios::binary) << bytes;
  }
}

/// A file's bytes as runs compare them: JSON and JSON Lines without timing fields (a file that does
/// not parse stays as it is, and so differs from any complete one), anything else byte for byte.
inline std::string comparable(const std::string& name, const std::string& bytes) {
  const auto ends = [&](const std::string& s) { return name.size() >= s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0; };
  if (ends(".json")) {
    const auto j = nlohmann::json::parse(bytes, nullptr, false);
    return j.is_discarded() ? bytes : without_timing(j).dump();
  }
  if (ends(".jsonl")) {
    std::string out;
    std::istringstream in(bytes);
    for (std::string line; std::getline(in, line);) {
      const auto j = nlohmann::json::parse(line, nullptr, false);
      out += (j.is_discarded() ? line : without_timing(j).dump()) + "\n";
    }
    return out;
  }
  return bytes;
}

inline Files comparable(const Files& files) {
  Files out;
  for (const auto& [name, bytes] : files) out[name] = comparable(name, bytes);
  return out;
}

/// Whether a file name is one of what an interrupted write leaves: `*.tmp.*`, `*.old.*` and
/// export-notebooks' `.render-*` scripts.
inline bool is_temporary_name(const std::string& name) {
  return name.find(".tmp.") != std::string::npos || name.find(".old.") != std::string::npos ||
         name.rfind(".render-", 0) == 0;
}

/// Names under `dir` (at any depth) of the temporaries an interrupted write left.
inline std::vector<std::string> leftover_temporaries(const fs::path& dir) {
  std::vector<std::string> out;
  if (!fs::exists(dir)) return out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (is_temporary_name(e.path().filename().string())) out.push_back(fs::relative(e.path(), dir).string());
  return out;
}

/// `files` without the temporaries a kill may leave inside an output folder (a later run removes
/// them: the tests check that separately).
inline Files without_temporaries(Files files) {
  std::erase_if(files, [](const auto& entry) { return is_temporary_name(fs::path(entry.first).filename().string()); });
  return files;
}

/// The pids of the processes whose working folder is `dir` or below it: what a killed tool's children
/// would be if they outlived it (export-notebooks runs Python in its staging folder).
inline std::vector<long> processes_working_in(const fs::path& dir) {
  const std::string root = fs::weakly_canonical(dir).string() + "/";
  std::vector<long> out;
  std::error_code ec;
  for (fs::directory_iterator it("/proc", ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::error_code link_ec;
    const std::string cwd = fs::read_symlink(it->path() / "cwd", link_ec).string() + "/";
    if (!link_ec && cwd.rfind(root, 0) == 0) out.push_back(std::stol(name));
  }
  return out;
}

/// Whether no process works in `dir` within 0.2 s (a dead parent's children get their SIGKILL as it
/// exits and end a moment later; a child that outlived it, drawing its figures, lasts far longer).
inline bool no_process_outlives_in(const fs::path& dir) {
  for (int i = 0; i < 20; ++i) {
    if (processes_working_in(dir).empty()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

/// What differs between two file sets, for a failure message: the names only in one or with other bytes.
inline std::string difference(const Files& a, const Files& b) {
  std::string out;
  for (const auto& [k, v] : a)
    if (!b.count(k)) out += " only-before:" + k;
    else if (b.at(k) != v) out += " differs:" + k;
  for (const auto& [k, v] : b)
    if (!a.count(k)) out += " only-after:" + k;
  return out.empty() ? " (same)" : out;
}

}  // namespace smseg::test
