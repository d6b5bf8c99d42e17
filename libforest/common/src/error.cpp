#include "smseg/common/error.hpp"

namespace smseg {

namespace {

/// A name as one line of text: control characters (a newline in a file name) written as \n, \t or \xNN,
/// so that an error stays one line however its file is named.
std::string one_line(const std::string& name) {
  static const char* hex = "0123456789abcdef";
  std::string s;
  for (const char ch : name) {
    const auto c = static_cast<unsigned char>(ch);
    if (c >= 0x20 && c != 0x7f) s += ch;
    else if (c == '\n') s += "\\n";
    else if (c == '\t') s += "\\t";
    else s += std::string("\\x") + hex[c >> 4] + hex[c & 15];
  }
  return s;
}

std::string compose(const std::string& file, const std::string& field, const std::string& reason) {
  std::string m;
  if (!file.empty()) m += one_line(file) + ": ";
  if (!field.empty()) m += one_line(field) + ": ";
  return m + reason;
}

}  // namespace

Error::Error(std::string file, std::string field, std::string reason)
    : std::runtime_error(compose(file, field, reason)),
      file_(std::move(file)),
      field_(std::move(field)),
      reason_(std::move(reason)) {}

}  // namespace smseg
