#pragma once
// What learn-textons and learn-hog-classes record of the folders a model was learned from.
#include <string>
#include <vector>

#include "smseg/common/digest.hpp"
#include "smseg/common/io.hpp"

namespace smseg::stacks {

/// Each work folder, absolute, with its stacks.json's digest (a folder extracted again shows).
inline Json learned_from(const std::vector<std::string>& works) {
  Json folders = Json::array();
  for (const auto& w : works)
    folders.push_back({{"work", fs::absolute(w).lexically_normal().string()},
                       {"stacks_json_fnv1a64", fnv1a64_hex(read_file(fs::path(w) / "stacks.json"))}});
  return folders;
}

}  // namespace smseg::stacks
