#pragma once
// File helpers shared by every stage: atomic writes (temporary file, then rename), JSON reading with
// errors that name the file and the field, and format/version checks (docs/design.md section 3).

#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "smseg/common/error.hpp"

namespace smseg {

namespace fs = std::filesystem;
using Json = nlohmann::json;

/// Writes bytes to path atomically: a temporary file in the same folder, flushed, then renamed over
/// path. Creates missing parent folders. Throws Error on failure; never leaves a partial path.
void write_file_atomic(const fs::path& path, std::string_view bytes);

/// write_file_atomic of j.dump(indent) plus a final newline.
/// j as the text a file `path` will hold (indent as Json::dump's); Error naming `path` when it holds
/// text that is not UTF-8 (nlohmann's type_error 316), which JSON cannot carry.
std::string json_text(const Json& j, const fs::path& path, int indent = -1);
void write_json_atomic(const fs::path& path, const Json& j, int indent = 1);

/// The most bytes a reader takes from one file, by what its format can hold (docs/reliability.md):
/// a larger file is refused with one line naming the file and the limit, before it is read.
inline constexpr std::uintmax_t kMiB = std::uintmax_t{1} << 20;
/// Manifests, configs, class tables, results and other JSON/CSV written by hand or per run.
inline constexpr std::uintmax_t kMaxTextFileBytes = 256 * kMiB;
/// The big JSON files: forests (and forest parts) and tracks files.
inline constexpr std::uintmax_t kMaxLargeFileBytes = 4096 * kMiB;

/// Why `path` is not a file we can read, in a few words for an error line ("does not exist", "is a
/// folder, expected a file", "is a FIFO (named pipe), expected a regular file", "is a device, ...",
/// "is a socket, ..."); empty when it is a regular file.
std::string why_not_a_file(const fs::path& path);

/// Reads a whole regular file of at most max_bytes; Error naming the file when it is missing,
/// unreadable, not a regular file (a FIFO, device or socket is refused at once, never waited on),
/// larger than the limit, or larger than the memory the process may still take (RLIMIT_AS) — each
/// before a byte is read.
std::string read_file(const fs::path& path, std::uintmax_t max_bytes = kMaxTextFileBytes);

/// Parses a JSON file of at most max_bytes (read_file, then parse_json).
Json read_json(const fs::path& path, std::uintmax_t max_bytes = kMaxTextFileBytes);

/// Parses JSON text that came from file (named in errors): malformed JSON, or a number too large for a
/// double (1e999), gives an Error with the line and column; so does nesting deeper than 256 arrays and
/// objects (a deeper document could overflow the stack of code that copies it). Under an address-space
/// limit, a document the process has no room for is refused as it is built, before the allocation
/// that would fail; an allocation that fails anyway is reported naming the file.
Json parse_json(std::string_view text, const fs::path& file);

/// A view of one JSON object inside a file, whose accessors throw Error naming the file and the
/// dotted path of the field ("frames[3].left") with what was expected.
class JsonView {
 public:
  JsonView(const Json& j, fs::path file, std::string where = {});

  const Json& json() const noexcept { return *j_; }
  const fs::path& file() const noexcept { return file_; }
  const std::string& where() const noexcept { return where_; }

  bool has(std::string_view key) const;
  JsonView at(std::string_view key) const;                 // required member
  std::optional<JsonView> maybe(std::string_view key) const;  // absent or null -> nullopt
  JsonView at(std::size_t index) const;                    // array element
  std::size_t size() const;                                // array size (error if not an array)

  std::string str(std::string_view key) const;
  double num(std::string_view key) const;
  std::int64_t integer(std::string_view key) const;
  bool boolean(std::string_view key) const;

  std::string as_str() const;
  double as_num() const;
  std::int64_t as_integer() const;

  /// Error for this field (or a member of it).
  [[noreturn]] void fail(std::string_view reason, std::string_view key = {}) const;

 private:
  std::string path_of(std::string_view key) const;
  const Json* j_;
  fs::path file_;
  std::string where_;
};

/// Checks j["format"] == format and j["version"] is one of versions; the error says what was found.
void check_format(const JsonView& j, std::string_view format, std::initializer_list<int> versions);

}  // namespace smseg
