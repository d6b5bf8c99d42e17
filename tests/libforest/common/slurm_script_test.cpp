// The Slurm helpers that need no cluster: array specs, quoting, the job script (run here by bash as
// Slurm would run it), and a tool's own options taken out of its command line.
#include <gtest/gtest.h>

#include <cstdio>
#include <sys/wait.h>

#include "temp_dir.hpp"
#include "smseg/common/error.hpp"
#include "smseg/common/io.hpp"
#include "smseg/common/slurm.hpp"

namespace slurm = smseg::slurm;
namespace fs = std::filesystem;

namespace {

/// Runs a shell command; its stdout, and the exit status in `status`.
std::string shell(const std::string& command, int& status) {
  std::string out;
  FILE* p = ::popen(command.c_str(), "r");
  char buf[512];
  while (p && std::fgets(buf, sizeof buf, p)) out += buf;
  const int st = p ? ::pclose(p) : -1;
  status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return out;
}

}  // namespace

TEST(Slurm, ArraySpecsCompressRuns) {
  EXPECT_EQ(slurm::array_spec({0, 1, 2, 3}), "0-3");
  EXPECT_EQ(slurm::array_spec({5, 0, 2, 3, 9, 8}), "0,2-3,5,8-9");
  EXPECT_EQ(slurm::array_spec({4}), "4");
}

TEST(Slurm, QuotedWordsReachTheCommandUnchanged) {
  for (const std::string s : {"plain", "two words", "it's", "$HOME `id` \"x\" \\ ; *", ""}) {
    int status = 0;
    EXPECT_EQ(shell("printf '%s' " + slurm::shell_quote(s), status), s);
    EXPECT_EQ(status, 0);
  }
}

TEST(Slurm, EachArrayTaskRunsItsOwnCommand) {
  const fs::path dir = smseg::test::temp_dir("slurm_script");
  slurm::ArrayJob job;
  job.name = "test";
  job.dir = dir / "job";
  job.workdir = dir;
  job.commands = {{"printf", "%s|", "zero", "it's 0"}, {"printf", "%s|", "one"}, {"sh", "-c", "exit 7"}};
  job.tasks = {1, 2};
  job.sbatch_options = {"--partition=short"};
  const fs::path script = slurm::write_job_script(job);
  const std::string text = smseg::read_file(script);
  EXPECT_NE(text.find("#SBATCH --array=1-2\n"), std::string::npos) << text;
  EXPECT_NE(text.find("#SBATCH --partition=short\n"), std::string::npos) << text;
  EXPECT_NE(text.find("#SBATCH --output=" + (dir / "job/logs/task-%a.log").string() + "\n"), std::string::npos) << text;
  EXPECT_NE(text.find("#SBATCH --chdir=" + dir.string() + "\n"), std::string::npos) << text;
  int status = 0;
  EXPECT_EQ(shell("SLURM_ARRAY_TASK_ID=0 bash " + script.string(), status), "zero|it's 0|");
  EXPECT_EQ(shell("SLURM_ARRAY_TASK_ID=1 bash " + script.string(), status), "one|");
  shell("SLURM_ARRAY_TASK_ID=2 bash " + script.string(), status);
  EXPECT_EQ(status, 7);
  shell("SLURM_ARRAY_TASK_ID=3 bash " + script.string() + " 2>/dev/null", status);
  EXPECT_EQ(status, 2);
  fs::remove_all(dir);
}

// The gather job runs once, after the array, and is cancelled (not left pending) when a task fails.
TEST(Slurm, TheGatherScriptRunsItsCommandAfterTheArray) {
  const fs::path dir = smseg::test::temp_dir("slurm_gather");
  const slurm::GatherJob job{"test", dir / "job", dir, {"printf", "%s", "it's gathered"}, {"--account=a"}};
  const std::string text = slurm::gather_script(job);
  EXPECT_NE(text.find("#SBATCH --job-name=test-gather\n"), std::string::npos) << text;
  EXPECT_NE(text.find("#SBATCH --kill-on-invalid-dep=yes\n"), std::string::npos) << text;
  EXPECT_NE(text.find("#SBATCH --account=a\n"), std::string::npos) << text;
  EXPECT_NE(text.find("#SBATCH --output=" + slurm::gather_log(dir / "job").string() + "\n"), std::string::npos) << text;
  smseg::write_file_atomic(dir / "gather.sh", text);
  int status = 0;
  EXPECT_EQ(shell("bash " + (dir / "gather.sh").string(), status), "it's gathered");
  EXPECT_EQ(status, 0);
  fs::remove_all(dir);
}

TEST(Slurm, BadJobsAreRefusedByName) {
  slurm::ArrayJob job;
  job.name = "test";
  job.dir = "/tmp/unused";
  EXPECT_THROW(slurm::job_script(job), smseg::Error);  // no task
  job.commands = {{"true"}};
  job.tasks = {1};
  EXPECT_THROW(slurm::job_script(job), smseg::Error);  // no command for task 1
  job.tasks = {};
  job.sbatch_options = {"--time=5\n#SBATCH --x"};
  try {
    slurm::job_script(job);
    ADD_FAILURE() << "an option with a newline was taken";
  } catch (const smseg::Error& e) {
    EXPECT_EQ(e.field(), "--slurm-arg");
  }
}

TEST(Slurm, ToolOptionsComeOutOfTheCommandLine) {
  const std::vector<std::string> args = {"work", "--slurm", "--tasks", "3", "-K", "40", "--poll=0.5",
                                         "-ofile.json", "--slurm-arg", "--partition=x", "-q", "--seed", "2"};
  EXPECT_EQ(slurm::without_options(args, {"--slurm", "-q"}, {"--tasks", "--poll", "-o", "--slurm-arg"}),
            (std::vector<std::string>{"work", "-K", "40", "--seed", "2"}));
}

TEST(Slurm, AMissingCommandIsNamed) {
  try {
    slurm::require_command("smseg-no-such-command", "needed here");
    ADD_FAILURE() << "found a command that does not exist";
  } catch (const smseg::Error& e) {
    EXPECT_EQ(e.field(), "smseg-no-such-command");
    EXPECT_NE(e.reason().find("not found on PATH"), std::string::npos);
  }
  EXPECT_NO_THROW(slurm::require_command("sh", "needed here"));
}
