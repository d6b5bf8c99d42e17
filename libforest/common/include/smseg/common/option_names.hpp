#pragma once
// The libraries check their parameters and name them as their structs and files do ("stereo.block_size");
// a tool that sets them from options checks them before any work and reports a bad value under the
// option the user typed ("--block-size"), as bad usage (exit status 2, README).
#include <map>
#include <string>
#include <utility>

#include "smseg/common/cli.hpp"

namespace smseg {

/// Library field -> command-line option, for validate_options.
using OptionNames = std::map<std::string, std::string>;

/// The field of a library Error as the user typed it: the option that sets it, or the field itself.
inline std::string option_of(const OptionNames& option_of_field, const Error& e) {
  const auto it = option_of_field.find(e.field());
  return it == option_of_field.end() ? e.field() : it->second;
}

/// Runs check() (the libraries' validate() calls); an Error it throws becomes a UsageError naming the
/// option that sets the field (or the field itself when no option does).
template <class Check>
void validate_options(const OptionNames& option_of_field, Check&& check) {
  try {
    std::forward<Check>(check)();
  } catch (const Error& e) {
    throw UsageError(e.file(), option_of(option_of_field, e), e.reason());
  }
}

/// Runs body() (the run itself) and returns what it returns; an Error about a parameter the run found
/// too late for the parser (a memory budget one tree does not fit in) is re-thrown naming the option,
/// still as a failure of the run (exit status 1). Usage errors pass as they are.
template <class Body>
auto naming_options(const OptionNames& option_of_field, Body&& body) {
  try {
    return std::forward<Body>(body)();
  } catch (const UsageError&) {
    throw;
  } catch (const Error& e) {
    throw Error(e.file(), option_of(option_of_field, e), e.reason());
  }
}

}  // namespace smseg
