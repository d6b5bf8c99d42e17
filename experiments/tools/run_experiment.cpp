// run-experiment: every point of an experiment config (sweeps, cross-training, comparisons; thesis
// chapter 4) trained and evaluated with the library, one JSON line per point, resumable.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include <opencv2/core/utility.hpp>

#include "smseg/common/cli.hpp"
#include "smseg/common/options.hpp"
#include "smseg/common/output.hpp"
#include "smseg/common/slurm_cli.hpp"
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

/// The command line: the config, where results go, and how the points run (here or on Slurm).
struct Args {
  std::string config, out, cache, points, slurm_dir;
  smseg::experiments::RunOptions opt;
  smseg::experiments::SlurmRun slurm;
  bool quick = false, quiet = false, check = false, on_slurm = false, no_wait = false, gather = false;
  int threads = 0, tasks = 0;
};

void add_options(CLI::App& app, Args& a) {
  app.add_option("CONFIG", a.config, "experiment config (JSON, format smseg-experiment)")->required();
  app.add_option("-o,--out", a.out, "results folder: config.json and experiment.jsonl (required unless --check)");
  app.add_flag("--quick", a.quick, "run the config's quick form (its \"quick\" merge patch: a coarse grid on small data)");
  app.add_option("--cache", a.cache, "folder for generated sequences and extracted work folders (default: OUT/../cache)");
  app.add_option("--max-points", a.opt.max_points, "stop after this many new points (0: all); a rerun continues")
      ->check(smseg::options::in_range(0, 1000000000))
      ->capture_default_str();
  app.add_option("--memory-mb", a.opt.memory_mb, "memory budget of each training in MiB: trees are built in batches that fit; refused if one tree does not")
      ->check(smseg::options::in_range<std::size_t>(1, std::size_t{1} << 30))  // 1 MiB .. 1 PiB: more is a typing error
      ->capture_default_str();
  smseg::add_threads_option(app, a.threads, "results do not depend on it");
  app.add_flag("--check", a.check, "validate the config and list its points, run nothing");
  app.add_flag("-q,--quiet", a.quiet, "no progress on stderr, no line per point");
  app.add_option("--points", a.points, "run only these points (comma-separated indices, as --check lists them)");
  smseg::slurm::add_options(
      app,
      {"run the points as a Slurm job array (sbatch) and a gather job that collects their records; wait for both",
       "array tasks (at least 1; more than the forests the points left need are not used)",
       "job folder (job.sh, logs/, tasks/), kept (default: OUT/slurm)", "OUT"},
      a.on_slurm, a.tasks, a.slurm_dir, a.slurm.sbatch_options, a.no_wait, a.slurm.mode);
  // The gather job's own command: the tasks' records (under --slurm-dir) into OUT. Not for users.
  app.add_flag("--slurm-gather", a.gather)->group("");
}

/// UsageError for Slurm options without --slurm, or --slurm without what it needs.
void check_slurm_options(const Args& a) {
  using smseg::UsageError;
  if (!a.on_slurm && (a.tasks != 0 || (!a.slurm_dir.empty() && !a.gather) || !a.slurm.sbatch_options.empty() ||
                      a.no_wait || a.slurm.mode.dry_run))
    throw UsageError("", "--tasks, --slurm-dir, --slurm-arg, --no-wait, --slurm-dry-run", "only with --slurm");
  if (a.gather && (a.on_slurm || a.slurm_dir.empty() || a.out.empty()))
    throw UsageError("", "--slurm-gather", "needs --slurm-dir and -o, not --slurm");
  if (a.on_slurm) {
    if (a.tasks < 1) throw UsageError("", "--tasks", "--slurm needs --tasks N, N >= 1");
    if (!a.points.empty() || a.opt.max_points > 0) throw UsageError("", "--points, --max-points", "not with --slurm");
    if (!(a.slurm.mode.poll_seconds > 0.0)) throw UsageError("", "--poll", "must be a positive number of seconds");
  }
}

/// --check: the experiment's name and its points.
int list_points(const smseg::experiments::Experiment& ex, bool quick) {
  std::cout << ex.name << (quick ? " (quick)" : "") << ": " << ex.points.size() << " points\n";
  for (const auto& p : ex.points) std::cout << "  " << p.index << ": " << p.describe() << "\n";
  return 0;
}

/// --slurm (submit the points left, wait unless --no-wait) or --slurm-gather (collect the tasks' records).
int run_on_slurm(const smseg::experiments::Experiment& ex, Args& a, int argc, char** argv) {
  using namespace smseg;
  experiments::RunOptions nothing = a.opt;  // checks the results folder, lists the points left
  nothing.points = std::vector<int>{};
  nothing.look_only = a.slurm.mode.dry_run;
  const std::vector<int> left = experiments::run_experiment(ex, nothing).left;
  if (left.empty()) return summary(ex.name, experiments::run_experiment(ex, nothing), a.out);
  a.slurm.dir = a.slurm_dir.empty() ? fs::path(a.out) / "slurm" : fs::path(a.slurm_dir);
  if (a.gather) return summary(ex.name, experiments::gather_task_records(ex, left, a.slurm.dir, a.out), a.out);
  a.slurm.mode.wait = !a.no_wait;
  a.slurm.cache = fs::absolute(a.cache.empty() ? experiments::default_cache(a.out) : fs::path(a.cache));
  const auto report = submit_to_slurm(ex, a.slurm, left, a.tasks, a.out, argc, argv, a.quiet);
  return report ? summary_after_gather(ex, nothing, *report, a.out, a.slurm.dir) : 0;  // else: dry run, --no-wait
}

/// The line printed after each point: its accuracies, training time and size, and time per frame.
void print_point(const smseg::experiments::Point& p, const nlohmann::json& rec, int total) {
  char line[512];
  std::snprintf(line, sizeof line,
                "[%d/%d] %s: global %s, class-average %s, mean IoU %s; train %.2f s, %.0f nodes per tree; %.1f ms per frame",
                p.index + 1, total, p.describe().c_str(), pct(rec["global_accuracy"]).c_str(),
                pct(rec["class_average_accuracy"]).c_str(), pct(rec["mean_iou"]).c_str(),
                rec["train_seconds"].get<double>(), rec["nodes_per_tree"].get<double>(),
                1000 * rec["seconds_per_frame"].get<double>());
  std::cout << line << std::endl;
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
  Args a;
  add_options(app, a);
  return run_tool(app, argc, argv, a.threads, [&] {
    if (a.threads > 0) cv::setNumThreads(a.threads);
    check_slurm_options(a);
    const experiments::Experiment ex = experiments::load_experiment(a.config, a.quick);
    if (a.check) return list_points(ex, a.quick);
    if (a.out.empty()) {
      std::cerr << "run-experiment: --out is required (see run-experiment --help)\n";
      return 2;
    }
    a.opt.out = a.out;
    a.opt.cache = a.cache;
    a.opt.progress = !a.quiet;
    if (!a.points.empty())
      a.opt.points =
          as_usage([&] { return experiments::points_from_string(a.points, static_cast<int>(ex.points.size())); });
    std::optional<OutputLock> one_writer;  // not the gather job: its submitter holds it, waiting for it
    if (!a.gather && !a.slurm.mode.dry_run) one_writer.emplace(a.out, std::vector<fs::path>{a.config});
    if (a.on_slurm || a.gather) return run_on_slurm(ex, a, argc, argv);
    const int total = static_cast<int>(ex.points.size());
    if (!a.quiet)
      a.opt.on_point = [total](const experiments::Point& p, const nlohmann::json& rec) { print_point(p, rec, total); };
    return summary(ex.name, experiments::run_experiment(ex, a.opt), a.out);
  });
}
