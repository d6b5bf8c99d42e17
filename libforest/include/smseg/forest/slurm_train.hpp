#pragma once
// Training a forest as a Slurm job array (train-forest --slurm): the M trees are split into --tasks
// contiguous ranges (split_trees), task i trains range i with the very same command line plus
// "--trees A:B -o DIR/parts/part-<i>.json", and a gather job (after every task has succeeded) runs
// "train-forest --merge DIR/parts/part-*.json -o OUT", so the forest appears even when the submitting
// command does not wait. The merged forest is the local one for the same seed, timing fields aside.
//
// The job folder DIR keeps job.sh, gather.sh, logs/task-<i>.log, logs/gather.log and parts/. A rerun resubmits only the tasks
// whose part is missing (parts already there must be of this very training, else Error), so a failed
// or cancelled task costs only its own trees.

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "smseg/common/slurm.hpp"
#include "smseg/forest/forest.hpp"
#include "smseg/forest/params.hpp"

namespace smseg::forest {

struct SlurmTraining {
  std::filesystem::path program;            ///< the train-forest to run in each task
  std::vector<std::string> args;            ///< its arguments, without tree range, output or Slurm options
  TrainParams params;                       ///< the training (M and everything parts must agree on)
  int tasks = 0;                            ///< array tasks (1..M); 0: one per tree
  std::filesystem::path dir;                ///< job folder
  std::filesystem::path out;                ///< the forest file the gather job writes
  std::vector<std::string> sbatch_options;  ///< extra #SBATCH options (--slurm-arg)
  slurm::RunMode mode;                      ///< dry run, wait or not, polling, progress
};

/// Submits the missing parts and the gather job (see slurm::run_array_then_gather), or merges here
/// when no part is missing. Returns true when the forest is at job.out, false after a dry run or
/// without waiting. Error naming the failed tasks (Slurm's state for each and its log) when a part
/// is missing afterwards, or the gather log when the gather job wrote no forest.
bool train_forest_slurm(const SlurmTraining& job);

/// DIR/parts/part-<task>.json
std::filesystem::path part_file(const std::filesystem::path& dir, int task);

}  // namespace smseg::forest
