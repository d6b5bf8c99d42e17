// Self-calibration of the disparity offset (disparity_offset.hpp).
#include "smseg/frontend/disparity_offset.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <limits>
#include <optional>
#include <sstream>

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "smseg/frontend/motion.hpp"
#include "smseg/frontend/stereo.hpp"

namespace smseg::frontend {

namespace {

constexpr std::size_t kMaxRowsPerPair = 300;  // enough for six parameters, and the search stays fast
constexpr int kMinRowsPerPair = 20;
constexpr double kCoarseRange = 3.0, kCoarseStep = 0.5, kFineStep = 0.125;

// One pair's correspondences: (u, v, d) in its first frame and in its second.
struct PairRows {
  std::vector<Eigen::Vector3d> a, b;
};

// Pair t's rows, from the matches whose two observations have a disparity, evenly thinned to at most
// kMaxRowsPerPair (the same rows for every trial).
PairRows pair_rows(const FrameObservations& fa, const FrameObservations& fb, const std::vector<cv::DMatch>& matches) {
  PairRows all;
  for (const auto& m : matches) {
    const float da = fa.disparities[m.queryIdx], db = fb.disparities[m.trainIdx];
    if (!(da > 0) || !(db > 0)) continue;
    all.a.emplace_back(fa.pixels[m.queryIdx].x, fa.pixels[m.queryIdx].y, da);
    all.b.emplace_back(fb.pixels[m.trainIdx].x, fb.pixels[m.trainIdx].y, db);
  }
  const std::size_t n = all.a.size();
  if (n <= kMaxRowsPerPair) return all;
  PairRows thin;
  for (std::size_t k = 0; k < kMaxRowsPerPair; ++k) {
    const auto i = static_cast<std::size_t>(static_cast<double>(k) * static_cast<double>(n - 1) / (kMaxRowsPerPair - 1));
    thin.a.push_back(all.a[i]);
    thin.b.push_back(all.b[i]);
  }
  return thin;
}

Eigen::Matrix3d rotation(const Eigen::Vector3d& w) {
  const double th = w.norm();
  if (th < 1e-12) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(th, w / th).toRotationMatrix();
}

struct Motion {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

// The rigid motion carrying points P onto their observations `seen` (u, v, d) with the least Huber
// (1 px) reprojection loss, by Gauss-Newton from `m`; appends each point's reprojection error.
void fit_motion(const std::vector<Eigen::Vector3d>& P, const std::vector<Eigen::Vector3d>& seen,
                const StereoCamera& cam, Motion& m, std::vector<double>& errors) {
  for (int it = 0; it < 6; ++it) {
    Eigen::Matrix<double, 6, 6> H = 1e-9 * Eigen::Matrix<double, 6, 6>::Identity();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    for (std::size_t i = 0; i < P.size(); ++i) {
      const Eigen::Vector3d RP = m.R * P[i], X = RP + m.t;
      if (!(X.z() > 1e-9)) continue;
      const Eigen::Vector3d r = cam.project(X) - seen[i];
      const double iz = 1.0 / X.z();
      Eigen::Matrix3d Jp;
      Jp << cam.fx * iz, 0, -cam.fx * X.x() * iz * iz, 0, cam.fy * iz, -cam.fy * X.y() * iz * iz, 0, 0,
          -cam.fx * cam.baseline * iz * iz;
      Eigen::Matrix3d skew;
      skew << 0, -RP.z(), RP.y(), RP.z(), 0, -RP.x(), -RP.y(), RP.x(), 0;
      Eigen::Matrix<double, 3, 6> J;
      J.leftCols<3>() = -Jp * skew;
      J.rightCols<3>() = Jp;
      for (int k = 0; k < 3; ++k) {
        const double a = std::abs(r[k]), w = a < 1.0 ? 1.0 : 1.0 / a;
        H += w * J.row(k).transpose() * J.row(k);
        g += w * J.row(k).transpose() * r[k];
      }
    }
    const Eigen::Matrix<double, 6, 1> dx = H.ldlt().solve(-g);
    m.R = rotation(dx.head<3>()) * m.R;
    m.t += dx.tail<3>();
    if (dx.norm() < 1e-8) break;
  }
  for (std::size_t i = 0; i < P.size(); ++i) errors.push_back((cam.project(m.R * P[i] + m.t) - seen[i]).norm());
}

double median(std::vector<double> v) {
  const std::size_t h = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(h), v.end());
  const double upper = v[h];
  if (v.size() % 2 == 1) return upper;
  return 0.5 * (*std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(h)) + upper);
}

// Median reprojection error over every usable pair with `extra` pixels added to every disparity;
// each pair's motion starts from the previous trial's. NaN when no pair is usable.
double score(const std::vector<PairRows>& pairs, const StereoCamera& cam, double extra, std::vector<Motion>& motions,
             int* usable = nullptr) {
  std::vector<double> errors;
  int used = 0;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    std::vector<Eigen::Vector3d> P, seen;
    for (std::size_t i = 0; i < pairs[k].a.size(); ++i) {
      const Eigen::Vector3d a = pairs[k].a[i] + Eigen::Vector3d(0, 0, extra);
      const Eigen::Vector3d b = pairs[k].b[i] + Eigen::Vector3d(0, 0, extra);
      if (!(a.z() > 1) || !(b.z() > 1)) continue;
      P.push_back(cam.backproject(a));
      seen.push_back(b);
    }
    if (static_cast<int>(P.size()) < kMinRowsPerPair) continue;
    fit_motion(P, seen, cam, motions[k], errors);
    ++used;
  }
  if (usable) *usable = used;
  return errors.empty() ? std::numeric_limits<double>::quiet_NaN() : median(std::move(errors));
}

// The vertex of the parabola through the best trial and its neighbours (the best itself at an end).
double vertex(const std::map<double, double>& table, std::map<double, double>::const_iterator best) {
  if (best == table.begin() || std::next(best) == table.end()) return best->first;
  const auto lo = std::prev(best), hi = std::next(best);
  const double x0 = lo->first, x1 = best->first, x2 = hi->first, e0 = lo->second, e1 = best->second, e2 = hi->second;
  const double denom = (x0 - x1) * (x0 - x2) * (x1 - x2);
  const double a = (x2 * (e1 - e0) + x1 * (e0 - e2) + x0 * (e2 - e1)) / denom;
  const double b = (x2 * x2 * (e0 - e1) + x1 * x1 * (e2 - e0) + x0 * x0 * (e1 - e2)) / denom;
  return a > 0 ? -b / (2 * a) : x1;
}

std::map<double, double>::const_iterator least(const std::map<double, double>& table) {
  auto best = table.end();
  for (auto it = table.begin(); it != table.end(); ++it)
    if (std::isfinite(it->second) && (best == table.end() || it->second < best->second)) best = it;
  return best;
}

}  // namespace

DisparityOffsetChoice parse_disparity_offset(const std::string& text, const std::string& field) {
  if (text == "auto") return {DisparityOffsetChoice::Mode::Auto, 0};
  if (text == "calibration") return {DisparityOffsetChoice::Mode::Calibration, 0};
  double px = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), px);
  if (ec != std::errc() || end != text.data() + text.size() || !(std::abs(px) <= 1000))
    throw Error("", field, "must be auto, calibration or a number of pixels in -1000..1000, got '" + text + "'");
  return {DisparityOffsetChoice::Mode::Pixels, px};
}

std::string disparity_offset_name(const DisparityOffsetChoice& c) {
  if (c.mode == DisparityOffsetChoice::Mode::Auto) return "auto";
  if (c.mode == DisparityOffsetChoice::Mode::Calibration) return "calibration";
  std::ostringstream s;
  s << c.pixels;
  return s.str();
}

OffsetEstimate estimate_disparity_offset(const std::vector<FrameObservations>& frames,
                                         const std::vector<std::vector<cv::DMatch>>& matches, const StereoCamera& cam) {
  std::vector<PairRows> pairs;
  for (std::size_t t = 0; t + 1 < frames.size() && t < matches.size(); ++t)
    pairs.push_back(pair_rows(frames[t], frames[t + 1], matches[t]));
  std::vector<Motion> motions(pairs.size());
  std::map<double, double> table;
  OffsetEstimate est;
  for (double x = -kCoarseRange; x <= kCoarseRange + 1e-9; x += kCoarseStep)
    table[x] = score(pairs, cam, x, motions, x == 0 ? &est.pairs : nullptr);
  const auto coarse = least(table);
  if (coarse == table.end()) return est;
  const double c = coarse->first;
  const bool inside = c > -kCoarseRange && c < kCoarseRange;
  for (double x = c - 3 * kFineStep; x <= c + 3 * kFineStep + 1e-9; x += kFineStep)
    if (!table.count(x)) table[x] = score(pairs, cam, x, motions);
  const auto best = least(table);
  est.best = vertex(table, best);
  est.error_best_px = best->second;
  est.error_none_px = table.at(0.0);
  est.kept = est.pairs >= 2 && inside && est.error_best_px <= (1 - kOffsetMinGain) * est.error_none_px;
  est.extra = est.kept ? est.best : 0;
  return est;
}

void offset_observations(FrameObservations& obs, double offset, const sequence::Calibration& calib) {
  if (offset == 0) return;
  const auto add = static_cast<float>(offset);
  const double fx = *calib.fx, fy = calib.fy.value_or(fx), B = *calib.baseline;
  for (std::size_t i = 0; i < obs.disparities.size(); ++i) {
    float& d = obs.disparities[i];
    if (!(d > 0)) continue;
    d = d + add > 0 ? d + add : kInvalidDisparity;
    obs.points[i] = d > 0 ? backproject(obs.pixels[i].x, obs.pixels[i].y, d, fx, fy, calib.cx, calib.cy, B)
                          : Eigen::Vector3d::Zero();
  }
}

}  // namespace smseg::frontend
