#include "smseg/common/io.hpp"
#include "smseg/common/output.hpp"

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

void write_json_atomic(const fs::path& path, const Json& j, int indent) {
  write_file_atomic(path, j.dump(indent) + "\n");
}

std::string why_not_a_file(const fs::path& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (!fs::exists(st)) return "does not exist";
  if (fs::is_directory(st)) return "is a folder, expected a file";
  if (!fs::is_regular_file(st)) return "is not a regular file";
  return {};
}

namespace {

std::string describe_limit(std::uintmax_t max_bytes) {
  if (max_bytes % kMiB == 0) return std::to_string(max_bytes / kMiB) + " MiB";
  return std::to_string(max_bytes) + " bytes";
}

[[noreturn]] void fail_too_large(const fs::path& path, std::uintmax_t max_bytes) {
  throw Error(path.string(), "", "is larger than the " + describe_limit(max_bytes) + " this reader accepts");
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

}  // namespace

std::string read_file(const fs::path& path, std::uintmax_t max_bytes) {
  std::error_code ec;
  // Devices and FIFOs are read (bounded, below); what cannot be read at all is named for what it is.
  if (!fs::exists(path, ec) || fs::is_directory(path, ec)) throw Error(path.string(), "", why_not_a_file(path));
  // A regular file that is too large is refused before a byte is read; anything else (a device, a
  // FIFO, a file still growing) is read in chunks until it ends or passes the limit.
  std::uintmax_t expected_size = 0;
  if (fs::is_regular_file(path, ec)) {
    expected_size = fs::file_size(path, ec);
    if (ec) expected_size = 0;
    if (expected_size > max_bytes) fail_too_large(path, max_bytes);
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string(), "", std::string("cannot be read: ") + std::strerror(errno));
  std::string bytes;
  bytes.reserve(static_cast<std::size_t>(expected_size));
  std::array<char, 16384> chunk;
  while (bytes.size() <= max_bytes) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    bytes.append(chunk.data(), static_cast<std::size_t>(in.gcount()));
    if (!in) break;
  }
  if (in.bad()) throw Error(path.string(), "", "read failed");
  if (bytes.size() > max_bytes) fail_too_large(path, max_bytes);
  return bytes;
}

Json parse_json(std::string_view text, const fs::path& file) {
  try {
    return Json::parse(text);
  } catch (const Json::parse_error& e) {
    throw Error(file.string(), "", "malformed JSON at " + line_and_column(text, e.byte));
  } catch (const Json::out_of_range&) {  // a number beyond a double (1e999); nlohmann gives no offset
    throw Error(file.string(), "", "a number is too large for a double (beyond 1.8e308)");
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
