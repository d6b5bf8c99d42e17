#pragma once
// Our JSON outputs with their wall-clock fields taken out, for comparing runs byte for byte: every key
// whose name says "seconds" (stats.seconds of a forest, seconds_per_frame and per-frame seconds of
// results, training_seconds) is a timing and differs from run to run; everything else must not.
#include <string>

#include <nlohmann/json.hpp>

namespace smseg::test {

inline nlohmann::json without_timing(nlohmann::json j) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end();) {
      if (it.key().find("seconds") != std::string::npos) {
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
