#pragma once
// The Slurm options of the tools that can run on a cluster (train-forest, run-experiment), declared once:
// the same spellings, checks and help, each tool saying what its tasks do and where its job folder is.
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "smseg/common/options.hpp"
#include "smseg/common/slurm.hpp"

namespace smseg::slurm {

/// What the help of a tool's Slurm options says of it.
struct OptionHelp {
  std::string slurm;  ///< --slurm: what runs as the job array and what the gather job does
  std::string tasks;  ///< --tasks: what each array task does, and its range
  std::string dir;    ///< --slurm-dir: what the job folder holds, and its default
  std::string out;    ///< what the gather job writes ("-o", "OUT")
};

/// Adds --slurm, --tasks, --slurm-dir, --slurm-arg, --no-wait, --slurm-dry-run and --poll, writing into
/// the tool's own fields.
inline void add_options(CLI::App& app, const OptionHelp& help, bool& on_slurm, int& tasks, std::string& dir,
                        std::vector<std::string>& sbatch_options, bool& no_wait, RunMode& mode) {
  app.add_flag("--slurm", on_slurm, help.slurm);
  app.add_option("--tasks", tasks, "with --slurm: " + help.tasks)->check(options::in_range(0, 100000));
  app.add_option("--slurm-dir", dir, "with --slurm: " + help.dir);
  app.add_option("--slurm-arg", sbatch_options,
                 "with --slurm: an sbatch option for the array and the gather job, e.g. --slurm-arg=--partition=short "
                 "(repeatable)")
      ->allow_extra_args(false);
  app.add_flag("--no-wait", no_wait,
               "with --slurm: return once submitted (job ids and logs on stdout); the gather job writes " + help.out);
  app.add_flag("--slurm-dry-run", mode.dry_run, "with --slurm: print the job scripts and sbatch lines, submit nothing");
  app.add_option("--poll", mode.poll_seconds, "with --slurm: seconds between squeue checks")->capture_default_str()
      ->check(options::in_range(0.01, 3600.0));
}

}  // namespace smseg::slurm
