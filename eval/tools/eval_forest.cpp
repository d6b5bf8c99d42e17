// eval-forest: label the test frames of work folders with a forest; scores, results.json, pictures,
// and sweeps of M, B or V (sweep.jsonl).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include <opencv2/core/utility.hpp>

#include "smseg/common/cli.hpp"
#include "smseg/common/options.hpp"
#include "smseg/common/output.hpp"
#include "smseg/eval/evaluate.hpp"
#include "smseg/eval/sweep.hpp"

namespace {

std::string pct(double v) {
  if (std::isnan(v)) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f%%", 100 * v);
  return buf;
}

std::string mode_text(const smseg::eval::EvalOptions& opt) {
  using smseg::eval::to_string;
  if (opt.grid > 0)
    return "grid B=" + std::to_string(opt.grid) + " V=" + std::to_string(opt.votes) + " " + to_string(opt.vote);
  if (opt.superpixels > 0)
    return "superpixels " + std::to_string(opt.superpixels) + " px V=" + std::to_string(opt.votes) + " " +
           to_string(opt.vote);
  if (opt.smooth.enabled())
    return "per pixel, " + smseg::eval::to_string(opt.smooth.method) + " lambda=" + std::to_string(opt.smooth.lambda) +
           " " + std::to_string(opt.smooth.connectivity) + "-connected" + (opt.smooth.contrast ? "" : ", no contrast");
  return "per pixel";
}

}  // namespace

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Evaluate a forest on the labelled frames of one or more work folders (thesis 2.3.4, 3.2.7, 4.5.1):\n"
      "each pixel runs through every tree and takes the class of maximum summed leaf distribution; or the\n"
      "image is cut into regions (--grid B: B x B cells; --superpixels: SLIC regions) and V random pixels\n"
      "of each region vote for its class. Prints global accuracy, class-average accuracy, mean IoU, the\n"
      "boundary-tolerant accuracy, the mean cost per pixel (--costs) and the row-normalised confusion\n"
      "matrix; writes OUT/results.json and, per test frame, OUT/frames/NNNNNN_{labels,overlay,error,\n"
      "montage}.png, both at once: OUT is rebuilt beside itself and swapped in whole at the end (a killed or\n"
      "failed run leaves OUT as it was; files in OUT that this run does not write are kept). With --sweep,\n"
      "evaluates one point per value instead and appends one JSON line per point to OUT/sweep.jsonl (a\n"
      "rerun resumes: finished points are skipped). Void pixels never count.",
      "eval-forest"};
  std::string forest_file, frames = "0:", out, costs;
  std::vector<std::string> works, sweeps;
  eval::EvalOptions opt;
  int threads = 0;
  bool no_pictures = false, quiet = false;
  app.add_option("FOREST", forest_file, "forest file from train-forest")->required();
  app.add_option("WORK", works, "work folders (from extract-features)")->required();
  app.add_option("--test-frames", frames, "labelled frames to test, A:B half-open (110: = from 110 on)")
      ->capture_default_str();
  eval::eval_options_table().add_to(app, opt);
  app.add_option("--costs", costs,
                 "class-to-class cost matrix, reports the mean cost per pixel: {\"format\": \"smseg-costs\", "
                 "\"version\": 1, \"classes\": [every class of the forest, any order], \"costs\": [[row per true "
                 "class: cost of each output class; >= 0, diagonal 0]]}");
  app.add_option("--sweep", sweeps,
                 "sweep instead of one evaluation: M=A:B (first m trees), B=A:B:S (grid size) or V=A:B "
                 "(votes); bounds inclusive; repeatable; one JSON line per point in OUT/sweep.jsonl, resumable; no "
                 "pictures or results.json");
  add_threads_option(app, threads, "the results do not depend on it");
  app.add_flag("--no-pictures", no_pictures, "write results.json only");
  app.add_flag("-q,--quiet", quiet, "no progress and no table on stderr/stdout, just the summary line");
  app.add_option("-o,--out", out, "output folder")->required();
  return run_tool(app, argc, argv, threads, [&] {
    if (threads > 0) cv::setNumThreads(threads);  // SLIC runs on OpenCV's own thread pool
    opt.frames = as_usage([&] { return features::FrameRange::parse(frames, "--test-frames"); });
    opt.progress = !quiet;
    std::vector<eval::SweepSpec> specs;
    for (const auto& s : sweeps) specs.push_back(as_usage([&] { return eval::SweepSpec::parse(s, "--sweep"); }));
    as_usage([&] { opt.validate(); });
    // results.json and the pictures are built in a folder beside OUT and swapped in whole at the end, so
    // that OUT never mixes this run's pictures with another run's scores (killed or failed half-way).
    std::optional<FolderReplacement> replacement;
    if (specs.empty()) replacement.emplace(out);
    const fs::path staging = replacement ? replacement->staging() : fs::path(out);
    if (!no_pictures && specs.empty()) opt.pictures = staging / "frames";
    const forest::Forest f = forest::load_forest(forest_file);
    if (opt.trees > static_cast<int>(f.trees.size()))
      throw Error(forest_file, "--trees", std::to_string(opt.trees) + " trees asked, the forest has " +
                                              std::to_string(f.trees.size()));
    if (!costs.empty()) {
      opt.costs = eval::CostMatrix::load(costs, f.classes);
      opt.costs_file = costs;
    }
    const std::vector<fs::path> work_paths(works.begin(), works.end());

    if (!specs.empty()) {
      remove_stale_temporaries(out);  // a sweep appends to OUT/sweep.jsonl; a killed line is cut on reading
      const fs::path jsonl = fs::path(out) / "sweep.jsonl";
      for (const auto& spec : specs) {
        const auto report = eval::run_sweep(f, forest_file, work_paths, opt, spec, jsonl, [&](const Json& rec) {
          char line[256];
          std::snprintf(line, sizeof line, "%s=%d: global %s, class-average %s, mean IoU %s, %.2f ms per frame",
                        rec["sweep"].get<std::string>().c_str(), rec["value"].get<int>(),
                        pct(rec["global_accuracy"].is_null() ? NAN : rec["global_accuracy"].get<double>()).c_str(),
                        pct(rec["class_average_accuracy"].is_null() ? NAN : rec["class_average_accuracy"].get<double>()).c_str(),
                        pct(rec["mean_iou"].is_null() ? NAN : rec["mean_iou"].get<double>()).c_str(),
                        1000 * rec["seconds_per_frame"].get<double>());
          std::cout << line << std::endl;
        });
        std::cout << "sweep " << spec.str() << ": " << report.run << " points evaluated, " << report.done_before
                  << " already done -> " << jsonl.string() << "\n";
      }
      return 0;
    }

    const eval::EvalResult r = eval::evaluate(f, work_paths, opt);
    if (!r.frames_without_points.empty() && !quiet)
      std::cerr << "eval-forest: warning: " << r.frames_without_points << "; they are labelled from the class prior alone\n";
    write_json_atomic(staging / "results.json", r.to_json(f, opt, works));
    replacement->commit();
    std::string line = std::to_string(r.frames.size()) + " test frames: global accuracy " +
                       pct(r.confusion.global_accuracy()) + ", class-average accuracy " +
                       pct(r.confusion.class_average_accuracy()) + ", mean IoU " + pct(r.confusion.mean_iou()) +
                       ", within " + std::to_string(opt.tolerance) + " px " + pct(r.tolerant_accuracy()) +
                       ", boundary F1 " + pct(r.boundary.f1());
    if (opt.costs) {
      char buf[64];
      std::snprintf(buf, sizeof buf, ", mean cost %.4f", eval::mean_cost(r.confusion, *opt.costs));
      line += buf;
    }
    char buf[128];
    std::snprintf(buf, sizeof buf, ", %.2f ms per frame", 1000 * r.seconds_per_frame);
    line += buf;
    if (opt.superpixels > 0) {
      std::snprintf(buf, sizeof buf, " + %.2f ms superpixels", 1000 * r.superpixel_seconds_per_frame);
      line += buf;
    }
    if (opt.smooth.enabled()) {
      std::snprintf(buf, sizeof buf, " + %.2f ms smoothing", 1000 * r.smooth_seconds_per_frame);
      line += buf;
    }
    if (r.frames_in_flight > 1) {
      std::snprintf(buf, sizeof buf, "; %d frames at a time, %.2f ms per frame in all", r.frames_in_flight,
                    1000 * r.wall_seconds_per_frame);
      line += buf;
    }
    std::cout << line << " (" << mode_text(opt) << ")\n";
    if (!quiet) {
      std::vector<double> accs;
      for (const auto& fr : r.frames)
        if (fr.confusion.total() > 0) accs.push_back(fr.confusion.global_accuracy());
      if (!accs.empty()) {
        std::sort(accs.begin(), accs.end());
        std::cout << "per-frame global accuracy: min " << pct(accs.front()) << ", median "
                  << pct(accs[accs.size() / 2]) << ", max " << pct(accs.back()) << "\n";
      }
      std::cout << "\nConfusion matrix (rows: ground truth, columns: output; % of the row):\n"
                << r.confusion.table(f.classes) << "\n";
      std::cout << "results: " << (fs::path(out) / "results.json").string();
      if (!no_pictures) std::cout << "\npictures: " << (fs::path(out) / "frames").string() << "/";
      std::cout << "\n";
    }
    return 0;
  });
}
