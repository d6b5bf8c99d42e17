#pragma once
// Progress on stderr for anything longer than a second: "label  37/300  12%  ETA 4s", redrawn in place.
// Thread-safe; silent when disabled or when stderr is not a terminal (logs get no progress lines),
// and it prints nothing until a second has passed.

#include <atomic>
#include <chrono>
#include <mutex>
#include <string>

namespace smseg {

class Progress {
 public:
  Progress(std::string label, long total, bool enabled = true);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void tick(long n = 1);  ///< n more units done
  void finish();          ///< prints the final line (if anything was printed before)

 private:
  void print(long done, bool final_line);
  std::string label_;
  long total_;
  bool enabled_;
  std::atomic<long> done_{0};
  std::chrono::steady_clock::time_point start_, last_;
  bool printed_ = false;
  bool finished_ = false;
  std::mutex mutex_;
};

}  // namespace smseg
