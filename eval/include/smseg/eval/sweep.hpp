#pragma once
// Sweeps of an evaluation parameter without retraining (thesis 4.3, 4.5.1; docs/design.md section 5):
//   M=A:B[:S]  the first m trees of the forest for m = A, A+S, ..., B (a forest of the largest M
//              serves every smaller M)
//   B=A:B[:S]  grid cell size (per-pixel evaluation is not a point of this sweep)
//   V=A:B[:S]  voting pixels per region (needs --grid or --superpixels)
// Bounds are inclusive. Each point is one JSON Lines record appended to OUT/sweep.jsonl as one
// write of a full line, then fsync'd; a rerun reads the finished points and skips them, and drops a
// half-written last line left by a kill, so nothing is lost or repeated. Every record carries "run",
// the parameters of the run other than the swept one: points of another run in the same file are an
// error rather than silently mixed.

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "smseg/eval/evaluate.hpp"

namespace smseg::eval {

struct SweepSpec {
  char param = 'M';  ///< 'M' (trees), 'B' (grid cell size) or 'V' (votes)
  int first = 1, last = 1, step = 1;
  std::vector<int> values() const;
  std::string str() const;  ///< "M=1:42:1"
  /// "M=1:42", "B=5:95:5", "V=9"; Error naming `option` otherwise.
  static SweepSpec parse(const std::string& text, const std::string& option);
};

/// Reads the complete records of a JSON Lines file (none when it does not exist). A last line without
/// its newline (an interrupted write) is cut off the file. A complete line that is not a JSON object
/// is an Error naming the file and line.
std::vector<nlohmann::json> read_jsonl(const fs::path& path);
/// Appends j as one line with a single write, then fsync (the file is created if missing).
void append_jsonl(const fs::path& path, const nlohmann::json& j);

struct SweepReport {
  int done_before = 0;  ///< points found finished in the file
  int run = 0;          ///< points evaluated now
};

/// Runs every point of `spec` not yet in `jsonl` (see the file comment), calling on_point(record) after
/// each new one is written. opt.pictures is ignored. forest_file: how the forest is named in "run".
SweepReport run_sweep(const forest::Forest& forest, const std::string& forest_file, const std::vector<fs::path>& works,
                      const EvalOptions& opt, const SweepSpec& spec, const fs::path& jsonl,
                      const std::function<void(const nlohmann::json&)>& on_point = {});

}  // namespace smseg::eval
