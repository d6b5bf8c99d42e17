// run-experiment: every point of an experiment config (sweeps, cross-training, comparisons; thesis
// chapter 4) trained and evaluated with the library, one JSON line per point, resumable.
#include <cmath>
#include <cstdio>
#include <iostream>

#include <opencv2/core/utility.hpp>
#include <tbb/global_control.h>

#include "smseg/cli.hpp"
#include "smseg/experiments/runner.hpp"

namespace {

std::string pct(const nlohmann::json& v) {
  if (!v.is_number()) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f%%", 100 * v.get<double>());
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Run an experiment config (experiments/thesis/*.json): for each point of its sweep, train a forest on\n"
      "the training frames and evaluate it on the test frames, with the library (no tools in a loop), and\n"
      "append one JSON line per point to OUT/experiment.jsonl (accuracies, confusion, per-frame accuracy,\n"
      "training and evaluation time, nodes per tree, nodes per feature, chosen-window histograms).\n"
      "Synthetic sequences are generated and feature stacks extracted as the points need them, once,\n"
      "into a cache shared by experiments. A rerun resumes: finished points are skipped, none is lost or\n"
      "repeated. Progress with an ETA on stderr. The config format is in\n"
      "experiments/include/smseg/experiments/config.hpp and experiments/thesis/README.md.",
      "run-experiment"};
  std::string config, out, cache;
  experiments::RunOptions opt;
  bool quick = false, quiet = false, check = false;
  int threads = 0;
  app.add_option("CONFIG", config, "experiment config (JSON, format smseg-experiment)")->required();
  app.add_option("-o,--out", out, "results folder: config.json and experiment.jsonl (required unless --check)");
  app.add_flag("--quick", quick, "run the config's quick form (its \"quick\" merge patch: a coarse grid on small data)");
  app.add_option("--cache", cache, "folder for generated sequences and extracted work folders (default: OUT/../cache)");
  app.add_option("--max-points", opt.max_points, "stop after this many new points (0: all); a rerun continues")
      ->capture_default_str();
  app.add_option("--memory-mb", opt.memory_mb, "memory budget of each training in MiB: trees are built in batches that fit; refused if one tree does not")
      ->capture_default_str();
  app.add_option("--threads", threads, "worker threads (0: all cores); results do not depend on it")->capture_default_str();
  app.add_flag("--check", check, "validate the config and list its points, run nothing");
  app.add_flag("-q,--quiet", quiet, "no progress on stderr, no line per point");
  return run_tool(app, argc, argv, [&] {
    std::unique_ptr<tbb::global_control> limit;
    if (threads < 0) throw Error("", "--threads", "must be 0 (all cores) or a number of threads");
    if (opt.max_points < 0) throw Error("", "--max-points", "must be 0 (all) or a number of points");
    if (threads > 0) {
      limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
      cv::setNumThreads(threads);
    }
    const experiments::Experiment ex = experiments::load_experiment(config, quick);
    if (check) {
      std::cout << ex.name << (quick ? " (quick)" : "") << ": " << ex.points.size() << " points\n";
      for (const auto& p : ex.points) std::cout << "  " << p.index << ": " << p.describe() << "\n";
      return 0;
    }
    if (out.empty()) {
      std::cerr << "run-experiment: --out is required (see run-experiment --help)\n";
      return 2;
    }
    opt.out = out;
    opt.cache = cache;
    opt.progress = !quiet;
    const int total = static_cast<int>(ex.points.size());
    if (!quiet)
      opt.on_point = [&](const experiments::Point& p, const nlohmann::json& rec) {
        char line[512];
        std::snprintf(line, sizeof line,
                      "[%d/%d] %s: global %s, class-average %s, mean IoU %s; train %.2f s, %.0f nodes per tree; %.1f ms per frame",
                      p.index + 1, total, p.describe().c_str(), pct(rec["global_accuracy"]).c_str(),
                      pct(rec["class_average_accuracy"]).c_str(), pct(rec["mean_iou"]).c_str(),
                      rec["train_seconds"].get<double>(), rec["nodes_per_tree"].get<double>(),
                      1000 * rec["seconds_per_frame"].get<double>());
        std::cout << line << std::endl;
      };
    const auto r = experiments::run_experiment(ex, opt);
    char line[256];
    std::snprintf(line, sizeof line, "%s: %d points evaluated, %d already done, %d left, %.1f s -> ", ex.name.c_str(),
                  r.run, r.done_before, r.total - r.run - r.done_before, r.seconds);
    std::cout << line << (fs::path(out) / "experiment.jsonl").string() << "\n";
    return 0;
  });
}
