#pragma once
// File helpers shared by every stage: atomic writes (temporary file, then rename), JSON reading with
// errors that name the file and the field, and format/version checks (DESIGN section 3).

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
void write_json_atomic(const fs::path& path, const Json& j, int indent = 1);

/// Reads a whole file; Error("path", "", "cannot be read: ...") when missing or unreadable.
std::string read_file(const fs::path& path);

/// Why `path` is not a file we can read, in a few words for an error line ("does not exist", "is a
/// folder, expected a file", "is not a regular file"); empty when it is a regular file.
std::string why_not_a_file(const fs::path& path);

/// Parses a JSON file; malformed JSON gives an Error with the line and column.
Json read_json(const fs::path& path);

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
