#include "smseg/common/error.hpp"

namespace smseg {

namespace {
std::string compose(const std::string& file, const std::string& field, const std::string& reason) {
  std::string m;
  if (!file.empty()) m += file + ": ";
  if (!field.empty()) m += field + ": ";
  return m + reason;
}
}  // namespace

Error::Error(std::string file, std::string field, std::string reason)
    : std::runtime_error(compose(file, field, reason)),
      file_(std::move(file)),
      field_(std::move(field)),
      reason_(std::move(reason)) {}

}  // namespace smseg
