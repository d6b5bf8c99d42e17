// run-experiment: every point of an experiment config (sweeps, cross-training, comparisons; thesis
// chapter 4) trained and evaluated with the library, one JSON line per point, resumable.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include <opencv2/core/utility.hpp>

#include "smseg/common/cli.hpp"
#include "smseg/experiments/runner.hpp"
#include "smseg/experiments/shards.hpp"
#include "smseg/common/slurm.hpp"

namespace {

std::string pct(const nlohmann::json& v) {
  if (!v.is_number()) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f%%", 100 * v.get<double>());
  return buf;
}

/// This run's arguments for an array task: the same, without what the task gets its own way.
std::vector<std::string> task_args(int argc, char** argv) {
  return smseg::slurm::without_options(std::vector<std::string>(argv + 1, argv + argc), {"--slurm", "-q", "--quiet", "--no-wait", "--slurm-dry-run", "--slurm-gather"},
                                       {"--tasks", "--slurm-dir", "--slurm-arg", "--poll", "-o", "--out", "--cache",
                                        "--points"});
}

int summary(const std::string& name, const smseg::experiments::RunReport& r, const std::string& out) {
  char line[256];
  std::snprintf(line, sizeof line, "%s: %d points evaluated, %d already done, %d left, %.1f s -> ", name.c_str(), r.run,
                r.done_before, r.total - r.run - r.done_before, r.seconds);
  std::cout << line << (smseg::fs::path(out) / "experiment.jsonl").string() << "\n";
  return 0;
}

/// Shards the points that no task has done yet (a rerun submits only those; the task count is capped
/// at the number of forests they need) and submits them.
std::optional<smseg::experiments::RunReport> submit_to_slurm(const smseg::experiments::Experiment& ex, smseg::experiments::SlurmRun& slurm,
                     const std::vector<int>& left, int tasks, const std::string& out, int argc, char** argv, bool quiet) {
  using namespace smseg;
  // More tasks than the forests the points need would leave tasks idle: use as many as there are
  // forests, and say so (a sweep of 2 forests asked for in 3 tasks runs in 2).
  const int forests = experiments::forests_needed(ex, left);
  if (tasks > forests && forests > 0 && !quiet)
    std::cerr << "run-experiment: --tasks " << tasks << ": the " << left.size() << " points left need " << forests
              << " forests and points sharing a forest run in one task; submitting " << forests << " tasks\n";
  const std::vector<int> todo = experiments::missing_task_records(ex, left, slurm.dir);
  std::vector<std::vector<int>> shards;
  if (!todo.empty()) shards = experiments::shard_points(ex, todo, std::min(tasks, experiments::forests_needed(ex, todo)));
  slurm.program = slurm::current_executable();
  slurm.args = task_args(argc, argv);
  slurm.out = out;
  slurm.mode.progress = !quiet;
  return experiments::run_experiment_slurm(ex, slurm, left, shards);
}

/// After the gather job: the summary, or Error when it left points without a record in OUT.
int summary_after_gather(const smseg::experiments::Experiment& ex, const smseg::experiments::RunOptions& nothing,
                         const smseg::experiments::RunReport& report, const std::string& out,
                         const smseg::fs::path& dir) {
  const std::vector<int> left = smseg::experiments::run_experiment(ex, nothing).left;
  if (!left.empty())
    throw smseg::Error(out, "--slurm",
                       "the gather job left points " + smseg::experiments::points_to_string(left) +
                           " without a record; its log: " + smseg::slurm::gather_log(dir).string());
  return summary(ex.name, report, out);
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
      "repeated. Progress with an ETA on stderr. With --slurm the points run as a Slurm job array\n"
      "(--tasks tasks; points sharing a forest in the same task) and a gather job collects their records\n"
      "into OUT/experiment.jsonl in point order, as a local run writes them (timings aside); paths must\n"
      "be on a file system the nodes share (docs/distributed.md). The config format is in\n"
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
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--memory-mb", opt.memory_mb, "memory budget of each training in MiB: trees are built in batches that fit; refused if one tree does not")
      ->check(CLI::Range(1.0, 1048576.0 * 1024))  // 1 MiB .. 1 PiB: more is a typing error
      ->capture_default_str();
  add_threads_option(app, threads, "results do not depend on it");
  app.add_flag("--check", check, "validate the config and list its points, run nothing");
  app.add_flag("-q,--quiet", quiet, "no progress on stderr, no line per point");
  std::string points;
  app.add_option("--points", points, "run only these points (comma-separated indices, as --check lists them)");
  experiments::SlurmRun slurm;
  bool on_slurm = false;
  int tasks = 0;
  std::string slurm_dir;
  app.add_flag("--slurm", on_slurm,
               "run the points as a Slurm job array (sbatch) and a gather job that collects their records; wait for both");
  app.add_option("--tasks", tasks, "with --slurm: array tasks (at least 1; more than the forests the points left need are not used)");
  app.add_option("--slurm-dir", slurm_dir, "with --slurm: job folder (job.sh, logs/, tasks/), kept (default: OUT/slurm)");
  app.add_option("--slurm-arg", slurm.sbatch_options,
                 "with --slurm: an sbatch option for the array and the gather job, e.g. --slurm-arg=--partition=short (repeatable)")
      ->allow_extra_args(false);
  bool no_wait = false, gather = false;
  app.add_flag("--no-wait", no_wait, "with --slurm: return once submitted (job ids and logs on stdout); the gather job writes OUT");
  app.add_flag("--slurm-dry-run", slurm.mode.dry_run, "with --slurm: print the job scripts and sbatch lines, submit nothing");
  app.add_option("--poll", slurm.mode.poll_seconds, "with --slurm: seconds between squeue checks")->capture_default_str();
  // The gather job's own command: the tasks' records (under --slurm-dir) into OUT. Not for users.
  app.add_flag("--slurm-gather", gather)->group("");
  return run_tool(app, argc, argv, threads, [&] {
    if (threads > 0) cv::setNumThreads(threads);
    if (!on_slurm && (tasks != 0 || (!slurm_dir.empty() && !gather) || !slurm.sbatch_options.empty() || no_wait ||
                      slurm.mode.dry_run))
      throw UsageError("", "--tasks, --slurm-dir, --slurm-arg, --no-wait, --slurm-dry-run", "only with --slurm");
    if (gather && (on_slurm || slurm_dir.empty() || out.empty()))
      throw UsageError("", "--slurm-gather", "needs --slurm-dir and -o, not --slurm");
    if (on_slurm) {
      if (tasks < 1) throw UsageError("", "--tasks", "--slurm needs --tasks N, N >= 1");
      if (!points.empty() || opt.max_points > 0) throw UsageError("", "--points, --max-points", "not with --slurm");
      if (!(slurm.mode.poll_seconds > 0.0)) throw UsageError("", "--poll", "must be a positive number of seconds");
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
    if (!points.empty())
      opt.points = as_usage([&] { return experiments::points_from_string(points, static_cast<int>(ex.points.size())); });
    if (on_slurm || gather) {
      experiments::RunOptions nothing = opt;  // checks the results folder, lists the points left
      nothing.points = std::vector<int>{};
      const std::vector<int> left = experiments::run_experiment(ex, nothing).left;
      if (left.empty()) return summary(ex.name, experiments::run_experiment(ex, nothing), out);
      slurm.dir = slurm_dir.empty() ? fs::path(out) / "slurm" : fs::path(slurm_dir);
      if (gather) return summary(ex.name, experiments::gather_task_records(ex, left, slurm.dir, out), out);
      slurm.mode.wait = !no_wait;
      slurm.cache = fs::absolute(cache.empty() ? experiments::default_cache(out) : fs::path(cache));
      const auto report = submit_to_slurm(ex, slurm, left, tasks, out, argc, argv, quiet);
      return report ? summary_after_gather(ex, nothing, *report, out, slurm.dir) : 0;  // else: dry run, --no-wait
    }
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
    return summary(ex.name, experiments::run_experiment(ex, opt), out);
  });
}
