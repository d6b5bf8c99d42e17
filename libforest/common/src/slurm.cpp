// Slurm job arrays from a tool: job script, sbatch, squeue, sacct / scontrol (see slurm.hpp).
#include "smseg/common/slurm.hpp"

#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "smseg/common/cli.hpp"  // UsageError
#include "smseg/common/error.hpp"
#include "smseg/common/io.hpp"

namespace smseg::slurm {

namespace {

struct CommandResult {
  int status = -1;  ///< exit status; -1 when killed by a signal
  std::string out, err;
};

/// Runs argv (no shell) and collects its stdout and stderr; Error when it cannot be started.
CommandResult run_command(const std::vector<std::string>& argv) {
  int out_pipe[2], err_pipe[2];
  if (::pipe(out_pipe) != 0 || ::pipe(err_pipe) != 0)
    throw Error("", argv.front(), std::string("cannot run: ") + std::strerror(errno));
  const pid_t pid = ::fork();
  if (pid < 0) throw Error("", argv.front(), std::string("cannot run: ") + std::strerror(errno));
  if (pid == 0) {
    ::dup2(out_pipe[1], 1);
    ::dup2(err_pipe[1], 2);
    ::close(out_pipe[0]);
    ::close(err_pipe[0]);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execvp(args[0], args.data());
    ::_exit(127);
  }
  ::close(out_pipe[1]);
  ::close(err_pipe[1]);
  CommandResult r;
  pollfd fds[2] = {{out_pipe[0], POLLIN, 0}, {err_pipe[0], POLLIN, 0}};
  std::string* sinks[2] = {&r.out, &r.err};
  int open = 2;
  char buf[4096];
  while (open > 0) {
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    for (int i = 0; i < 2; ++i) {
      if (fds[i].fd < 0 || !(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const ssize_t n = ::read(fds[i].fd, buf, sizeof buf);
      if (n > 0) {
        sinks[i]->append(buf, static_cast<std::size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        ::close(fds[i].fd);
        fds[i].fd = -1;
        --open;
      }
    }
  }
  int st = 0;
  while (::waitpid(pid, &st, 0) < 0 && errno == EINTR) {
  }
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

std::string first_line(const std::string& s) {
  std::string line = s.substr(0, s.find('\n'));
  return line.empty() ? "(no message)" : line;
}

std::string trim(std::string s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.erase(s.begin());
  return s;
}

/// "key=value" fields of one `scontrol -o` record.
std::map<std::string, std::string> scontrol_fields(const std::string& line) {
  std::map<std::string, std::string> f;
  std::istringstream in(line);
  for (std::string word; in >> word;) {
    const auto eq = word.find('=');
    if (eq != std::string::npos) f[word.substr(0, eq)] = word.substr(eq + 1);
  }
  return f;
}

std::vector<TaskState> states_from_sacct(const std::string& job_id) {
  const auto r = run_command({"sacct", "-n", "-P", "-X", "-j", job_id, "--format=JobID,State,ExitCode"});
  std::vector<TaskState> states;
  if (r.status != 0) return states;  // e.g. "Slurm accounting storage is disabled"
  std::istringstream in(r.out);
  for (std::string line; std::getline(in, line);) {
    // "1234_5|COMPLETED|0:0"; a state may read "CANCELLED by 0".
    const auto bar1 = line.find('|'), bar2 = line.rfind('|');
    const auto under = line.find('_');
    if (bar1 == std::string::npos || bar2 == bar1 || under == std::string::npos || under > bar1) continue;
    TaskState s;
    s.task = std::atoi(line.substr(under + 1, bar1 - under - 1).c_str());
    s.state = line.substr(bar1 + 1, bar2 - bar1 - 1);
    s.exit_code = line.substr(bar2 + 1);
    states.push_back(s);
  }
  return states;
}

std::vector<TaskState> states_from_scontrol(const std::string& job_id) {
  const auto r = run_command({"scontrol", "-o", "show", "job", job_id});
  std::vector<TaskState> states;
  if (r.status != 0) return states;  // purged after MinJobAge
  std::istringstream in(r.out);
  for (std::string line; std::getline(in, line);) {
    auto f = scontrol_fields(line);
    if (!f.count("ArrayTaskId") || !f.count("JobState")) continue;
    TaskState s;
    s.task = std::atoi(f["ArrayTaskId"].c_str());
    s.state = f["JobState"];
    s.exit_code = f["ExitCode"];
    states.push_back(s);
  }
  return states;
}

/// The #SBATCH lines both scripts share: name, log, folder, the user's options (--slurm-arg).
std::string sbatch_lines(const std::string& name, const fs::path& log, const fs::path& workdir,
                         const std::vector<std::string>& options) {
  std::string s = "#SBATCH --job-name=" + name + "\n";
  s += "#SBATCH --output=" + log.string() + "\n";
  s += "#SBATCH --chdir=" + fs::absolute(workdir.empty() ? fs::current_path() : workdir).string() + "\n";
  for (const auto& o : options) {
    if (o.empty() || o[0] != '-' || o.find_first_of("\n\r") != std::string::npos)
      throw Error("", "--slurm-arg", "\"" + o + "\" is not one sbatch option (expected e.g. --partition=NAME)");
    s += "#SBATCH " + o + "\n";
  }
  return s;
}

std::string quoted_command(const std::vector<std::string>& argv) {
  std::string s;
  for (const auto& a : argv) s += " " + shell_quote(a);
  return s;
}

std::vector<int> array_tasks(const ArrayJob& job) {
  std::vector<int> tasks = job.tasks;
  if (tasks.empty())
    for (int i = 0; i < static_cast<int>(job.commands.size()); ++i) tasks.push_back(i);
  return tasks;
}

}  // namespace

void require_command(const std::string& command, const std::string& why) {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path ? path : "");
  for (std::string d; std::getline(dirs, d, ':');) {
    const fs::path p = fs::path(d.empty() ? "." : d) / command;
    if (::access(p.c_str(), X_OK) == 0 && !fs::is_directory(p)) return;
  }
  throw Error("", command, "not found on PATH; " + why);
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string array_spec(std::vector<int> tasks) {
  std::sort(tasks.begin(), tasks.end());
  tasks.erase(std::unique(tasks.begin(), tasks.end()), tasks.end());
  std::string spec;
  for (std::size_t i = 0; i < tasks.size();) {
    std::size_t j = i;
    while (j + 1 < tasks.size() && tasks[j + 1] == tasks[j] + 1) ++j;
    if (!spec.empty()) spec += ',';
    spec += std::to_string(tasks[i]);
    if (j > i) spec += "-" + std::to_string(tasks[j]);
    i = j + 1;
  }
  return spec;
}

fs::path task_log(const fs::path& dir, int task) {
  return fs::absolute(dir) / "logs" / ("task-" + std::to_string(task) + ".log");
}

/// Every text a job script carries (paths in comments and #SBATCH lines, quoted arguments): a control
/// character, a newline above all, would end its line and start a command of its own.
void refuse_control_characters(const std::string& text, const std::string& what) {
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 || c == 0x7f)
      throw UsageError(text, what, "holds a control character (a newline or tab, say), which a Slurm job script cannot carry; "
                                   "rename it");
  }
}

void refuse_control_characters(const std::string& name, const fs::path& dir, const fs::path& workdir,
                               const std::vector<std::string>& sbatch_options,
                               const std::vector<std::vector<std::string>>& commands) {
  refuse_control_characters(name, "job name");
  refuse_control_characters(fs::absolute(dir).string(), "job folder");
  refuse_control_characters(workdir.string(), "working folder");
  for (const auto& o : sbatch_options) refuse_control_characters(o, "--slurm-arg");
  for (const auto& command : commands)
    for (const auto& arg : command) refuse_control_characters(arg, "a task's command line");
}

std::string job_script(const ArrayJob& job) {
  refuse_control_characters(job.name, job.dir, job.workdir, job.sbatch_options, job.commands);
  if (job.commands.empty()) throw Error(job.dir.string(), "tasks", "a job array needs at least one task");
  const std::vector<int> tasks = array_tasks(job);
  for (int t : tasks)
    if (t < 0 || t >= static_cast<int>(job.commands.size()))
      throw Error(job.dir.string(), "tasks", "task " + std::to_string(t) + " has no command");
  const fs::path dir = fs::absolute(job.dir);
  std::string s = "#!/bin/bash\n";
  s += "# Written by " + job.name + ": one task per command below; resubmit with: sbatch " + (dir / "job.sh").string() + "\n";
  s += "#SBATCH --array=" + array_spec(tasks) + "\n";
  s += sbatch_lines(job.name, dir / "logs" / "task-%a.log", job.workdir, job.sbatch_options);
  s += "set -eu\ncase \"$SLURM_ARRAY_TASK_ID\" in\n";
  for (std::size_t t = 0; t < job.commands.size(); ++t) {
    s += "  " + std::to_string(t) + ") exec" + quoted_command(job.commands[t]) + " ;;\n";
  }
  s += "  *) echo \"no command for array task $SLURM_ARRAY_TASK_ID\" >&2; exit 2 ;;\nesac\n";
  return s;
}

fs::path write_job_script(const ArrayJob& job) {
  const fs::path dir = fs::absolute(job.dir);
  std::error_code ec;
  fs::create_directories(dir / "logs", ec);
  if (ec) throw Error((dir / "logs").string(), "", "cannot be created: " + ec.message());
  const fs::path script = dir / "job.sh";
  write_file_atomic(script, job_script(job));
  return script;
}

std::string gather_script(const GatherJob& job) {
  refuse_control_characters(job.name, job.dir, job.workdir, job.sbatch_options, {job.command});
  const fs::path dir = fs::absolute(job.dir);
  std::string s = "#!/bin/bash\n";
  s += "# Written by " + job.name + ": merges what the array tasks wrote, once all have succeeded\n";
  s += "#SBATCH --kill-on-invalid-dep=yes\n";  // a failed task cancels it instead of leaving it pending
  s += sbatch_lines(job.name + "-gather", gather_log(dir), job.workdir, job.sbatch_options);
  s += "set -eu\nexec" + quoted_command(job.command) + "\n";
  return s;
}

fs::path gather_log(const fs::path& dir) { return fs::absolute(dir) / "logs" / "gather.log"; }

std::string submit(const fs::path& script, const std::string& after) {
  require_command("sbatch", "submitting to Slurm needs its client commands (Debian package slurm-client)");
  std::vector<std::string> argv{"sbatch", "--parsable"};
  if (!after.empty()) argv.push_back("--dependency=afterok:" + after);
  argv.push_back(script.string());
  const auto r = run_command(argv);
  if (r.status != 0) throw Error(script.string(), "sbatch", "refused the job: " + first_line(trim(r.err + r.out)));
  // --parsable prints "jobid" or "jobid;cluster".
  const std::string id = trim(r.out.substr(0, r.out.find(';')));
  if (id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
    throw Error(script.string(), "sbatch", "printed \"" + trim(r.out) + "\", expected a job id");
  return id;
}

void cancel(const std::string& job_id) { run_command({"scancel", job_id}); }

void wait_for_job(const std::string& job_id, const WaitOptions& options) {
  require_command("squeue", "waiting for a Slurm job needs its client commands (Debian package slurm-client)");
  const auto pause = std::chrono::duration<double>(std::max(0.05, options.poll_seconds));
  int failures = 0;  // consecutive squeue failures: the controller may be restarting
  for (;;) {
    // One line per pending array (or task) and per running task; none once all have finished.
    const auto r = run_command({"squeue", "-h", "-r", "-j", job_id, "-o", "%i"});
    if (r.status != 0) {
      if (r.err.find("Invalid job id") != std::string::npos) return;  // finished and already purged
      if (++failures >= 10) throw Error("", "squeue", "job " + job_id + ": " + first_line(trim(r.err)));
    } else {
      failures = 0;
      const int unfinished = static_cast<int>(std::count(r.out.begin(), r.out.end(), '\n'));
      if (options.on_poll) options.on_poll(unfinished);
      if (unfinished == 0) return;
    }
    std::this_thread::sleep_for(pause);
  }
}

std::vector<TaskState> task_states(const std::string& job_id) {
  std::vector<TaskState> states = states_from_sacct(job_id);
  if (states.empty()) states = states_from_scontrol(job_id);
  std::sort(states.begin(), states.end(), [](const TaskState& a, const TaskState& b) { return a.task < b.task; });
  return states;
}

std::string run_array_job(const ArrayJob& job, const WaitOptions& options,
                          const std::function<void(const std::string&)>& says) {
  require_command("sbatch", "submitting to Slurm needs its client commands (Debian package slurm-client)");
  const fs::path script = write_job_script(job);
  const std::string id = submit(script);
  if (says) {
    const std::size_t n = job.tasks.empty() ? job.commands.size() : job.tasks.size();
    says("submitted Slurm job " + id + " (" + std::to_string(n) + " array tasks, " + script.string() + ")");
  }
  wait_for_job(id, options);
  return id;
}

namespace {

/// Waiting that tells the user, when `progress`, how many of the job's tasks are not finished.
WaitOptions told_waiting(const std::string& name, const std::string& what, double poll_seconds, bool progress) {
  WaitOptions wait;
  wait.poll_seconds = poll_seconds;
  if (progress)
    wait.on_poll = [name, what, last = -1](int unfinished) mutable {
      if (unfinished != last) std::cerr << name << ": " << unfinished << " " << what << " not finished\n";
      last = unfinished;
    };
  return wait;
}

void print_dry_run(const ArrayJob& array, const GatherJob& gather) {
  const std::string array_script = job_script(array), gather_sh = gather_script(gather);  // checked before printing
  const fs::path dir = fs::absolute(array.dir), gdir = fs::absolute(gather.dir);
  std::cout << "# sbatch --parsable " << shell_quote((dir / "job.sh").string()) << "\n"
            << array_script << "\n# sbatch --parsable --dependency=afterok:<array job id> "
            << shell_quote((gdir / "gather.sh").string()) << "\n"
            << gather_sh << "# (dry run: nothing written, nothing submitted)\n";
}

}  // namespace

bool run_array_then_gather(const ArrayJob& array, const GatherJob& gather, const RunMode& mode,
                           const std::function<std::vector<int>()>& failed_tasks) {
  if (mode.dry_run) {
    print_dry_run(array, gather);
    return false;
  }
  require_command("sbatch", "submitting to Slurm needs its client commands (Debian package slurm-client)");
  const std::string array_id = submit(write_job_script(array));
  const fs::path gather_sh = fs::absolute(gather.dir) / "gather.sh";
  write_file_atomic(gather_sh, gather_script(gather));
  std::string gather_id;
  try {
    gather_id = submit(gather_sh, array_id);
  } catch (const Error&) {
    cancel(array_id);  // nothing would merge what it writes
    throw;
  }
  const std::size_t n = array.tasks.empty() ? array.commands.size() : array.tasks.size();
  const std::string said = "submitted Slurm array job " + array_id + " (" + std::to_string(n) + " tasks, logs " +
                           task_log(array.dir, 0).parent_path().string() + "/task-<i>.log) and gather job " +
                           gather_id + " (after them; log " + gather_log(gather.dir).string() + ")";
  if (!mode.wait) {
    std::cout << array.name << ": " << said << "\n";
    return false;
  }
  if (mode.progress) std::cerr << array.name << ": " << said << "\n";
  wait_for_job(array_id, told_waiting(array.name, "array tasks", mode.poll_seconds, mode.progress));
  const std::vector<int> failed = failed_tasks();
  if (!failed.empty()) {
    cancel(gather_id);
    throw Error(fs::absolute(array.dir).string(), "--slurm",
                "Slurm job " + array_id + ": " + std::to_string(failed.size()) + " of " + std::to_string(n) +
                    " tasks did not deliver: " + describe_failures(array.dir, failed, task_states(array_id)) +
                    "; what did arrive is kept, submit again to rerun only the rest");
  }
  wait_for_job(gather_id, told_waiting(array.name, "gather job", mode.poll_seconds, mode.progress));
  return true;
}

std::vector<std::string> without_options(const std::vector<std::string>& args, const std::vector<std::string>& flags,
                                         const std::vector<std::string>& valued) {
  const auto is_in = [](const std::vector<std::string>& v, const std::string& s) {
    return std::find(v.begin(), v.end(), s) != v.end();
  };
  std::vector<std::string> out;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (is_in(flags, a)) continue;
    if (is_in(valued, a)) {
      ++i;  // and its value
      continue;
    }
    const auto eq = a.find('=');
    if (a.rfind("--", 0) == 0 && eq != std::string::npos && is_in(valued, a.substr(0, eq))) continue;
    if (a.size() > 2 && a[0] == '-' && a[1] != '-' && is_in(valued, a.substr(0, 2))) continue;  // "-ofile"
    out.push_back(a);
  }
  return out;
}

fs::path current_executable() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw Error("/proc/self/exe", "", "cannot tell this program's path: " + ec.message());
  return p;
}

std::string describe_failures(const fs::path& dir, const std::vector<int>& failed, const std::vector<TaskState>& states) {
  std::string s;
  for (int t : failed) {
    std::string how = "no result";
    for (const auto& st : states)
      if (st.task == t) how = st.state + ", exit " + st.exit_code;
    if (!s.empty()) s += "; ";
    s += "task " + std::to_string(t) + " (" + how + ", log " + task_log(dir, t).string() + ")";
  }
  return s;
}

}  // namespace smseg::slurm
