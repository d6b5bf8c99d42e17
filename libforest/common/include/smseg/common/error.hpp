#pragma once
// The one error type of the toolkit: it names the file, the field and what was wrong, so that a
// command-line tool can print it as one line (docs/design.md section 7, "Errors").

#include <stdexcept>
#include <string>

namespace smseg {

class Error : public std::runtime_error {
 public:
  /// file: the file (or folder) concerned, may be empty; field: the JSON field, frame or option
  /// concerned, may be empty; reason: what was expected or what went wrong.
  Error(std::string file, std::string field, std::string reason);

  const std::string& file() const noexcept { return file_; }
  const std::string& field() const noexcept { return field_; }
  const std::string& reason() const noexcept { return reason_; }

 private:
  std::string file_;
  std::string field_;
  std::string reason_;
};

}  // namespace smseg
