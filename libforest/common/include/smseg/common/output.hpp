#pragma once
// Output that survives kill -9 (docs/reliability.md, "Interrupted runs (kill -9)").
//
// Every temporary a tool writes is named after the host and the process writing it
// (`<name>.tmp.<host>.<pid>...`), so that a later run can tell a dead writer's leftovers from the
// temporaries of a writer still running, on this host or on another one sharing the file system (Slurm
// tasks writing parts into one folder). A folder of several files (eval-forest's results and pictures,
// export-notebooks' notebooks) is built whole beside its final place and swapped in at the end, so that
// the folder holds either its complete previous content or the complete new one, never a mix.

#include <filesystem>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

namespace smseg {

namespace fs = std::filesystem;

/// This machine's host name, as it appears in temporary names ("localhost" when it has none).
const std::string& host_name();

/// A fresh temporary name beside `path` for this process: path + ".tmp.<host>.<pid>.<n>" + ext (`ext`
/// for writers that choose the format by the extension, such as PCL's).
fs::path temporary_beside(const fs::path& path, std::string_view ext = {});

/// Cleans `folder` (not below it) of what killed runs of this host left: removes every temporary file
/// or folder named `*.tmp.<host>.<pid>*` whose process is gone, and puts a folder that a killed swap had
/// moved aside (`X.old.<host>.<pid>`) back in place when X is missing (else removes it). Leaves alone
/// temporaries of live processes and of other hosts. A missing folder is fine. Returns how many
/// entries it removed or restored.
int remove_stale_temporaries(const fs::path& folder);

/// The new content of a folder, built in a staging folder beside it (`<target>.tmp.<host>.<pid>`) and
/// swapped in whole by commit(). Until commit() the target is untouched; a destroyed, uncommitted
/// replacement removes its staging folder (an error), and a killed one leaves it for the next run's
/// remove_stale_temporaries. Entries of the old target that the new content does not have (files the
/// tool does not write, such as eval-forest's sweep.jsonl or the user's own) are carried over by hard
/// links.
class FolderReplacement {
 public:
  /// Cleans the target's parent of stale temporaries and creates an empty staging folder.
  explicit FolderReplacement(const fs::path& target);
  ~FolderReplacement();
  FolderReplacement(const FolderReplacement&) = delete;
  FolderReplacement& operator=(const FolderReplacement&) = delete;

  /// Where to write the new content.
  const fs::path& staging() const noexcept { return staging_; }
  const fs::path& target() const noexcept { return target_; }

  /// Swaps the staging folder in: one atomic exchange of the two names where the file system has it
  /// (Linux renameat2 RENAME_EXCHANGE), else two renames (a kill between them leaves the target missing
  /// and the old content at `<target>.old.<host>.<pid>`, which the next run puts back); then removes the
  /// old content.
  void commit();

 private:
  fs::path target_, staging_;
  bool committed_ = false;
};

/// One writer per output. Holds an exclusive lock (flock) on `.<name>.lock` beside `output` for its
/// life: a second process claiming the same output refuses at once (Error naming the output and the
/// process that holds it) instead of writing the same files. The lock file is removed when the object
/// goes; a killed holder leaves it unlocked (the kernel releases the lock however a process exits), and
/// the next writer takes it. Before locking, refuses (UsageError) an empty
/// output path and an output that is one of the run's `inputs` or holds one (check_output_apart).
class OutputLock {
 public:
  /// `option`: how the user named the output ("-o"), for the messages.
  explicit OutputLock(const fs::path& output, const std::vector<fs::path>& inputs = {}, const std::string& option = "-o");
  ~OutputLock();
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

 private:
  fs::path path_;
  int fd_ = -1;
};

/// `items` (a tool's repeated positional inputs) and `more` as paths, for OutputLock's inputs.
template <class Strings>
std::vector<fs::path> paths_of(const Strings& items, std::initializer_list<fs::path> more = {}) {
  std::vector<fs::path> paths(items.begin(), items.end());
  paths.insert(paths.end(), more.begin(), more.end());
  return paths;
}

/// Refuses (a UsageError naming `option`) an output that is one of `inputs` or holds one (a
/// folder the input lies in): writing it would destroy what the run reads. Paths are compared after
/// resolving `.`, `..` and symbolic links; inputs that do not exist are skipped.
void check_output_apart(const fs::path& output, const std::vector<fs::path>& inputs, const std::string& option = "-o");

/// ROOT/<name of each folder> (add-context's and add-textons' outputs, one per input work folder): a
/// UsageError naming `option` when two folders have one name (they would write one output folder).
std::vector<fs::path> folders_by_name(const std::vector<std::string>& folders, const fs::path& root,
                                      const std::string& option = "WORK");

}  // namespace smseg
