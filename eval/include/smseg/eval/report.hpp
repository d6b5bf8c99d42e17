#pragma once
// What eval-forest prints: the summary line of an evaluation, the per-frame figures and confusion
// table, one line per sweep point; and its sweep loop (every spec's points, one line each).

#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "smseg/eval/evaluate.hpp"
#include "smseg/eval/sweep.hpp"

namespace smseg::eval {

/// "12.3%", or "n/a" for NaN.
std::string percent_text(double fraction);

/// How the frames were labelled: "per pixel", "grid B=.. V=.. <vote>", "superpixels .. px ..", or the
/// per-pixel smoothing.
std::string mode_text(const EvalOptions& options);

/// The one summary line: frame count, accuracies, IoU, tolerant accuracy, boundary F1, mean cost,
/// milliseconds per frame and the mode.
std::string summary_line(const EvalResult& result, const EvalOptions& options);

/// The report after the summary line: per-frame accuracy spread, the confusion matrix, where results
/// (and pictures) are in `out`. Ends with a newline.
std::string detail_report(const EvalResult& result, const std::vector<std::string>& classes,
                          const std::filesystem::path& out, bool pictures);

/// One sweep point's line, from its sweep.jsonl record.
std::string sweep_point_line(const Json& record);

/// Runs every spec's points into OUT/sweep.jsonl (resuming), printing a line per point and per spec
/// to `os`.
void run_sweeps(const forest::Forest& forest, const std::string& forest_file, const std::vector<fs::path>& works,
                const EvalOptions& options, const std::vector<SweepSpec>& specs, const std::filesystem::path& out,
                std::ostream& os);

}  // namespace smseg::eval
