// Geometry helpers of the monocular SfM: focal length self-calibration and the ground-plane RANSAC.

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "smseg/frontend/sfm.hpp"

namespace smseg::features {

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

std::uint64_t mix(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
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

PlaneFit fit_ground_plane(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& up_in, double threshold,
                          double max_tilt_deg, int iterations, std::uint64_t seed) {
  PlaneFit best;
  const int n = static_cast<int>(pts.size());
  if (n < 3 || !(up_in.norm() > 0)) return best;
  const Eigen::Vector3d up = up_in.normalized();
  const double min_cos = std::cos(max_tilt_deg * M_PI / 180);
  std::mt19937_64 rng(mix(seed));
  std::uniform_int_distribution<int> pick(0, n - 1);
  auto count = [&](const Eigen::Vector3d& nrm, double d) {
    int c = 0;
    for (const auto& p : pts) c += std::abs(nrm.dot(p) + d) < threshold;
    return c;
  };
  for (int it = 0; it < iterations; ++it) {
    const int a = pick(rng), b = pick(rng), c = pick(rng);
    if (a == b || b == c || a == c) continue;
    Eigen::Vector3d nrm = (pts[b] - pts[a]).cross(pts[c] - pts[a]);
    if (!(nrm.norm() > 1e-12)) continue;
    nrm.normalize();
    if (nrm.dot(up) < 0) nrm = -nrm;
    if (nrm.dot(up) < min_cos) continue;
    const double d = -nrm.dot(pts[a]);
    const int k = count(nrm, d);
    if (k > best.inliers) {
      best.inliers = k;
      best.normal = nrm;
      best.d = d;
      best.ok = true;
    }
  }
  if (!best.ok || best.inliers < 3) return PlaneFit{};
  // Least-squares refit on the inliers (twice: the inlier set may grow).
  for (int round = 0; round < 2; ++round) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    int k = 0;
    for (const auto& p : pts)
      if (std::abs(best.normal.dot(p) + best.d) < threshold) {
        mean += p;
        ++k;
      }
    if (k < 3) break;
    mean /= k;
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    for (const auto& p : pts)
      if (std::abs(best.normal.dot(p) + best.d) < threshold) C += (p - mean) * (p - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
    Eigen::Vector3d nrm = es.eigenvectors().col(0).normalized();
    if (nrm.dot(up) < 0) nrm = -nrm;
    if (nrm.dot(up) < min_cos) break;
    best.normal = nrm;
    best.d = -nrm.dot(mean);
    best.inliers = count(best.normal, best.d);
  }
  return best;
}

}  // namespace smseg::features
