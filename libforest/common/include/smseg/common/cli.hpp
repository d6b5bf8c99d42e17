#pragma once
// What every command-line tool shares: CLI11 parsing with our exit codes (2 for bad usage), and
// errors turned into one line on stderr with exit status 1 (docs/design.md section 7, "Errors").

#include <charconv>
#include <cstdint>
#include <exception>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "smseg/common/error.hpp"
#include "smseg/common/threads.hpp"

namespace smseg {

/// An error in how the tool was called (a bad option value, options that exclude each other) found
/// after parsing: printed like a CLI11 parse error, exit status 2.
class UsageError : public Error {
 public:
  using Error::Error;
};

/// For unsigned options (seeds): only decimal digits. CLI11 reads "-1" into an unsigned as 2^64-1 and
/// "010" as octal; a seed typed that way is a mistake, not a wish.
inline const CLI::Validator kDecimalDigits(
    [](std::string& value) -> std::string {
      std::uint64_t x = 0;
      const char* end = value.data() + value.size();
      const auto parsed = std::from_chars(value.data(), end, x);  // fails past 2^64 - 1 (CLI11 would wrap)
      const bool digits = !value.empty() && value.find_first_not_of("0123456789") == std::string::npos &&
                          !(value.size() > 1 && value[0] == '0') && parsed.ec == std::errc() && parsed.ptr == end;
      return digits ? std::string()
                    : "expected a non-negative whole number (decimal digits, at most 18446744073709551615), got '" + value + "'";
    },
    "UINT");

/// The items of an option's comma-separated list ("fH,fC,fD"), empty items dropped.
inline std::vector<std::string> split_comma_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

/// f(), with an Error it throws turned into a UsageError: for checking option values with the
/// library's own parsers (a bad value is bad usage, exit status 2, not a failure of the run).
template <class F>
auto as_usage(F&& f) {
  try {
    return f();
  } catch (const UsageError&) {
    throw;
  } catch (const Error& e) {
    throw UsageError(e.file(), e.field(), e.reason());
  }
}

/// Parses argv into app, then runs body(); returns the process exit status.
template <class Body>
int run_tool(CLI::App& app, int argc, char** argv, Body&& body) {
  const std::string name = app.get_name();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::cerr << name << ": " << e.what() << " (see " << name << " --help)\n";
    return 2;
  }
  try {
    return body();
  } catch (const UsageError& e) {
    std::cerr << name << ": " << e.what() << " (see " << name << " --help)\n";
    return 2;
  } catch (const Error& e) {
    std::cerr << name << ": error: " << e.what() << "\n";
  } catch (const std::bad_alloc&) {
    std::cerr << name << ": error: out of memory\n";
  } catch (const std::exception& e) {
    std::cerr << name << ": error: " << e.what() << "\n";
  }
  return 1;
}

/// run_tool, with body() run on `threads` worker threads (the tool's --threads, see add_threads_option;
/// read after parsing).
template <class Body>
int run_tool(CLI::App& app, int argc, char** argv, const int& threads, Body&& body) {
  return run_tool(app, argc, argv, [&] { return with_threads(threads, body); });
}

}  // namespace smseg
