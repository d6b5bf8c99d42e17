#include "smseg/common/output.hpp"

#include <signal.h>
#include <stdio.h>  // renameat2, RENAME_EXCHANGE (glibc >= 2.28)
#include <fcntl.h>  // AT_FDCWD
#include <sys/file.h>  // flock
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cerrno>
#include <cstring>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include "smseg/common/cli.hpp"  // UsageError
#include "smseg/common/error.hpp"

namespace smseg {

namespace {

bool process_alive(long pid) {
  if (pid <= 0) return true;  // not a process we could judge: keep its files
  if (pid == ::getpid()) return true;
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

/// What a temporary's name says about it: the kind marker (".tmp." or ".old.") and the writer's pid.
struct TemporaryName {
  std::string marker;
  std::string base;  // the name before the marker: what the temporary stands for
  long pid = 0;
};

/// Parses `<base><marker><host>.<pid>[.<anything>]` for this host; nullopt for any other name.
std::optional<TemporaryName> parse_temporary(const std::string& name) {
  for (const char* marker : {".tmp.", ".old."}) {
    const std::string key = marker + host_name() + ".";
    const std::size_t at = name.find(key);
    if (at == std::string::npos || at == 0) continue;
    std::size_t p = at + key.size(), digits = 0;
    long pid = 0;
    while (p < name.size() && name[p] >= '0' && name[p] <= '9' && digits < 10) {
      pid = pid * 10 + (name[p] - '0');
      ++p;
      ++digits;
    }
    if (digits == 0 || (p < name.size() && name[p] != '.')) continue;
    return TemporaryName{marker, name.substr(0, at), pid};
  }
  return std::nullopt;
}

/// Copies `from` to `to` as hard links (a tree of folders and links; a copy where links are refused).
void link_tree(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  const fs::file_status st = fs::symlink_status(from, ec);
  if (fs::is_symlink(st)) {
    fs::copy_symlink(from, to);
  } else if (fs::is_directory(st)) {
    fs::create_directory(to);
    for (const auto& e : fs::directory_iterator(from)) link_tree(e.path(), to / e.path().filename());
  } else {
    fs::create_hard_link(from, to, ec);
    if (ec) fs::copy_file(from, to);
  }
}

/// The target's path as the swap sees it: absolute, without a trailing separator.
fs::path normal_target(const fs::path& target) {
  fs::path t = fs::absolute(target).lexically_normal();
  if (t.filename().empty()) t = t.parent_path();
  if (t == t.root_path()) throw Error(target.string(), "", "cannot be replaced (a file system root)");
  return t;
}

}  // namespace

const std::string& host_name() {
  static const std::string name = [] {
    char buf[256] = {};
    if (::gethostname(buf, sizeof buf - 1) != 0 || buf[0] == 0) return std::string("localhost");
    std::string s(buf);
    for (char& c : s)
      if (c == '/' || c == '.') c = '-';  // one name component; dots would blur the pid that follows
    return s;
  }();
  return name;
}

fs::path temporary_beside(const fs::path& path, std::string_view ext) {
  static std::atomic<unsigned> counter{0};
  fs::path tmp = path;
  tmp += ".tmp." + host_name() + "." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  tmp += std::string(ext);
  return tmp;
}

int remove_stale_temporaries(const fs::path& folder) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return 0;
  int cleaned = 0;
  std::vector<fs::path> entries;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) entries.push_back(it->path());
  for (const fs::path& p : entries) {
    const auto t = parse_temporary(p.filename().string());
    if (!t || process_alive(t->pid)) continue;
    const fs::path original = folder / t->base;
    if (t->marker == ".old." && !fs::exists(fs::symlink_status(original, ec))) {
      fs::rename(p, original, ec);  // a swap killed half-way: the previous content goes back
    } else {
      fs::remove_all(p, ec);
      if (ec) {  // a child of the dead writer may still be ending its last write: once more, a moment later
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        fs::remove_all(p, ec);
      }
    }
    if (!ec) ++cleaned;
  }
  return cleaned;
}

FolderReplacement::FolderReplacement(const fs::path& target) : target_(normal_target(target)) {
  std::error_code ec;
  fs::create_directories(target_.parent_path(), ec);
  if (ec) throw Error(target_.string(), "", "cannot create its parent folder: " + ec.message());
  if (fs::exists(target_, ec) && !fs::is_directory(target_, ec))
    throw Error(target_.string(), "", "is a file, expected an output folder");
  remove_stale_temporaries(target_.parent_path());
  staging_ = target_;
  staging_ += ".tmp." + host_name() + "." + std::to_string(::getpid());
  fs::remove_all(staging_, ec);  // this process's own, from an earlier replacement of the same folder
  fs::create_directory(staging_, ec);
  if (ec) throw Error(staging_.string(), "", "cannot be created: " + ec.message());
}

FolderReplacement::~FolderReplacement() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

void FolderReplacement::commit() {
  std::error_code ec;
  if (!fs::exists(target_, ec)) {
    fs::rename(staging_, target_, ec);
    if (ec) throw Error(target_.string(), "", "cannot be created: " + ec.message());
    committed_ = true;
    return;
  }
  // Keep what the new content does not replace (the user's files, other modes' outputs).
  for (const auto& e : fs::directory_iterator(target_)) {
    const fs::path to = staging_ / e.path().filename();
    if (!fs::exists(fs::symlink_status(to, ec))) link_tree(e.path(), to);
  }
  if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, target_.c_str(), RENAME_EXCHANGE) == 0) {
    committed_ = true;
    fs::remove_all(staging_, ec);  // now the old content
    return;
  }
  if (errno != EINVAL && errno != ENOSYS)
    throw Error(target_.string(), "", std::string("cannot be replaced: ") + std::strerror(errno));
  // No atomic exchange on this file system: move the old content aside, then the new one in.
  fs::path old = target_;
  old += ".old." + host_name() + "." + std::to_string(::getpid());
  fs::remove_all(old, ec);
  fs::rename(target_, old, ec);
  if (ec) throw Error(target_.string(), "", "cannot be moved aside: " + ec.message());
  fs::rename(staging_, target_, ec);
  if (ec) {
    const std::string why = ec.message();
    fs::rename(old, target_, ec);
    throw Error(target_.string(), "", "cannot be replaced: " + why);
  }
  committed_ = true;
  fs::remove_all(old, ec);
}

namespace {

/// The lock file of an output: hidden, beside it, so that a folder swapped in whole keeps its lock.
fs::path lock_file_of(const fs::path& output) {
  const fs::path target = normal_target(output);
  return target.parent_path() / ("." + target.filename().string() + ".lock");
}

/// What the lock file says of its holder ("pid 123 on host"), for the refusal.
std::string holder_of(int fd) {
  char text[128] = {};
  const ssize_t n = ::pread(fd, text, sizeof text - 1, 0);
  std::string s = n > 0 ? std::string(text, static_cast<std::size_t>(n)) : std::string();
  while (!s.empty() && (s.back() == '\n' || s.back() == '\0')) s.pop_back();
  return s.empty() ? "another process" : s;
}

/// `p` with `.`, `..` and symbolic links resolved as far as it exists.
fs::path resolved(const fs::path& p) {
  std::error_code ec;
  fs::path r = fs::weakly_canonical(fs::absolute(p, ec), ec);
  return ec ? fs::absolute(p).lexically_normal() : r;
}

bool lies_in(const fs::path& inner, const fs::path& folder) {
  auto i = inner.begin();
  for (auto f = folder.begin(); f != folder.end(); ++f, ++i) {
    if (f->empty()) continue;  // a trailing separator
    if (i == inner.end() || *i != *f) return false;
  }
  return true;
}

}  // namespace

OutputLock::OutputLock(const fs::path& output, const std::vector<fs::path>& inputs, const std::string& option) {
  if (output.empty()) throw UsageError("", option, "is empty: name the output");
  check_output_apart(output, inputs, option);
  path_ = lock_file_of(output);
  std::error_code ec;
  fs::create_directories(path_.parent_path(), ec);
  if (ec) throw Error(output.string(), "", "cannot be written: its folder cannot be created (" + ec.message() + ")");
  // The holder removes the lock file when it is done; a process that opened the file before that must
  // not hold a lock on a removed file while a third creates a new one: it retries on the name's file.
  for (;;) {
    fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw Error(output.string(), "", std::string("cannot be written there (") + std::strerror(errno) + ")");
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      const std::string holder = holder_of(fd_);
      ::close(fd_);
      fd_ = -1;
      throw Error(output.string(), "", "is being written by " + holder + "; wait for it to finish or write to another " + option);
    }
    struct stat held {}, named {};
    if (::fstat(fd_, &held) == 0 && ::stat(path_.c_str(), &named) == 0 && held.st_ino == named.st_ino &&
        held.st_dev == named.st_dev)
      break;
    ::close(fd_);  // removed by its last holder meanwhile: lock the file that has the name now
  }
  const std::string me = "pid " + std::to_string(::getpid()) + " on " + host_name() + "\n";
  if (::ftruncate(fd_, 0) == 0) (void)!::pwrite(fd_, me.data(), me.size(), 0);
}

OutputLock::~OutputLock() {
  if (fd_ < 0) return;
  ::unlink(path_.c_str());  // while still locked: no one can hold a lock on the name's file meanwhile
  ::close(fd_);
}

void check_output_apart(const fs::path& output, const std::vector<fs::path>& inputs, const std::string& option) {
  const fs::path out = resolved(output);
  for (const fs::path& input : inputs) {
    std::error_code ec;
    if (input.empty() || !fs::exists(input, ec)) continue;
    const fs::path in = resolved(input);
    if (in == out) throw UsageError("", option, output.string() + " is an input of this run (" + input.string() + "); write to another path");
    if (lies_in(in, out))
      throw UsageError("", option, output.string() + " holds an input of this run (" + input.string() + "); write to another path");
  }
}

std::vector<fs::path> folders_by_name(const std::vector<std::string>& folders, const fs::path& root,
                                      const std::string& option) {
  std::vector<fs::path> outs;
  std::set<std::string> names;
  for (const auto& w : folders) {
    const std::string name = fs::absolute(w).lexically_normal().filename().string();
    if (name.empty() || !names.insert(name).second)
      throw UsageError("", option, w + ": another work folder has the name \"" + name + "\" (each goes to OUT/<its name>)");
    outs.push_back(root / name);
  }
  return outs;
}

}  // namespace smseg
