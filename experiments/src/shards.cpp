// run-experiment --slurm: points shared out among array tasks, records collected (see shards.hpp).
#include "smseg/experiments/shards.hpp"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <map>
#include <sstream>

#include "smseg/common/error.hpp"
#include "smseg/eval/sweep.hpp"
#include "smseg/common/slurm.hpp"

namespace smseg::experiments {

namespace {

/// Runs of consecutive points (in `left`) with the same training parameters: the runner trains one
/// forest per run, so a run must not be split between tasks.
std::vector<std::vector<int>> forest_groups(const Experiment& ex, const std::vector<int>& left) {
  std::vector<std::vector<int>> groups;
  std::string last_key;
  for (int i : left) {
    const std::string key = ex.points.at(static_cast<std::size_t>(i)).training_key().dump();
    if (groups.empty() || key != last_key || groups.back().back() + 1 != i) groups.emplace_back();
    groups.back().push_back(i);
    last_key = key;
  }
  return groups;
}

/// The tasks whose points include one of `missing`.
std::vector<int> tasks_of(const std::vector<std::vector<int>>& shards, const std::vector<int>& missing) {
  std::vector<int> tasks;
  for (std::size_t t = 0; t < shards.size(); ++t)
    for (int p : shards[t])
      if (std::count(missing.begin(), missing.end(), p)) {
        tasks.push_back(static_cast<int>(t));
        break;
      }
  return tasks;
}

}  // namespace

std::vector<std::vector<int>> shard_points(const Experiment& ex, const std::vector<int>& left, int tasks,
                                           const std::string& option) {
  const auto groups = forest_groups(ex, left);
  if (tasks < 1 || tasks > static_cast<int>(std::max<std::size_t>(1, groups.size())))
    throw Error("", option,
                "is " + std::to_string(tasks) + ", expected 1.." + std::to_string(std::max<std::size_t>(1, groups.size())) +
                    ": the " + std::to_string(left.size()) + " points left need " + std::to_string(groups.size()) +
                    " forests, and points sharing a forest run in one task");
  std::vector<std::vector<int>> shards(static_cast<std::size_t>(tasks));
  for (std::size_t g = 0; g < groups.size(); ++g) {
    auto& shard = shards[g % static_cast<std::size_t>(tasks)];
    shard.insert(shard.end(), groups[g].begin(), groups[g].end());
  }
  return shards;
}

int forests_needed(const Experiment& ex, const std::vector<int>& points) {
  return static_cast<int>(forest_groups(ex, points).size());
}

std::string points_to_string(const std::vector<int>& points) {
  std::string s;
  for (int p : points) s += (s.empty() ? "" : ",") + std::to_string(p);
  return s;
}

std::vector<int> points_from_string(const std::string& text, int count, const std::string& option) {
  std::vector<int> points;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    int v = -1;
    const auto r = std::from_chars(item.data(), item.data() + item.size(), v);
    if (item.empty() || r.ec != std::errc() || r.ptr != item.data() + item.size())
      throw Error("", option, "\"" + item + "\" is not a point index (a comma-separated list like 0,3,4)");
    if (v < 0 || v >= count)
      throw Error("", option, std::to_string(v) + " is not a point of this config (0.." + std::to_string(count - 1) + ")");
    points.push_back(v);
  }
  if (points.empty()) throw Error("", option, "names no point");
  return points;
}

std::filesystem::path task_results(const std::filesystem::path& dir, int task) {
  return std::filesystem::absolute(dir) / "tasks" / ("task-" + std::to_string(task));
}

namespace {

/// Every record found in the task folders under DIR/tasks, by canonical point.
std::map<std::string, nlohmann::json> task_records(const std::filesystem::path& dir) {
  std::map<std::string, nlohmann::json> found;
  const std::filesystem::path tasks = std::filesystem::absolute(dir) / "tasks";
  if (std::filesystem::exists(tasks))
    for (const auto& entry : std::filesystem::directory_iterator(tasks))
      for (auto& rec : eval::read_jsonl(entry.path() / "experiment.jsonl"))
        found.emplace(rec.at("point").dump(), std::move(rec));
  return found;
}

RunReport report_of(const Experiment& ex, const std::vector<int>& left, std::chrono::steady_clock::time_point t0) {
  RunReport report;
  report.total = static_cast<int>(ex.points.size());
  report.done_before = report.total - static_cast<int>(left.size());
  report.run = static_cast<int>(left.size());
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

}  // namespace

std::vector<int> missing_task_records(const Experiment& ex, const std::vector<int>& left,
                                      const std::filesystem::path& dir) {
  const auto found = task_records(dir);
  std::vector<int> missing;
  for (int i : left)
    if (!found.count(ex.points.at(static_cast<std::size_t>(i)).json.dump())) missing.push_back(i);
  return missing;
}

std::vector<int> collect_task_records(const Experiment& ex, const std::vector<int>& left,
                                      const std::filesystem::path& dir, const std::filesystem::path& out) {
  const auto found = task_records(dir);
  std::vector<int> missing;
  for (int i : left) {
    const auto it = found.find(ex.points.at(static_cast<std::size_t>(i)).json.dump());
    if (it == found.end()) {
      missing.push_back(i);
      continue;
    }
    eval::append_jsonl(out / "experiment.jsonl", it->second);
  }
  return missing;
}

RunReport gather_task_records(const Experiment& ex, const std::vector<int>& left, const std::filesystem::path& dir,
                              const std::filesystem::path& out) {
  const auto t0 = std::chrono::steady_clock::now();
  // Check first, append after: a gather that cannot finish leaves OUT as it was.
  const std::vector<int> missing = missing_task_records(ex, left, dir);
  if (!missing.empty())
    throw Error(std::filesystem::absolute(dir / "tasks").string(), "--slurm-gather",
                "points " + points_to_string(missing) + " have no record in any task's folder");
  collect_task_records(ex, left, dir, out);
  return report_of(ex, left, t0);
}

std::optional<RunReport> run_experiment_slurm(const Experiment& ex, const SlurmRun& run, const std::vector<int>& left,
                                              const std::vector<std::vector<int>>& shards) {
  const auto t0 = std::chrono::steady_clock::now();
  if (shards.empty() && !run.mode.dry_run) return gather_task_records(ex, left, run.dir, run.out);
  slurm::ArrayJob array;
  array.name = "run-experiment";
  array.dir = run.dir;
  array.sbatch_options = run.sbatch_options;
  std::vector<int> todo;
  const auto command = [&](std::initializer_list<std::string> own) {
    std::vector<std::string> cmd{run.program.string()};
    cmd.insert(cmd.end(), run.args.begin(), run.args.end());
    cmd.insert(cmd.end(), {"--cache", run.cache.string(), "--quiet"});
    cmd.insert(cmd.end(), own);
    return cmd;
  };
  for (std::size_t t = 0; t < shards.size(); ++t) {
    array.commands.push_back(
        command({"-o", task_results(run.dir, static_cast<int>(t)).string(), "--points", points_to_string(shards[t])}));
    todo.insert(todo.end(), shards[t].begin(), shards[t].end());
  }
  const std::string dir = std::filesystem::absolute(run.dir).string();
  const slurm::GatherJob gather{"run-experiment", run.dir, {},
                                command({"-o", std::filesystem::absolute(run.out).string(), "--slurm-dir", dir,
                                         "--slurm-gather"}),
                                run.sbatch_options};
  const auto failed = [&] { return tasks_of(shards, missing_task_records(ex, todo, run.dir)); };
  if (!slurm::run_array_then_gather(array, gather, run.mode, failed)) return std::nullopt;
  return report_of(ex, left, t0);
}

}  // namespace smseg::experiments
