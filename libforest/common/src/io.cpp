#include "smseg/common/io.hpp"
#include "smseg/common/output.hpp"

#include <fcntl.h>
#include <malloc.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <thread>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <new>
#include <limits>
#include <optional>
#include <sstream>

namespace smseg {

namespace {

// For the kill -9 tests only (tests/faults): SMSEG_TEST_WRITE_PAUSE_MS=N pauses every write half-way
// for N ms, so that a kill polled from outside lands in the middle of writing a file (without it, a
// small file is written in microseconds and no kill catches it half-written). Unset: no pause.
void pause_for_kill_tests() {
  static const int ms = [] {
    const char* v = std::getenv("SMSEG_TEST_WRITE_PAUSE_MS");
    return v ? std::max(0, std::atoi(v)) : 0;
  }();
  if (ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(ms));
}

}  // namespace

void write_file_atomic(const fs::path& path, std::string_view bytes) {
  std::error_code ec;
  if (path.has_parent_path()) {
    fs::create_directories(path.parent_path(), ec);
    if (ec) throw Error(path.string(), "", "cannot create its folder: " + ec.message());
  }
  const fs::path tmp = temporary_beside(path);  // named so that a later run can clean up after a kill
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw Error(path.string(), "", std::string("cannot be written: ") + std::strerror(errno));
  const std::size_t half = bytes.size() / 2;
  bool ok = std::fwrite(bytes.data(), 1, half, f) == half && std::fflush(f) == 0;
  pause_for_kill_tests();
  ok = ok && std::fwrite(bytes.data() + half, 1, bytes.size() - half, f) == bytes.size() - half &&
       std::fflush(f) == 0;
  const bool closed = std::fclose(f) == 0;
  if (!ok || !closed) {
    fs::remove(tmp, ec);
    throw Error(path.string(), "", "write failed (disk full?)");
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    const std::string why = fs::is_directory(path) ? "is a folder, expected a file" : "cannot be replaced: " + ec.message();
    fs::remove(tmp, ec);  // (overwrites ec: the reason is taken first)
    throw Error(path.string(), "", why);
  }
}

std::string json_text(const Json& j, const fs::path& path, int indent) {
  try {
    return j.dump(indent);
  } catch (const Json::type_error&) {  // 316: a string that is not UTF-8, most often a file name
    throw Error(path.string(), "", "cannot be written: it would record text that is not UTF-8 (a file or folder name? "
                                   "rename it to UTF-8)");
  }
}

void write_json_atomic(const fs::path& path, const Json& j, int indent) {
  write_file_atomic(path, json_text(j, path, indent) + "\n");
}

namespace {

/// What a file of this mode is when it is not a regular file, in a few words; empty for a regular file.
std::string why_not_regular(mode_t mode) {
  if (S_ISREG(mode)) return {};
  if (S_ISDIR(mode)) return "is a folder, expected a file";
  // A FIFO or socket may never end (or never start: opening a FIFO waits for a writer), and a device
  // is not a file someone wrote: none is taken as an input.
  if (S_ISFIFO(mode)) return "is a FIFO (named pipe), expected a regular file";
  if (S_ISSOCK(mode)) return "is a socket, expected a regular file";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "is a device, expected a regular file";
  return "is not a regular file";
}

std::string mib_text(std::uintmax_t bytes) {
  return bytes >= kMiB ? std::to_string(bytes / kMiB) + " MiB" : std::to_string(bytes) + " bytes";
}

std::string describe_limit(std::uintmax_t max_bytes) {
  if (max_bytes % kMiB == 0) return std::to_string(max_bytes / kMiB) + " MiB";
  return std::to_string(max_bytes) + " bytes";
}

[[noreturn]] void fail_too_large(const fs::path& path, std::uintmax_t max_bytes) {
  throw Error(path.string(), "", "is larger than the " + describe_limit(max_bytes) + " this reader accepts");
}

/// The address space this process may still take (its RLIMIT_AS, `ulimit -v`, less what it uses now),
/// or nullopt when it has no such limit.
std::optional<std::uintmax_t> address_space_left() {
  rlimit limit{};
  if (::getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return std::nullopt;
  std::uintmax_t pages = 0;
  if (FILE* statm = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(statm, "%ju", &pages) != 1) pages = 0;
    std::fclose(statm);
  }
  // What malloc holds free (freed by an earlier reading, kept mapped) is mapped but can be used again.
  const std::uintmax_t reusable = ::mallinfo2().fordblks;
  const std::uintmax_t mapped = pages * static_cast<std::uintmax_t>(::sysconf(_SC_PAGESIZE));
  const std::uintmax_t used = mapped > reusable ? mapped - reusable : 0;
  return limit.rlim_cur > used ? limit.rlim_cur - used : 0;
}

/// Refuses, naming the file, to start a read that needs more memory than the process may take: the
/// answer comes before the allocation that would fail, not as a bare "out of memory" half-way.
void require_memory(const fs::path& path, std::uintmax_t file_bytes) {
  const std::optional<std::uintmax_t> left = address_space_left();
  if (!left || file_bytes <= *left) return;
  throw Error(path.string(), "",
              "is " + mib_text(file_bytes) + "; reading it needs about " + mib_text(file_bytes) +
                  " of memory, and this process may take only " + mib_text(*left) +
                  " more (its address-space limit, ulimit -v)");
}

[[noreturn]] void fail_out_of_memory(const fs::path& path, std::uintmax_t file_bytes, const char* doing) {
  throw Error(path.string(), "", "out of memory " + std::string(doing) + " (the file is " + mib_text(file_bytes) + ")");
}

/// Closes a file descriptor when the reading ends, thrown out of or not.
struct FdCloser {
  int fd;
  ~FdCloser() { ::close(fd); }
};

/// Appends what fd holds to bytes until the end of the file or until bytes passes max_bytes.
void read_to_end(int fd, const fs::path& path, std::string& bytes, std::uintmax_t max_bytes) {
  std::array<char, 16384> chunk;
  while (bytes.size() <= max_bytes) {
    const ssize_t n = ::read(fd, chunk.data(), chunk.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw Error(path.string(), "", std::string("read failed: ") + std::strerror(errno));
    if (n == 0) return;
    bytes.append(chunk.data(), static_cast<std::size_t>(n));
  }
}

/// "line L, column C" of the byte before offset in text (nlohmann counts bytes from 1).
std::string line_and_column(std::string_view text, std::size_t byte) {
  std::size_t line = 1, col = 1;
  const std::size_t end = std::min<std::size_t>(byte > 0 ? byte - 1 : 0, text.size());
  for (std::size_t i = 0; i < end; ++i) {
    if (text[i] == '\n') {
      ++line;
      col = 1;
    } else {
      ++col;
    }
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(col);
}

/// The deepest nesting of arrays and objects a JSON file may have. Our formats nest under ten levels;
/// nlohmann copies and prints a document by recursion, one call per level, so a file nested
/// 100,000 deep would overflow the stack of whatever copies it after reading.
constexpr std::size_t kMaxJsonDepth = 256;

/// What parse_json must know of a JSON text before parsing it.
struct JsonShape {
  std::size_t too_deep_at = std::string_view::npos;  ///< the bracket that opens level kMaxJsonDepth + 1
  std::size_t longest_token = 0;  ///< the longest string, number or literal, in bytes
  std::size_t longest_gap = 0;    ///< the longest stretch between two of them (spaces, brackets, commas)
};

bool is_value_byte(char c) {
  return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '-' || c == '+' || c == '.';
}

/// The end of the string whose opening quote is at text[open]: its closing quote (the first one not
/// escaped), or the end of the text.
std::size_t string_end(std::string_view text, std::size_t open) {
  for (std::size_t end = open + 1; (end = text.find('"', end)) != std::string_view::npos; ++end) {
    std::size_t backslashes = 0;
    while (text[end - 1 - backslashes] == '\\') ++backslashes;
    if (backslashes % 2 == 0) return end;
  }
  return text.size();
}

/// One pass over the text: the first bracket nested too deep, and what nlohmann's reader holds at once.
/// It keeps each token whole in a buffer and also records every byte read since the last token began
/// (for its error messages), so a 2 GB string or 2 GB of spaces needs several GB. Brackets inside
/// strings do not count; the text need not be valid JSON (the parser says what else is wrong).
JsonShape shape_of(std::string_view text) {
  JsonShape shape;
  std::size_t depth = 0, gap_start = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"' || is_value_byte(c)) {
      std::size_t end = i + 1;
      if (c == '"') end = string_end(text, i) + 1;
      else
        while (end < text.size() && is_value_byte(text[end])) ++end;
      shape.longest_token = std::max(shape.longest_token, end - i);
      i = end - 1;
      gap_start = end;
      continue;
    }
    shape.longest_gap = std::max(shape.longest_gap, i + 1 - gap_start);
    if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth) {
        shape.too_deep_at = i;
        return shape;
      }
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return shape;
}

/// The memory nlohmann's reader may take beside the document for the longest token and stretch between
/// tokens: a string in its buffer and in the record, spaces in the record, each grown by doubling
/// (up to twice its length, and the old buffer beside the new one while it grows).
std::uintmax_t reader_buffers(const JsonShape& shape) {
  return std::max(4 * std::uintmax_t{shape.longest_token}, 3 * std::uintmax_t{shape.longest_gap});
}

/// nlohmann's own DOM builder (what Json::parse uses, so the document is the same), which also counts
/// what the document takes in memory as it is built and stops when the count passes a budget: a
/// document the process has no room for is refused before the allocation that would fail. The count
/// follows libstdc++'s layout and malloc's chunks, arrays at the capacity their growth gives them (a
/// forest file parses into about 11 times its size). It keeps room for nlohmann's destructor, which
/// allocates a stack as long as the largest array or object: without that room, a document cut short
/// by a failed allocation ends the process while it is freed.
class BudgetedDomParser : public nlohmann::detail::json_sax_dom_parser<Json> {
 public:
  using Base = nlohmann::detail::json_sax_dom_parser<Json>;
  struct OverBudget {};

  BudgetedDomParser(Json& root, std::uintmax_t budget) : Base(root), budget_(budget) {}

  bool null() { return add_value(0) && Base::null(); }
  bool boolean(bool v) { return add_value(0) && Base::boolean(v); }
  bool number_integer(number_integer_t v) { return add_value(0) && Base::number_integer(v); }
  bool number_unsigned(number_unsigned_t v) { return add_value(0) && Base::number_unsigned(v); }
  bool number_float(number_float_t v, const string_t& s) { return add_value(0) && Base::number_float(v, s); }
  bool string(string_t& v) { return add_value(kString + heap_chars(v.size())) && Base::string(v); }
  bool binary(binary_t& v) { return add_value(kString + v.size()) && Base::binary(v); }
  bool key(string_t& k) { return add_member(k.size()) && Base::key(k); }
  bool start_object(std::size_t n) { return open(false) && Base::start_object(n); }
  bool start_array(std::size_t n) { return open(true) && Base::start_array(n); }
  bool end_object() { return close() && Base::end_object(); }
  bool end_array() { return close() && Base::end_array(); }

 private:
  // Bytes of an array element, of an object member (a map node with its key and value, in malloc's
  // 96-byte chunk), of an object's or array's own heap object and of a string's (the value holds a
  // pointer to them).
  static constexpr std::uintmax_t kSlot = 16, kMember = 96, kContainer = 64, kString = 48;
  static std::uintmax_t heap_chars(std::size_t n) { return n > 15 ? n + 1 : 0; }

  struct Open {
    bool array;
    std::uintmax_t count = 0, capacity = 0;
  };

  bool open(bool array) {
    add_value(kContainer);
    open_.push_back({array});
    return true;
  }
  bool close() {
    open_.pop_back();
    return true;
  }
  bool add_member(std::size_t key_bytes) {
    Open& object = open_.back();
    largest_ = std::max(largest_, ++object.count);
    return charge(kMember + heap_chars(key_bytes), 0);
  }
  /// A value's own bytes, and its slot when an array holds it: the vector doubles its capacity when
  /// full, the old and the new buffer side by side while the elements move.
  bool add_value(std::uintmax_t bytes) {
    if (open_.empty() || !open_.back().array) return charge(bytes, 0);
    Open& array = open_.back();
    largest_ = std::max(largest_, ++array.count);
    if (array.count <= array.capacity) return charge(bytes, 0);
    const std::uintmax_t grown = array.capacity == 0 ? 1 : 2 * array.capacity;
    const std::uintmax_t old_buffer = kSlot * array.capacity;
    array.capacity = grown;
    return charge(bytes + kSlot * grown - old_buffer, old_buffer);
  }
  bool charge(std::uintmax_t bytes, std::uintmax_t for_a_moment) {
    used_ += bytes;
    // The destructor's stack takes two slots per element of the largest container (it grows too).
    if (used_ + for_a_moment + 2 * kSlot * largest_ > budget_) throw OverBudget{};
    return true;
  }

  std::uintmax_t budget_;
  std::uintmax_t used_ = 0;
  std::uintmax_t largest_ = 0;  ///< elements of the largest array or object so far
  std::vector<Open> open_;
};

}  // namespace

std::string why_not_a_file(const fs::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return "does not exist";
  return why_not_regular(st.st_mode);
}

std::string read_file(const fs::path& path, std::uintmax_t max_bytes) {
  // Opened without waiting (a FIFO with no writer would hold the reader forever), and what was opened
  // is checked, not the name: a file swapped for a FIFO after a look at it is refused as well.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    if (const std::string why = why_not_a_file(path); !why.empty()) throw Error(path.string(), "", why);  // a socket
    throw Error(path.string(), "", std::string("cannot be read: ") + std::strerror(err));
  }
  const FdCloser closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw Error(path.string(), "", std::string("cannot be read: ") + std::strerror(errno));
  if (const std::string why = why_not_regular(st.st_mode); !why.empty()) throw Error(path.string(), "", why);
  // Too large a file is refused before a byte is read (a sparse 4 GiB file at once), and so is one
  // that the process has no room left for.
  const auto size = static_cast<std::uintmax_t>(st.st_size);
  if (size > max_bytes) fail_too_large(path, max_bytes);
  require_memory(path, size);
  std::string bytes;
  try {
    bytes.reserve(static_cast<std::size_t>(size));
    // A file may hold more than its size said (one still growing, or in /proc): read on to the limit.
    read_to_end(fd, path, bytes, max_bytes);
  } catch (const std::bad_alloc&) {
    fail_out_of_memory(path, std::max<std::uintmax_t>(size, bytes.size()), "reading it");
  }
  if (bytes.size() > max_bytes) fail_too_large(path, max_bytes);
  return bytes;
}

Json parse_json(std::string_view text, const fs::path& file) {
  const JsonShape shape = shape_of(text);
  if (shape.too_deep_at != std::string_view::npos)
    throw Error(file.string(), "",
                "nested deeper than " + std::to_string(kMaxJsonDepth) + " levels of arrays and objects at " +
                    line_and_column(text, shape.too_deep_at + 1) + " (no file of this toolkit nests so deep)");
  const std::optional<std::uintmax_t> left = address_space_left();
  const std::uintmax_t reader_memory = reader_buffers(shape);
  const auto no_room = [&] {
    return Error(file.string(), "",
                 "is " + mib_text(text.size()) + " of JSON; parsing it would take more than the " + mib_text(*left) +
                     " of memory this process may still take (its address-space limit, ulimit -v)");
  };
  if (left && reader_memory > *left) throw no_room();
  try {
    Json doc;  // in here, so that a document cut short is freed before the error is made
    BudgetedDomParser builder(doc, left ? *left - reader_memory : std::numeric_limits<std::uintmax_t>::max());
    Json::sax_parse(text, &builder);
    return doc;
  } catch (const Json::parse_error& e) {
    throw Error(file.string(), "", "malformed JSON at " + line_and_column(text, e.byte));
  } catch (const Json::out_of_range&) {  // a number beyond a double (1e999); nlohmann gives no offset
    throw Error(file.string(), "", "a number is too large for a double (beyond 1.8e308)");
  } catch (const BudgetedDomParser::OverBudget&) {
    throw no_room();
  } catch (const std::bad_alloc&) {
    fail_out_of_memory(file, text.size(), "parsing its JSON");
  }
}

Json read_json(const fs::path& path, std::uintmax_t max_bytes) { return parse_json(read_file(path, max_bytes), path); }

JsonView::JsonView(const Json& j, fs::path file, std::string where)
    : j_(&j), file_(std::move(file)), where_(std::move(where)) {}

std::string JsonView::path_of(std::string_view key) const {
  if (key.empty()) return where_.empty() ? std::string("(top level)") : where_;
  if (where_.empty()) return std::string(key);
  return where_ + "." + std::string(key);
}

void JsonView::fail(std::string_view reason, std::string_view key) const {
  throw Error(file_.string(), path_of(key), std::string(reason));
}

bool JsonView::has(std::string_view key) const {
  return j_->is_object() && j_->contains(key) && !(*j_)[std::string(key)].is_null();
}

JsonView JsonView::at(std::string_view key) const {
  if (!j_->is_object()) fail("expected an object");
  auto it = j_->find(key);
  if (it == j_->end() || it->is_null()) fail("missing (required)", key);
  return JsonView(*it, file_, path_of(key));
}

std::optional<JsonView> JsonView::maybe(std::string_view key) const {
  if (!has(key)) return std::nullopt;
  return at(key);
}

JsonView JsonView::at(std::size_t index) const {
  if (!j_->is_array()) fail("expected an array");
  if (index >= j_->size()) fail("index " + std::to_string(index) + " out of range");
  return JsonView((*j_)[index], file_, path_of({}) + "[" + std::to_string(index) + "]");
}

std::size_t JsonView::size() const {
  if (!j_->is_array()) fail("expected an array");
  return j_->size();
}

std::string JsonView::as_str() const {
  if (!j_->is_string()) fail("expected a string, found " + std::string(j_->type_name()));
  return j_->get<std::string>();
}
double JsonView::as_num() const {
  if (!j_->is_number()) fail("expected a number, found " + std::string(j_->type_name()));
  return j_->get<double>();
}
std::int64_t JsonView::as_integer() const {
  if (!j_->is_number_integer() && !j_->is_number_unsigned())
    fail("expected an integer, found " + (j_->is_number() ? j_->dump() : std::string(j_->type_name())));
  return j_->get<std::int64_t>();
}

std::string JsonView::str(std::string_view key) const { return at(key).as_str(); }
double JsonView::num(std::string_view key) const { return at(key).as_num(); }
std::int64_t JsonView::integer(std::string_view key) const { return at(key).as_integer(); }
bool JsonView::boolean(std::string_view key) const {
  JsonView v = at(key);
  if (!v.json().is_boolean()) v.fail("expected true or false");
  return v.json().get<bool>();
}

void check_format(const JsonView& j, std::string_view format, std::initializer_list<int> versions) {
  if (!j.json().is_object()) j.fail("expected a JSON object of format '" + std::string(format) + "'");
  if (!j.has("format"))
    j.fail("missing; expected \"" + std::string(format) + "\" (not a file of this toolkit?)", "format");
  const std::string found = j.str("format");
  if (found != format)
    j.fail("is \"" + found + "\", expected \"" + std::string(format) + "\"", "format");
  const auto v = j.integer("version");
  std::string list;
  for (int x : versions) {
    if (v == x) return;
    list += (list.empty() ? "" : ", ") + std::to_string(x);
  }
  j.fail("unsupported version " + std::to_string(v) + " (this build reads " + list + ")", "version");
}

}  // namespace smseg
