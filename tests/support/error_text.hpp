#pragma once
// What an smseg::Error says, for tests that check an error names the file, the option and the problem.
#include <functional>
#include <string>

#include "smseg/common/error.hpp"

namespace smseg::test {

/// The message of the smseg::Error f() throws, or "(no error)".
inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const smseg::Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace smseg::test
