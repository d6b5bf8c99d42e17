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

/// Runs check() (the libraries' validate() calls); an Error it throws becomes a UsageError naming the
/// option that sets the field (or the field itself when no option does).
template <class Check>
void validate_options(const OptionNames& option_of_field, Check&& check) {
  try {
    std::forward<Check>(check)();
  } catch (const Error& e) {
    const auto it = option_of_field.find(e.field());
    throw UsageError(e.file(), it == option_of_field.end() ? e.field() : it->second, e.reason());
  }
}

}  // namespace smseg
