// The ground-plane RANSAC shared by the monocular SfM's scale and the stereo path's gravity (gravity.hpp).

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "smseg/frontend/gravity.hpp"

namespace smseg::frontend {

namespace {

std::uint64_t mix(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

}  // namespace

PlaneFit fit_ground_plane(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& up_in, double threshold,
                          double max_tilt_deg, int iterations, std::uint64_t seed, int min_inliers) {
  min_inliers = std::max(3, min_inliers);
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
  if (!best.ok || best.inliers < min_inliers) return PlaneFit{};
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
  return best.inliers >= min_inliers ? best : PlaneFit{};
}

}  // namespace smseg::frontend
