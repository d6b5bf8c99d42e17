#include "smseg/frontend/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include <Eigen/Dense>

namespace smseg::frontend {

namespace {

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  const double hi = *mid;
  const double lo = *std::max_element(v.begin(), mid);
  return 0.5 * (lo + hi);
}

double quantile_of(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(std::floor(pos));
  const std::size_t j = std::min(v.size() - 1, i + 1);
  return v[i] + (pos - static_cast<double>(i)) * (v[j] - v[i]);
}

double rotation_angle_deg(const Eigen::Matrix3d& R) {
  const double c = std::clamp((R.trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / std::numbers::pi;
}

}  // namespace

Eigen::Vector3d pose_centre(const sequence::Pose& p) { return {p.t[0], p.t[1], p.t[2]}; }

Eigen::Matrix3d pose_rotation(const sequence::Pose& p) {
  Eigen::Matrix3d R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(i, j) = p.R[3 * i + j];
  return R;
}

sequence::Pose make_pose(const Eigen::Matrix3d& R, const Eigen::Vector3d& c) {
  sequence::Pose p;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) p.R[3 * i + j] = R(i, j);
    p.t[i] = c(i);
  }
  return p;
}

Similarity3 umeyama(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                    bool with_scale) {
  if (src.size() != dst.size()) throw Error("", "points", "umeyama needs as many target points as source points");
  if (src.empty()) throw Error("", "points", "umeyama needs at least one correspondence");
  const double n = static_cast<double>(src.size());
  Eigen::Vector3d ms = Eigen::Vector3d::Zero(), md = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i) ms += src[i], md += dst[i];
  ms /= n;
  md /= n;
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();  // covariance dst x src
  double var_src = 0;
  for (std::size_t i = 0; i < src.size(); ++i) {
    S += (dst[i] - md) * (src[i] - ms).transpose();
    var_src += (src[i] - ms).squaredNorm();
  }
  S /= n;
  var_src /= n;
  Similarity3 out;
  if (S.cwiseAbs().maxCoeff() > 0) {
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Vector3d d(1, 1, 1);
    if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) d(2) = -1;
    out.R = svd.matrixU() * d.asDiagonal() * svd.matrixV().transpose();
    if (with_scale && var_src > 0) out.s = svd.singularValues().dot(d) / var_src;
    if (!out.R.allFinite() || !std::isfinite(out.s)) out.R.setIdentity(), out.s = 1;
  }
  out.t = md - out.s * (out.R * ms);
  return out;
}

double path_length(const std::vector<sequence::Pose>& poses) {
  double len = 0;
  for (std::size_t i = 1; i < poses.size(); ++i) len += (pose_centre(poses[i]) - pose_centre(poses[i - 1])).norm();
  return len;
}

PathError absolute_path_error(const std::vector<sequence::Pose>& estimate, const std::vector<sequence::Pose>& truth,
                              PathAlignment alignment) {
  if (estimate.size() != truth.size())
    throw Error("", "poses",
                "estimated path has " + std::to_string(estimate.size()) + " poses, ground truth " +
                    std::to_string(truth.size()));
  if (estimate.size() < 2) throw Error("", "poses", "the trajectory error needs at least 2 poses");
  std::vector<Eigen::Vector3d> e, g;
  for (std::size_t i = 0; i < estimate.size(); ++i) e.push_back(pose_centre(estimate[i])), g.push_back(pose_centre(truth[i]));
  PathError out;
  out.frames = static_cast<int>(e.size());
  out.alignment = umeyama(e, g, alignment == PathAlignment::Similarity);
  out.scale = out.alignment.s;
  double sse = 0;
  for (std::size_t i = 0; i < e.size(); ++i) {
    const double d = (out.alignment.apply(e[i]) - g[i]).norm();
    out.errors.push_back(d);
    sse += d * d;
    out.max_error = std::max(out.max_error, d);
  }
  out.rmse = std::sqrt(sse / static_cast<double>(e.size()));
  out.path_length = path_length(truth);
  out.relative = out.path_length > 0 ? out.rmse / out.path_length : 0;
  return out;
}

RelativeError relative_path_error(const std::vector<sequence::Pose>& estimate, const std::vector<sequence::Pose>& truth) {
  if (estimate.size() != truth.size())
    throw Error("", "poses",
                "estimated path has " + std::to_string(estimate.size()) + " poses, ground truth " +
                    std::to_string(truth.size()));
  RelativeError out;
  double st = 0, sr = 0;
  for (std::size_t i = 0; i + 1 < estimate.size(); ++i) {
    // Relative motion of camera i+1 in camera i's frame: R = Ri^T Rj, t = Ri^T (cj - ci).
    auto rel = [](const sequence::Pose& a, const sequence::Pose& b, Eigen::Matrix3d& R, Eigen::Vector3d& t) {
      const Eigen::Matrix3d Ra = pose_rotation(a);
      R = Ra.transpose() * pose_rotation(b);
      t = Ra.transpose() * (pose_centre(b) - pose_centre(a));
    };
    Eigen::Matrix3d Re, Rg;
    Eigen::Vector3d te, tg;
    rel(estimate[i], estimate[i + 1], Re, te);
    rel(truth[i], truth[i + 1], Rg, tg);
    // E = inv(rel_e) * rel_g: rotation Re^T Rg, translation Re^T (tg - te).
    const double dt = (Re.transpose() * (tg - te)).norm();
    const double dr = rotation_angle_deg(Re.transpose() * Rg);
    out.translation.push_back(dt);
    out.rotation_deg.push_back(dr);
    st += dt * dt;
    sr += dr * dr;
    out.translation_max = std::max(out.translation_max, dt);
    out.rotation_max_deg = std::max(out.rotation_max_deg, dr);
  }
  out.pairs = static_cast<int>(out.translation.size());
  if (out.pairs > 0) {
    out.translation_rmse = std::sqrt(st / out.pairs);
    out.rotation_rmse_deg = std::sqrt(sr / out.pairs);
  }
  return out;
}

DepthError tracked_depth_error(const std::vector<Track>& tracks, const std::function<cv::Mat(int)>& gt_depth) {
  // Observations grouped by frame so that each ground-truth map is loaded once.
  std::map<int, std::vector<std::pair<cv::Point2f, double>>> by_frame;
  DepthError out;
  for (const auto& tr : tracks)
    for (std::size_t k = 0; k < tr.size(); ++k) {
      ++out.observations;
      by_frame[tr.frames[k]].emplace_back(tr.pixels[k], tr.points[k].z());
    }
  std::vector<double> rel, signed_rel;
  for (const auto& [frame, list] : by_frame) {
    const cv::Mat d = gt_depth(frame);
    if (d.empty()) continue;
    if (d.type() != CV_32FC1) throw Error("", "gt_depth", "ground-truth depth must be CV_32FC1");
    for (const auto& [px, z] : list) {
      const int x = static_cast<int>(std::lround(px.x)), y = static_cast<int>(std::lround(px.y));
      if (x < 0 || y < 0 || x >= d.cols || y >= d.rows) continue;
      const double zg = d.at<float>(y, x);
      if (!(zg > 0) || !std::isfinite(zg) || !(z > 0) || !std::isfinite(z)) continue;
      signed_rel.push_back((z - zg) / zg);
      rel.push_back(std::abs(z - zg) / zg);
    }
  }
  out.evaluated = static_cast<long>(rel.size());
  if (!rel.empty()) {
    double sum = 0;
    for (double r : rel) sum += r;
    out.mean_relative = sum / static_cast<double>(rel.size());
    out.median_relative = median_of(rel);
    out.p90_relative = quantile_of(rel, 0.9);
    out.median_signed_relative = median_of(signed_rel);
  }
  return out;
}

}  // namespace smseg::frontend
