#include "smseg/common/progress.hpp"

#include <cstdio>
#include <unistd.h>

namespace smseg {

Progress::Progress(std::string label, long total, bool enabled)
    // Only on a terminal: in a log or a pipe the redrawn lines are noise that buries the errors.
    : label_(std::move(label)), total_(total), enabled_(enabled && ::isatty(STDERR_FILENO)) {
  start_ = last_ = std::chrono::steady_clock::now();
}

Progress::~Progress() { finish(); }

void Progress::tick(long n) {
  const long done = done_ += n;
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  std::lock_guard lock(mutex_);
  if (now - start_ < std::chrono::seconds(1) || now - last_ < std::chrono::milliseconds(250)) return;
  last_ = now;
  print(done, false);
}

void Progress::finish() {
  std::lock_guard lock(mutex_);
  if (finished_) return;
  finished_ = true;
  if (enabled_ && printed_) print(done_.load(), true);
}

void Progress::print(long done, bool final_line) {
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  char buf[256];
  if (final_line) {
    std::snprintf(buf, sizeof buf, "%s  %ld/%ld  done in %.1fs", label_.c_str(), done, total_, secs);
  } else {
    const double eta = done > 0 ? secs * double(total_ - done) / double(done) : 0.0;
    std::snprintf(buf, sizeof buf, "%s  %ld/%ld  %3.0f%%  ETA %.0fs", label_.c_str(), done, total_,
                  total_ > 0 ? 100.0 * double(done) / double(total_) : 100.0, eta);
  }
  // The line is redrawn in place.
  std::fprintf(stderr, "\r%s\033[K%s", buf, final_line ? "\n" : "");
  std::fflush(stderr);
  printed_ = true;
}

}  // namespace smseg
