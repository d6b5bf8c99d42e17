#pragma once
// What GrabCutSFM's building blocks (grabcut_sfm.cpp) and its pipeline (grabcut_sfm_pipeline.cpp) share.
// Internal.
#include <algorithm>
#include <cstdint>
#include <vector>

namespace smseg::cloud::detail {

/// Seeds for separate stages, so that changing one stage's draws does not shift another's.
inline std::uint64_t stage_seed(std::uint64_t seed, std::uint64_t stage) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ull * (stage + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/// The median (the mean of the two middle values for an even count); 0 for none.
inline double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const std::size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(m), v.end());
  double hi = v[m];
  if (v.size() % 2 == 1) return hi;
  const double lo = *std::max_element(v.begin(), v.begin() + std::ptrdiff_t(m));
  return 0.5 * (lo + hi);
}

}  // namespace smseg::cloud::detail
