#pragma once
// Small helpers over channel names, shared by the channel maps (mirror.cpp, exposure.cpp).

#include <algorithm>
#include <string>
#include <vector>

namespace smseg::stacks::names {

inline bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

inline bool in(const std::vector<std::string>& list, const std::string& name) {
  return std::find(list.begin(), list.end(), name) != list.end();
}

}  // namespace smseg::stacks::names
