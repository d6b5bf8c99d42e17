// Focal length self-calibration of the monocular SfM (the ground-plane RANSAC is frontend/ground_plane.cpp).

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "smseg/sfm/sfm.hpp"

namespace smseg::sfm {

namespace {

// Mendonca & Cipolla: E = K^T F K has two equal singular values for the right K.
double equal_singular_cost(const cv::Matx33d& F, double f, double cx, double cy) {
  Eigen::Matrix3d Fe;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Fe(r, c) = F(r, c);
  Eigen::Matrix3d K;
  K << f, 0, cx, 0, f, cy, 0, 0, 1;
  const Eigen::Matrix3d E = K.transpose() * Fe * K;
  const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::Matrix3d>(E).singularValues();
  if (!(s(0) > 0)) return 1.0;
  return (s(0) - s(1)) / (s(0) + s(1));
}

}  // namespace

std::optional<double> estimate_focal_from_fundamentals(const std::vector<cv::Matx33d>& fundamentals, cv::Size size,
                                                       int* pairs_used) {
  const double cx = (size.width - 1) / 2.0, cy = (size.height - 1) / 2.0;
  const double lo = 0.3 * size.width, hi = 4.0 * size.width;
  constexpr int kGrid = 160;
  std::vector<double> grid(kGrid);
  for (int i = 0; i < kGrid; ++i) grid[i] = lo * std::pow(hi / lo, i / (kGrid - 1.0));
  std::vector<const cv::Matx33d*> used;
  std::vector<double> total(kGrid, 0.0);
  for (const auto& F : fundamentals) {
    std::vector<double> c(kGrid);
    double cmin = 1e9, cmax = -1e9;
    for (int i = 0; i < kGrid; ++i) {
      c[i] = equal_singular_cost(F, grid[i], cx, cy);
      cmin = std::min(cmin, c[i]);
      cmax = std::max(cmax, c[i]);
    }
    // A pair constrains f when its cost has a clear minimum near zero inside the range: at most 0.05,
    // and at least 0.05 below the cost's maximum over the range (a 6-degree rotation gives ~0.07;
    // pure translation, which leaves f free, a flat cost near 0).
    if (!(cmin < 0.05 && cmax - cmin > 0.05)) continue;
    const int imin = static_cast<int>(std::min_element(c.begin(), c.end()) - c.begin());
    if (imin == 0 || imin == kGrid - 1) continue;
    used.push_back(&F);
    for (int i = 0; i < kGrid; ++i) total[i] += c[i];
  }
  if (pairs_used) *pairs_used = static_cast<int>(used.size());
  if (used.empty()) return std::nullopt;
  const int imin = static_cast<int>(std::min_element(total.begin(), total.end()) - total.begin());
  if (imin == 0 || imin == kGrid - 1) return std::nullopt;
  // Golden-section refinement between the neighbouring grid values (log f).
  auto cost = [&](double logf) {
    double s = 0;
    for (const auto* F : used) s += equal_singular_cost(*F, std::exp(logf), cx, cy);
    return s;
  };
  double a = std::log(grid[imin - 1]), b = std::log(grid[imin + 1]);
  const double g = (std::sqrt(5.0) - 1) / 2;
  double x1 = b - g * (b - a), x2 = a + g * (b - a);
  double f1 = cost(x1), f2 = cost(x2);
  for (int it = 0; it < 40; ++it) {
    if (f1 < f2) {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - g * (b - a);
      f1 = cost(x1);
    } else {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + g * (b - a);
      f2 = cost(x2);
    }
  }
  return std::exp((a + b) / 2);
}

}  // namespace smseg::sfm
