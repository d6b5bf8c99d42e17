#pragma once
// Model files damaged one field at a time (texton dictionaries, HOG class models): each must be refused in
// one error naming the file and the field.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "smseg/common/io.hpp"
#include "error_text.hpp"

namespace smseg::test {

/// Writes `good` damaged by `damage` to `bad` and expects load(bad) to throw an Error that names `bad`'s
/// file name and `what`.
inline void expect_damage_refused(const Json& good, const std::filesystem::path& bad,
                                  const std::function<void(const std::filesystem::path&)>& load,
                                  const std::function<void(Json&)>& damage, const std::string& what) {
  Json j = good;
  damage(j);
  std::ofstream(bad) << j.dump();
  const std::string e = error_of([&] { load(bad); });
  EXPECT_NE(e.find(bad.filename().string()), std::string::npos) << e;
  EXPECT_NE(e.find(what), std::string::npos) << e;
}

}  // namespace smseg::test
