// Training a forest as a Slurm job array (see slurm_train.hpp).
#include "smseg/common/error.hpp"
#include "smseg/forest/parts.hpp"
#include "smseg/forest/slurm_train.hpp"
#include "smseg/common/slurm.hpp"

namespace smseg::forest {

namespace {

/// Whether task `task`'s part is already there. A part of another training is an Error: merging it
/// would mix forests, and overwriting it silently could destroy someone's results.
bool have_part(const SlurmTraining& job, int task, const TreeRange& range) {
  const std::filesystem::path file = part_file(job.dir, task);
  if (!std::filesystem::exists(file)) return false;
  const ForestPart part = load_forest_part(file);
  if (params_to_json(part.forest.params) != params_to_json(job.params))
    throw Error(file.string(), "params",
                "this part comes from another training (other parameters); remove " + job.dir.string() +
                    " or choose another --slurm-dir");
  if (part.range != range)
    throw Error(file.string(), "trees",
                "is " + part.range.to_string() + " but task " + std::to_string(task) + " now trains " +
                    range.to_string() + " (another --tasks); remove " + job.dir.string() + " or choose another --slurm-dir");
  return true;
}

std::vector<std::string> task_command(const SlurmTraining& job, int task, const TreeRange& range) {
  std::vector<std::string> cmd{job.program.string()};
  cmd.insert(cmd.end(), job.args.begin(), job.args.end());
  cmd.insert(cmd.end(), {"--trees", range.to_string(), "-o", part_file(job.dir, task).string(), "--quiet"});
  return cmd;
}

}  // namespace

std::filesystem::path part_file(const std::filesystem::path& dir, int task) {
  return std::filesystem::absolute(dir) / "parts" / ("part-" + std::to_string(task) + ".json");
}

bool train_forest_slurm(const SlurmTraining& job) {
  const int tasks = job.tasks == 0 ? job.params.M : job.tasks;
  const std::vector<TreeRange> ranges = split_trees(job.params.M, tasks, "--tasks");
  slurm::ArrayJob array;
  array.name = "train-forest";
  array.dir = job.dir;
  array.sbatch_options = job.sbatch_options;
  std::vector<std::filesystem::path> files;
  for (int t = 0; t < tasks; ++t) {
    array.commands.push_back(task_command(job, t, ranges[static_cast<std::size_t>(t)]));
    if (!have_part(job, t, ranges[static_cast<std::size_t>(t)])) array.tasks.push_back(t);
    files.push_back(part_file(job.dir, t));
  }
  if (array.tasks.empty() && !job.mode.dry_run) {  // every part is there: merge here
    save_forest(merge_forest_parts(files), job.out);
    return true;
  }
  slurm::GatherJob gather{"train-forest", job.dir, {}, {job.program.string(), "--merge"}, job.sbatch_options};
  for (const auto& f : files) gather.command.push_back(f.string());
  gather.command.insert(gather.command.end(), {"-o", std::filesystem::absolute(job.out).string()});
  // An older forest at -o must not pass for this one's if the gather job fails.
  if (!job.mode.dry_run) std::filesystem::remove(job.out);
  const auto failed = [&] {
    std::vector<int> missing;
    for (int t : array.tasks)
      if (!std::filesystem::exists(part_file(job.dir, t))) missing.push_back(t);
    return missing;
  };
  if (!slurm::run_array_then_gather(array, gather, job.mode, failed)) return false;
  if (!std::filesystem::exists(job.out))
    throw Error(job.out.string(), "--slurm",
                "the gather job wrote no forest; its log: " + slurm::gather_log(job.dir).string());
  return true;
}

}  // namespace smseg::forest
