// Matching and two-view verification of consecutive frames for the monocular SfM (see sfm_matching.hpp).
#include "sfm_matching.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <opencv2/calib3d.hpp>

namespace smseg::sfm::sfm_matching {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

namespace {

/// Offers candidate `who` at descriptor distance d to a keypoint's running nearest (best, d1) and
/// second-nearest distance (d2); ties go to the lower index, so the result does not depend on order.
void offer(float d, int who, int& best, float& d1, float& d2) {
  if (d < d1 || (d == d1 && who < best)) {
    d2 = d1;
    d1 = d;
    best = who;
  } else if (d < d2) {
    d2 = d;
  }
}

}  // namespace

/// Symmetric matches that also pass Lowe's ratio test in both directions.
std::vector<cv::DMatch> match_ratio(const cv::Mat& a, const cv::Mat& b, int norm, double ratio) {
  std::vector<cv::DMatch> out;
  if (a.empty() || b.empty() || a.rows < 2 || b.rows < 2) return out;
  cv::BFMatcher bf(norm, false);
  std::vector<std::vector<cv::DMatch>> ab, ba;
  bf.knnMatch(a, b, ab, 2);
  bf.knnMatch(b, a, ba, 2);
  auto passes = [&](const std::vector<cv::DMatch>& m) {
    return m.size() == 1 || (m.size() >= 2 && m[0].distance < ratio * m[1].distance);
  };
  for (const auto& m : ab) {
    if (m.empty() || !passes(m)) continue;
    const auto& back = ba[m[0].trainIdx];
    if (back.empty() || !passes(back) || back[0].trainIdx != m[0].queryIdx) continue;
    out.push_back(m[0]);
  }
  std::sort(out.begin(), out.end(), [](const cv::DMatch& x, const cv::DMatch& y) { return x.queryIdx < y.queryIdx; });
  return out;
}

/// Symmetric nearest-neighbour matching restricted to candidates within `radius` pixels (the camera
/// moves little between consecutive frames; the gate removes most ambiguity of repetitive texture):
/// (i, j) is kept when j is i's nearest descriptor among b's keypoints within the radius and i is j's
/// nearest among a's within it; with ratio > 0 the nearest must also beat the second by that ratio.
std::vector<cv::DMatch> match_gated(const cv::Mat& da, const std::vector<cv::Point2f>& pa, const cv::Mat& db,
                                    const std::vector<cv::Point2f>& pb, int norm, double radius, double ratio) {
  std::vector<cv::DMatch> out;
  const int na = da.rows, nb = db.rows;
  if (na == 0 || nb == 0) return out;
  // Bucket b's keypoints on a grid of radius-sized cells.
  const double cell = radius;
  auto key = [&](const cv::Point2f& p) {
    return std::pair<int, int>(static_cast<int>(std::floor(p.x / cell)), static_cast<int>(std::floor(p.y / cell)));
  };
  std::map<std::pair<int, int>, std::vector<int>> grid;
  for (int j = 0; j < nb; ++j) grid[key(pb[j])].push_back(j);
  const double r2 = radius * radius;
  std::vector<int> best_ab(na, -1);
  std::vector<float> dist_ab(na, std::numeric_limits<float>::max());
  std::vector<int> best_ba(nb, -1);
  std::vector<float> dist_ba(nb, std::numeric_limits<float>::max()), second_ba(nb, std::numeric_limits<float>::max());
  std::vector<char> ok_a(na, 0);
  for (int i = 0; i < na; ++i) {
    const auto [gx, gy] = key(pa[i]);
    float d1 = std::numeric_limits<float>::max(), d2 = d1;
    int b1 = -1;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy) {
        const auto it = grid.find({gx + dx, gy + dy});
        if (it == grid.end()) continue;
        for (int j : it->second) {
          const cv::Point2f v = pb[j] - pa[i];
          if (v.x * v.x + v.y * v.y > r2) continue;
          const float d = static_cast<float>(cv::norm(da.row(i), db.row(j), norm));
          offer(d, j, b1, d1, d2);
          offer(d, i, best_ba[j], dist_ba[j], second_ba[j]);
        }
      }
    best_ab[i] = b1;
    dist_ab[i] = d1;
    ok_a[i] = b1 >= 0 && (ratio <= 0 || d2 == std::numeric_limits<float>::max() || d1 < ratio * d2);
  }
  for (int i = 0; i < na; ++i) {
    const int j = best_ab[i];
    if (j < 0 || !ok_a[i] || best_ba[j] != i) continue;
    if (ratio > 0 && second_ba[j] != std::numeric_limits<float>::max() && !(dist_ba[j] < ratio * second_ba[j])) continue;
    out.emplace_back(i, j, dist_ab[i]);
  }
  return out;
}

std::vector<cv::DMatch> match_epipolar(const cv::Mat& da, const std::vector<cv::Point2f>& pa, const cv::Mat& db,
                                       const std::vector<cv::Point2f>& pb, const cv::Matx33d& F, int norm,
                                       double band_px, double ratio) {
  constexpr float kNone = std::numeric_limits<float>::max();
  const int na = da.rows, nb = db.rows;
  std::vector<cv::DMatch> out;
  if (na == 0 || nb == 0) return out;
  // Epipolar lines, normalised so that l . (x, y, 1) is a distance in pixels.
  auto normalised = [](const cv::Vec3d& l) {
    const double s = std::hypot(l[0], l[1]);
    return s > 0 ? l / s : cv::Vec3d(0, 0, 0);
  };
  std::vector<cv::Vec3d> line_in_b(na), line_in_a(nb);
  for (int i = 0; i < na; ++i) line_in_b[i] = normalised(F * cv::Vec3d(pa[i].x, pa[i].y, 1));
  for (int j = 0; j < nb; ++j) line_in_a[j] = normalised(F.t() * cv::Vec3d(pb[j].x, pb[j].y, 1));
  std::vector<int> best_ab(na, -1), best_ba(nb, -1);
  std::vector<float> d1a(na, kNone), d2a(na, kNone), d1b(nb, kNone), d2b(nb, kNone);
  for (int i = 0; i < na; ++i) {
    const cv::Vec3d& l = line_in_b[i];
    for (int j = 0; j < nb; ++j) {
      if (std::abs(l[0] * pb[j].x + l[1] * pb[j].y + l[2]) > band_px) continue;
      const cv::Vec3d& m = line_in_a[j];
      if (std::abs(m[0] * pa[i].x + m[1] * pa[i].y + m[2]) > band_px) continue;
      const float d = static_cast<float>(cv::norm(da.row(i), db.row(j), norm));
      offer(d, j, best_ab[i], d1a[i], d2a[i]);
      offer(d, i, best_ba[j], d1b[j], d2b[j]);
    }
  }
  for (int i = 0; i < na; ++i) {
    const int j = best_ab[i];
    if (j < 0 || best_ba[j] != i) continue;
    if (d2a[i] != kNone && !(d1a[i] < ratio * d2a[i])) continue;
    if (d2b[j] != kNone && !(d1b[j] < ratio * d2b[j])) continue;
    out.emplace_back(i, j, d1a[i]);
  }
  return out;
}

PairInfo verify_pair(std::vector<cv::DMatch>& m, const std::vector<cv::Point2f>& pa, const std::vector<cv::Point2f>& pb,
                     const SfmOptions& o) {
  PairInfo info;
  std::vector<double> motion;
  for (const auto& d : m) motion.push_back(cv::norm(pb[d.trainIdx] - pa[d.queryIdx]));
  if (m.size() < 8) {
    m.clear();
    return info;
  }
  const double med = median(motion);
  if (med < o.still_motion_px) {
    // Standing still: the epipolar geometry is undefined; keep the matches that did not move.
    const double keep = std::max(2.0, 4 * o.still_motion_px);
    std::vector<cv::DMatch> kept;
    for (std::size_t k = 0; k < m.size(); ++k)
      if (motion[k] <= keep) kept.push_back(m[k]);
    m = std::move(kept);
    info.still = true;
  } else {
    std::vector<cv::Point2f> a, b;
    for (const auto& d : m) {
      a.push_back(pa[d.queryIdx]);
      b.push_back(pb[d.trainIdx]);
    }
    std::vector<std::uint8_t> mask;
    const cv::Mat F = cv::findFundamentalMat(a, b, cv::FM_RANSAC, o.fundamental_threshold_px, 0.999, 2000, mask);
    if (F.rows != 3 || F.cols != 3) {
      m.clear();
      return info;
    }
    std::vector<cv::DMatch> kept;
    for (std::size_t k = 0; k < m.size(); ++k)
      if (mask[k]) kept.push_back(m[k]);
    m = std::move(kept);
    info.has_f = m.size() >= 30;
    info.F = cv::Matx33d(F.ptr<double>());
  }
  std::vector<double> mv;
  for (const auto& d : m) mv.push_back(cv::norm(pb[d.trainIdx] - pa[d.queryIdx]));
  info.median_motion = median(mv);
  return info;
}

}  // namespace smseg::sfm::sfm_matching
