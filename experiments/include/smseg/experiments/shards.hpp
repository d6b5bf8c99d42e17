#pragma once
// run-experiment --slurm: the points left to run are shared out among the tasks of a Slurm job
// array; each task is a run-experiment of its own points (--points) into its own results folder
// DIR/tasks/task-<i>, with the shared data cache; when every task has succeeded, a gather job
// (run-experiment --slurm-gather) appends their records to OUT/experiment.jsonl in point order. The
// records are those of a local run (timing fields aside), and a rerun runs only the points that
// have a record neither in OUT nor in any task's folder.
//
// Points that share a forest (consecutive points with the same training parameters, e.g. the grid
// sizes of one K) always go to the same task, so no forest is trained twice; forests are dealt to
// the tasks in turn (the first to task 0, the second to task 1, ...), which spreads the large and
// small ones of a sweep.

#include <filesystem>
#include <string>
#include <vector>

#include <optional>

#include "smseg/common/slurm.hpp"
#include "smseg/experiments/config.hpp"
#include "smseg/experiments/runner.hpp"

namespace smseg::experiments {

/// The points (indices, in order) of each task. `left`: the points to run; Error naming `option`
/// unless 1 <= tasks <= the number of forests they need.
std::vector<std::vector<int>> shard_points(const Experiment& ex, const std::vector<int>& left, int tasks,
                                           const std::string& option = "--tasks");

/// How many forests `points` need (runs of consecutive points with the same training).
int forests_needed(const Experiment& ex, const std::vector<int>& points);

/// "0,3,4": a --points value.
std::string points_to_string(const std::vector<int>& points);
/// The indices of a --points value ("0,3,4"); Error naming `option` for anything else or an index
/// outside 0..count-1.
std::vector<int> points_from_string(const std::string& text, int count, const std::string& option = "--points");

/// DIR/tasks/task-<i>: the results folder of task i.
std::filesystem::path task_results(const std::filesystem::path& dir, int task);

/// Appends to OUT/experiment.jsonl, in the order of `left`, the record of each point found in the
/// results folders under DIR/tasks; returns the points that have none.
std::vector<int> collect_task_records(const Experiment& ex, const std::vector<int>& left,
                                      const std::filesystem::path& dir, const std::filesystem::path& out);

/// The points of `left` that have no record under DIR/tasks.
std::vector<int> missing_task_records(const Experiment& ex, const std::vector<int>& left,
                                      const std::filesystem::path& dir);

/// The gather step (run-experiment --slurm-gather, the gather job): collect_task_records for the
/// points `left`; Error naming the points still without a record.
RunReport gather_task_records(const Experiment& ex, const std::vector<int>& left, const std::filesystem::path& dir,
                              const std::filesystem::path& out);

/// run-experiment --slurm.
struct SlurmRun {
  std::filesystem::path program;            ///< the run-experiment each task runs
  std::vector<std::string> args;            ///< its arguments: CONFIG, --quick, ... (no -o, --cache, --points)
  std::filesystem::path out;                ///< the results folder
  std::filesystem::path cache;              ///< the data cache the tasks share (absolute)
  std::filesystem::path dir;                ///< job folder: job.sh, logs/, tasks/
  std::vector<std::string> sbatch_options;  ///< extra #SBATCH options (--slurm-arg)
  slurm::RunMode mode;                      ///< dry run, wait or not, polling, progress
};

/// For the points `left` (no record in OUT): submits one array task per shard (from shard_points,
/// of the points no task has a record of yet) and the gather job, or gathers here when every point
/// has a task record. Returns the report when the records are in OUT/experiment.jsonl, nothing after
/// a dry run or without waiting. Error naming the failed tasks (state, log) when points are still
/// missing; the records that did arrive are kept, so a rerun runs only the rest.
std::optional<RunReport> run_experiment_slurm(const Experiment& ex, const SlurmRun& run, const std::vector<int>& left,
                                              const std::vector<std::vector<int>>& shards);

}  // namespace smseg::experiments
