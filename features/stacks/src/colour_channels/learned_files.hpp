#pragma once
// What the colour-image channels learned from training frames (textons, HOG classes) share: the seed of
// one frame's draws and the arrays their model files hold.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "smseg/common/io.hpp"

namespace smseg::stacks {

/// A frame's own seed: its draws do not depend on which thread or in what order it was read.
inline std::uint64_t frame_seed(std::uint64_t seed, std::size_t folder, int frame) {
  return seed ^ (0x9E3779B97F4A7C15ULL * (1 + folder * 1000003ULL + static_cast<std::uint64_t>(frame)));
}

/// An array of `count` finite numbers (Error naming the field otherwise).
inline std::vector<double> finite_numbers(const JsonView& a, std::size_t count) {
  if (a.size() != count) a.fail("has " + std::to_string(a.size()) + " numbers, expected " + std::to_string(count));
  std::vector<double> v;
  for (std::size_t i = 0; i < count; ++i) {
    v.push_back(a.at(i).as_num());
    if (!std::isfinite(v.back())) a.at(i).fail("is not a finite number");
  }
  return v;
}

}  // namespace smseg::stacks
