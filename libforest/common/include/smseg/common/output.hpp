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
#include <string>
#include <string_view>

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

}  // namespace smseg
