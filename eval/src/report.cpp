// eval-forest's printed report and sweep loop (report.hpp).
#include "smseg/eval/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "smseg/common/output.hpp"

namespace smseg::eval {

std::string percent_text(double v) {
  if (std::isnan(v)) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f%%", 100 * v);
  return buf;
}

std::string mode_text(const EvalOptions& opt) {
  if (opt.grid > 0)
    return "grid B=" + std::to_string(opt.grid) + " V=" + std::to_string(opt.votes) + " " + to_string(opt.vote);
  if (opt.superpixels > 0)
    return "superpixels " + std::to_string(opt.superpixels) + " px V=" + std::to_string(opt.votes) + " " +
           to_string(opt.vote);
  if (opt.smooth.enabled())
    return "per pixel, " + to_string(opt.smooth.method) + " lambda=" + std::to_string(opt.smooth.lambda) + " " +
           std::to_string(opt.smooth.connectivity) + "-connected" + (opt.smooth.contrast ? "" : ", no contrast");
  return "per pixel";
}

namespace {

// The milliseconds part of the summary line.
std::string timing_text(const EvalResult& r, const EvalOptions& opt) {
  char buf[128];
  std::snprintf(buf, sizeof buf, ", %.2f ms per frame", 1000 * r.seconds_per_frame);
  std::string text = buf;
  if (opt.superpixels > 0) {
    std::snprintf(buf, sizeof buf, " + %.2f ms superpixels", 1000 * r.superpixel_seconds_per_frame);
    text += buf;
  }
  if (opt.smooth.enabled()) {
    std::snprintf(buf, sizeof buf, " + %.2f ms smoothing", 1000 * r.smooth_seconds_per_frame);
    text += buf;
  }
  if (r.frames_in_flight > 1) {
    std::snprintf(buf, sizeof buf, "; %d frames at a time, %.2f ms per frame in all", r.frames_in_flight,
                  1000 * r.wall_seconds_per_frame);
    text += buf;
  }
  return text;
}

double number_or_nan(const Json& value) { return value.is_null() ? NAN : value.get<double>(); }

}  // namespace

std::string summary_line(const EvalResult& r, const EvalOptions& opt) {
  std::string line = std::to_string(r.frames.size()) + " test frames: global accuracy " +
                     percent_text(r.confusion.global_accuracy()) + ", class-average accuracy " +
                     percent_text(r.confusion.class_average_accuracy()) + ", mean IoU " +
                     percent_text(r.confusion.mean_iou()) + ", within " + std::to_string(opt.tolerance) + " px " +
                     percent_text(r.tolerant_accuracy()) + ", boundary F1 " + percent_text(r.boundary.f1());
  if (opt.costs) {
    char buf[64];
    std::snprintf(buf, sizeof buf, ", mean cost %.4f", mean_cost(r.confusion, *opt.costs));
    line += buf;
  }
  return line + timing_text(r, opt) + " (" + mode_text(opt) + ")";
}

std::string detail_report(const EvalResult& r, const std::vector<std::string>& classes,
                          const std::filesystem::path& out, bool pictures) {
  std::ostringstream os;
  std::vector<double> accs;
  for (const auto& fr : r.frames)
    if (fr.confusion.total() > 0) accs.push_back(fr.confusion.global_accuracy());
  if (!accs.empty()) {
    std::sort(accs.begin(), accs.end());
    os << "per-frame global accuracy: min " << percent_text(accs.front()) << ", median "
       << percent_text(accs[accs.size() / 2]) << ", max " << percent_text(accs.back()) << "\n";
  }
  os << "\nConfusion matrix (rows: ground truth, columns: output; % of the row):\n" << r.confusion.table(classes) << "\n";
  os << "results: " << (out / "results.json").string();
  if (pictures) os << "\npictures: " << (out / "frames").string() << "/";
  os << "\n";
  return os.str();
}

std::string sweep_point_line(const Json& rec) {
  char line[256];
  std::snprintf(line, sizeof line, "%s=%d: global %s, class-average %s, mean IoU %s, %.2f ms per frame",
                rec["sweep"].get<std::string>().c_str(), rec["value"].get<int>(),
                percent_text(number_or_nan(rec["global_accuracy"])).c_str(),
                percent_text(number_or_nan(rec["class_average_accuracy"])).c_str(),
                percent_text(number_or_nan(rec["mean_iou"])).c_str(), 1000 * rec["seconds_per_frame"].get<double>());
  return line;
}

void run_sweeps(const forest::Forest& forest, const std::string& forest_file, const std::vector<fs::path>& works,
                const EvalOptions& options, const std::vector<SweepSpec>& specs, const std::filesystem::path& out,
                std::ostream& os) {
  remove_stale_temporaries(out);  // a sweep appends to OUT/sweep.jsonl; a killed line is cut on reading
  const fs::path jsonl = out / "sweep.jsonl";
  for (const auto& spec : specs) {
    const auto report = run_sweep(forest, forest_file, works, options, spec, jsonl,
                                  [&](const Json& rec) { os << sweep_point_line(rec) << std::endl; });
    os << "sweep " << spec.str() << ": " << report.run << " points evaluated, " << report.done_before
       << " already done -> " << jsonl.string() << "\n";
  }
}

}  // namespace smseg::eval
