#pragma once
// Running work as a Slurm job array from a tool: write the job script, submit it with sbatch, wait
// for every task with squeue, and ask Slurm how each task ended (sacct when the cluster keeps
// accounting, otherwise scontrol, which remembers finished jobs for MinJobAge, 300 s by default).
//
// By default the tool that submits stays in the foreground until the array and the gather job that
// follows it are done, so a caller sees one command that succeeds or fails as a whole; it may also
// return right after submitting, the gather job then writing the outputs. Each task runs one command (an argv, quoted into the
// script, no shell expansion of our arguments) in the submitting folder, and writes its log to
// DIR/logs/task-<i>.log. Paths therefore have to be on a file system the nodes share.
//
// Depends on nothing of ours but the error and file helpers.

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace smseg::slurm {

/// One job array: task i runs commands[i].
struct ArrayJob {
  std::string name;                                  ///< sbatch --job-name
  std::filesystem::path dir;                         ///< job folder: job.sh and logs/ (made absolute)
  std::filesystem::path workdir;                     ///< where tasks run (sbatch --chdir); empty: the current folder
  std::vector<std::vector<std::string>> commands;    ///< argv per task
  std::vector<int> tasks;                            ///< the task indices to submit (empty: all)
  std::vector<std::string> sbatch_options;           ///< extra "#SBATCH" options ("--partition=p", "--time=30")
};

/// The gather job: one command, run once every array task has succeeded (sbatch
/// --dependency=afterok:<array>, --kill-on-invalid-dep=yes so a failed task cancels it rather than
/// leaving it pending for ever). It merges what the tasks wrote into the outputs a local run writes,
/// so the outputs appear even when the submitting tool does not wait (--no-wait).
struct GatherJob {
  std::string name;                         ///< sbatch --job-name
  std::filesystem::path dir;                ///< job folder: gather.sh and logs/gather.log
  std::filesystem::path workdir;            ///< empty: the current folder
  std::vector<std::string> command;         ///< argv
  std::vector<std::string> sbatch_options;  ///< as ArrayJob's (partition, account, ...)
};

/// How the tool goes through Slurm: print the scripts only, or submit and wait, or submit and return.
struct RunMode {
  bool dry_run = false;  ///< --slurm-dry-run: print scripts and sbatch lines, submit nothing
  bool wait = true;      ///< false: --no-wait
  double poll_seconds = 2.0;
  bool progress = true;  ///< submission and waiting on stderr
};

/// How one array task ended, as Slurm tells it.
struct TaskState {
  int task = -1;
  std::string state;      ///< COMPLETED, FAILED, CANCELLED, TIMEOUT, OUT_OF_MEMORY, NODE_FAIL, ...
  std::string exit_code;  ///< "status:signal", e.g. "1:0"
};

/// Waiting: how often squeue is asked, and what to tell the user (tasks not yet finished).
struct WaitOptions {
  double poll_seconds = 2.0;
  std::function<void(int unfinished)> on_poll;  ///< called after every squeue answer
};

/// Error naming `command` unless it is an executable on PATH.
void require_command(const std::string& command, const std::string& why);

/// The script sbatch gets: #SBATCH lines, then a case over SLURM_ARRAY_TASK_ID, one exec per task.
std::string job_script(const ArrayJob& job);
/// Writes dir/job.sh atomically (and makes dir/logs); returns its path.
std::filesystem::path write_job_script(const ArrayJob& job);
std::filesystem::path task_log(const std::filesystem::path& dir, int task);

/// The gather job's script: #SBATCH lines, then one exec.
std::string gather_script(const GatherJob& job);
std::filesystem::path gather_log(const std::filesystem::path& dir);

/// sbatch --parsable [--dependency=afterok:AFTER] SCRIPT; returns the job id. Error with sbatch's own
/// message when it refuses.
std::string submit(const std::filesystem::path& script, const std::string& after = "");
/// scancel JOB (errors ignored: the job may have ended meanwhile).
void cancel(const std::string& job_id);
/// Returns when squeue no longer lists the job (every task finished, failed or was cancelled).
void wait_for_job(const std::string& job_id, const WaitOptions& options);
/// How each task ended: sacct, else scontrol; empty when Slurm no longer knows the job.
std::vector<TaskState> task_states(const std::string& job_id);

/// write_job_script, submit, wait_for_job; returns the job id. `says` tells the user what was
/// submitted (one line, or nothing when empty).
std::string run_array_job(const ArrayJob& job, const WaitOptions& options,
                          const std::function<void(const std::string&)>& says = {});

/// The array and its gather job, by `mode`: a dry run prints both scripts and their sbatch lines on
/// stdout and returns false; otherwise both are submitted, and without `mode.wait` the job ids and
/// logs are printed and it returns false. Waiting, once the array has ended it asks `failed_tasks`
/// which tasks did not deliver: if any, the gather job is cancelled and Error names them (state,
/// exit code, log); else it waits for the gather job and returns true (the caller then checks the
/// gathered outputs). A caller with no task left to run gathers itself instead of calling this.
bool run_array_then_gather(const ArrayJob& array, const GatherJob& gather, const RunMode& mode,
                           const std::function<std::vector<int>()>& failed_tasks);

/// Single quotes for a POSIX shell: the string comes through as one word, unexpanded.
std::string shell_quote(const std::string& s);
/// "0-3,5,7-9": the array spec sbatch --array takes for these (sorted, distinct) indices.
std::string array_spec(std::vector<int> tasks);

/// argv without the options named: `flags` take no value; `valued` take one, given as "--opt v",
/// "--opt=v" or (one-letter) "-ov". For re-running a tool's own command line as a task.
std::vector<std::string> without_options(const std::vector<std::string>& args, const std::vector<std::string>& flags,
                                         const std::vector<std::string>& valued);
/// The running program's absolute path (/proc/self/exe), so tasks run the very same build.
std::filesystem::path current_executable();

/// One line saying what went wrong with the tasks that did not deliver: their state and log.
std::string describe_failures(const std::filesystem::path& dir, const std::vector<int>& failed,
                              const std::vector<TaskState>& states);

}  // namespace smseg::slurm
