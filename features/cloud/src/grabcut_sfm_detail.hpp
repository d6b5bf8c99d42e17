#pragma once
// What GrabCutSFM's building blocks (grabcut_sfm.cpp) and its pipeline (grabcut_sfm_pipeline.cpp) share.
// Internal.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Core>

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

/// Points on a voxel grid of `size`: the points within `size` of a point lie in its 27 surrounding cells.
class VoxelGrid {
 public:
  VoxelGrid(const std::vector<Eigen::Vector3f>& points, double size) : points_(points), size_(size), cells_(points.size()) {
    for (std::size_t i = 0; i < points.size(); ++i) cells_[i] = {key(cell_of(points[i])), int(i)};
    std::sort(cells_.begin(), cells_.end());
  }
  /// Calls visit(j) for every point j of the grid within `size` of p.
  template <class Visit>
  void for_each_near(const Eigen::Vector3f& p, Visit visit) const {
    const Eigen::Vector3i c = cell_of(p);
    const double s2 = size_ * size_;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const std::uint64_t k = key(c + Eigen::Vector3i(dx, dy, dz));
          for (auto it = std::lower_bound(cells_.begin(), cells_.end(), std::make_pair(k, -1));
               it != cells_.end() && it->first == k; ++it)
            if ((p - points_[std::size_t(it->second)]).squaredNorm() <= s2) visit(std::size_t(it->second));
        }
  }

 private:
  Eigen::Vector3i cell_of(const Eigen::Vector3f& p) const {
    return Eigen::Vector3i(int(std::floor(p.x() / size_)), int(std::floor(p.y() / size_)), int(std::floor(p.z() / size_)));
  }
  static std::uint64_t key(const Eigen::Vector3i& c) {
    return (std::uint64_t(std::uint32_t(c.x()) & 0x1FFFFF) << 42) | (std::uint64_t(std::uint32_t(c.y()) & 0x1FFFFF) << 21) |
           std::uint64_t(std::uint32_t(c.z()) & 0x1FFFFF);
  }
  const std::vector<Eigen::Vector3f>& points_;
  double size_;
  std::vector<std::pair<std::uint64_t, int>> cells_;
};

}  // namespace smseg::cloud::detail
