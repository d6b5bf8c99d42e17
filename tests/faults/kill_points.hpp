#pragma once
// Where a kill -9 test kills: at a seeded moment of the run, or as soon as the output holds a seeded
// number of new files (polled), so that kills land in the middle of writing and not only in start-up.
#include <chrono>
#include <cstdint>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "kill_harness.hpp"

namespace smseg::test {

struct KillPoint {
  double delay = -1;  ///< seconds after the start (< 0: not by time)
  int new_files = 0;  ///< as soon as this many files appeared under the watched folder (0: not by files)
  std::string appears;  ///< as soon as a file whose name starts with this appears (empty: not by name)

  std::string str() const {
    if (!appears.empty()) return "when " + appears + "* appeared";
    return delay >= 0 ? "at " + std::to_string(delay) + " s" : "after " + std::to_string(new_files) + " new files";
  }
};

/// `by_time` moments spread over a run of `seconds` and `by_files` counts in 1..`files`, from `seed`.
inline std::vector<KillPoint> kill_points(std::uint32_t seed, int by_time, double seconds, int by_files, int files) {
  std::vector<KillPoint> out;
  for (double d : kill_moments(seed, by_time, seconds)) out.push_back({d, 0, ""});
  std::mt19937 gen(seed + 1);
  for (int i = 0; i < by_files && files > 0; ++i) {
    // one count in each by_files-th of the files the run writes
    const int lo = files * i / by_files, hi = std::max(lo + 1, files * (i + 1) / by_files);
    out.push_back({-1, 1 + lo + static_cast<int>(gen() % static_cast<unsigned>(hi - lo)), ""});
  }
  return out;
}

/// Whether an entry whose name starts with `prefix` is under `dir`.
inline bool has_entry_named(const fs::path& dir, const std::string& prefix) {
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->path().filename().string().rfind(prefix, 0) == 0) return true;
  return false;
}

/// Runs `cmd` and sends it SIGKILL at `point` (new files counted under `watch`). True when the kill
/// landed, false when the tool had finished first.
inline bool run_and_kill(const Command& cmd, const KillPoint& point, const fs::path& watch) {
  const int before = count_entries(watch);
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = spawn(cmd);
  for (;;) {
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) return false;  // finished before the kill
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const bool now = (point.delay >= 0 && t >= point.delay) ||
                     (point.new_files > 0 && count_entries(watch) >= before + point.new_files) ||
                     (!point.appears.empty() && has_entry_named(watch, point.appears));
    if (now) break;
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  ::kill(pid, SIGKILL);
  const int status = wait_for(pid);
  return WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
}

}  // namespace smseg::test
