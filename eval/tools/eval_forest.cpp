// eval-forest: label the test frames of work folders with a forest; scores, results.json, pictures,
// and sweeps of M, B or V (sweep.jsonl).
#include <iostream>
#include <optional>

#include <opencv2/core/utility.hpp>

#include "smseg/common/cli.hpp"
#include "smseg/common/options.hpp"
#include "smseg/common/output.hpp"
#include "smseg/eval/evaluate.hpp"
#include "smseg/eval/report.hpp"
#include "smseg/eval/sweep.hpp"

namespace {

using namespace smseg;

// The forest, checked against --trees, and the cost matrix for its classes.
forest::Forest load_checked_forest(const std::string& forest_file, const std::string& costs, eval::EvalOptions& opt) {
  forest::Forest f = forest::load_forest(forest_file);
  if (opt.trees > static_cast<int>(f.trees.size()))
    throw Error(forest_file, "--trees", std::to_string(opt.trees) + " trees asked, the forest has " +
                                            std::to_string(f.trees.size()));
  if (!costs.empty()) {
    opt.costs = eval::CostMatrix::load(costs, f.classes);
    opt.costs_file = costs;
  }
  return f;
}

}  // namespace

int main(int argc, char** argv) {
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
    opt.frames = as_usage([&] { return stacks::FrameRange::parse(frames, "--test-frames"); });
    opt.progress = !quiet;
    std::vector<eval::SweepSpec> specs;
    for (const auto& s : sweeps) specs.push_back(as_usage([&] { return eval::SweepSpec::parse(s, "--sweep"); }));
    as_usage([&] { opt.validate(); });
    const OutputLock one_writer(out, paths_of(works, {forest_file, costs}));
    // results.json and the pictures are built in a folder beside OUT and swapped in whole at the end, so
    // that OUT never mixes this run's pictures with another run's scores (killed or failed half-way).
    std::optional<FolderReplacement> replacement;
    if (specs.empty()) replacement.emplace(out);
    const fs::path staging = replacement ? replacement->staging() : fs::path(out);
    if (!no_pictures && specs.empty()) opt.pictures = staging / "frames";
    const forest::Forest f = load_checked_forest(forest_file, costs, opt);
    const std::vector<fs::path> work_paths(works.begin(), works.end());

    if (!specs.empty()) {
      eval::run_sweeps(f, forest_file, work_paths, opt, specs, out, std::cout);
      return 0;
    }

    const eval::EvalResult r = eval::evaluate(f, work_paths, opt);
    if (!r.frames_without_points.empty() && !quiet)
      std::cerr << "eval-forest: warning: " << r.frames_without_points << "; they are labelled from the class prior alone\n";
    write_json_atomic(staging / "results.json", r.to_json(f, opt, works));
    replacement->commit();
    std::cout << eval::summary_line(r, opt) << "\n";
    if (!quiet) std::cout << eval::detail_report(r, f.classes, out, !no_pictures);
    return 0;
  });
}
