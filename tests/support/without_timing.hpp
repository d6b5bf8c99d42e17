#pragma once
// Our JSON outputs with their wall-clock fields taken out, for comparing runs byte for byte: every key
// whose name says "seconds" (stats.seconds of a forest, seconds_per_frame and per-frame seconds of
// results, training_seconds), "per_second" or "latency_ms", and label-stream's "stage_ms", is a timing
// and differs from run to run; everything else must not.
#include <string>

#include <nlohmann/json.hpp>

namespace smseg::test {

inline nlohmann::json without_timing(nlohmann::json j) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end();) {
      const std::string& k = it.key();
      if (k.find("seconds") != std::string::npos || k.find("per_second") != std::string::npos ||
          k.find("latency_ms") != std::string::npos || k == "stage_ms") {
        it = j.erase(it);
      } else {
        *it = without_timing(*it);
        ++it;
      }
    }
  } else if (j.is_array()) {
    for (auto& e : j) e = without_timing(e);
  }
  return j;
}

}  // namespace smseg::test
