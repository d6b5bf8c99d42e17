// The incremental reconstruction of the monocular front end (steps 3-6 of sfm.hpp) and its geometry.

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "sfm_front_end.hpp"

namespace smseg::sfm::sfm_front_end {

using namespace sfm_matching;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

double reprojection_error(const CamPose& P, const Eigen::Vector3d& X, const cv::Point2f& px, const Intrinsics& in) {
  const Eigen::Vector3d xc = P.R * X + P.t;
  if (!(xc.z() > 1e-9)) return kInf;
  const double u = in.f * xc.x() / xc.z() + in.cx, v = in.f * xc.y() / xc.z() + in.cy;
  return std::hypot(u - px.x, v - px.y);
}

double ray_angle(const Eigen::Vector3d& ra, const Eigen::Vector3d& rb) {
  return std::acos(std::clamp(ra.dot(rb) / (ra.norm() * rb.norm()), -1.0, 1.0));
}

bool triangulate(const CamPose& A, const CamPose& B, const cv::Point2f& pa, const cv::Point2f& pb,
                 const Intrinsics& in, double thr, double min_angle, Eigen::Vector3d& X) {
  const Eigen::Vector2d a((pa.x - in.cx) / in.f, (pa.y - in.cy) / in.f);
  const Eigen::Vector2d b((pb.x - in.cx) / in.f, (pb.y - in.cy) / in.f);
  Eigen::Matrix<double, 3, 4> Pa, Pb;
  Pa << A.R, A.t;
  Pb << B.R, B.t;
  Eigen::Matrix4d M;
  M.row(0) = a.x() * Pa.row(2) - Pa.row(0);
  M.row(1) = a.y() * Pa.row(2) - Pa.row(1);
  M.row(2) = b.x() * Pb.row(2) - Pb.row(0);
  M.row(3) = b.y() * Pb.row(2) - Pb.row(1);
  const Eigen::Vector4d h = Eigen::JacobiSVD<Eigen::Matrix4d>(M, Eigen::ComputeFullV).matrixV().col(3);
  if (!(std::abs(h(3)) > 1e-12)) return false;
  X = h.head<3>() / h(3);
  if (!X.allFinite()) return false;
  if (!(ray_angle(X - A.centre(), X - B.centre()) >= min_angle)) return false;
  return reprojection_error(A, X, pa, in) <= thr && reprojection_error(B, X, pb, in) <= thr;
}

bool pose_from_cv(const cv::Mat& rvec, const cv::Mat& tvec, CamPose& P) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  cv::cv2eigen(R, P.R);
  cv::cv2eigen(tvec, P.t);
  return P.R.allFinite() && P.t.allFinite();
}

// ---- 3-5. incremental reconstruction ----

void MonoFrontEnd::reconstruct() {
  point_.assign(ntracks_, Eigen::Vector3d::Zero());
  has_point_.assign(ntracks_, 0);
  point_index_.assign(ntracks_, -1);
  Progress progress("sfm", n_, options_.progress);
  find_initial_pair();
  if (init_b_ >= 0) {
    register_frames(progress);
    complete();
  } else {
    progress.tick(n_);
  }
  progress.finish();
}

/// Tracks common to frames a and b: (keypoint in a, keypoint in b).
std::vector<std::pair<int, int>> MonoFrontEnd::common(int a, int b) const {
  std::vector<std::pair<int, int>> c;
  for (int i = 0; i < n_keypoints_[a]; ++i)
    for (const auto& [f, k] : track_obs_[track_of_[a][i]])
      if (f == b) c.push_back({i, k});
  return c;
}

/// The median motion of the tracks common to frames a and b, pixels, and their number.
std::pair<double, int> MonoFrontEnd::median_motion(int a, int b) const {
  std::vector<double> mv;
  for (const auto& [i, k] : common(a, b)) mv.push_back(cv::norm(pixels_[b][k] - pixels_[a][i]));
  return std::pair<double, int>(median(mv), static_cast<int>(mv.size()));
}

/// Reprojection error of keypoint i of frame t against the point of track tr, pixels.
double MonoFrontEnd::observation_error(int t, int i, int tr) const {
  return reprojection_error(pose_[t], point_[tr], pixels_[t][i], intrinsics_);
}

/// The pose (R, tv) of the second view from the essential matrix of the correspondences (RANSAC):
/// the number of points recoverPose finds in front of both cameras, -1 without an essential matrix.
int MonoFrontEnd::relative_pose(const std::vector<cv::Point2d>& qa, const std::vector<cv::Point2d>& qb,
                                std::vector<std::uint8_t>& mask, cv::Mat& R, cv::Mat& tv) const {
  const cv::Mat E = cv::findEssentialMat(qa, qb, K_, cv::RANSAC, 0.999, 1.0, 1000, mask);
  if (E.rows != 3 || E.cols != 3) return -1;
  return cv::recoverPose(E, qa, qb, K_, R, tv, mask);
}

void MonoFrontEnd::find_initial_pair() {
  int a = 0;
  for (int b = 1; b < n_ && init_b_ < 0; ++b) {
    const auto [motion, shared] = median_motion(a, b);
    if (shared < 50) {  // the first frame's tracks died before enough motion: start later
      a = b;
      continue;
    }
    if (motion >= options_.init_motion_px) try_initial_pair(a, b);
  }
}

/// Frames a and b become the initial pair when the essential matrix poses them and enough of their
/// common tracks triangulate with a wide enough median angle.
void MonoFrontEnd::try_initial_pair(int a, int b) {
  std::vector<cv::Point2d> qa, qb;
  const auto cm = common(a, b);
  for (const auto& [i, k] : cm) {
    qa.emplace_back(pixels_[a][i].x, pixels_[a][i].y);
    qb.emplace_back(pixels_[b][k].x, pixels_[b][k].y);
  }
  std::vector<std::uint8_t> mask;
  cv::Mat R, tv;
  if (relative_pose(qa, qb, mask, R, tv) < 30) return;
  CamPose A, B;
  cv::cv2eigen(R, B.R);
  cv::cv2eigen(tv, B.t);
  const InitialPoints points = triangulate_initial(a, b, A, B, cm, mask);
  if (points.made.size() < 30 || median(points.angles) < options_.init_min_angle_deg * M_PI / 180) return;
  accept_initial_pair(a, b, A, B, points);
}

InitialPoints MonoFrontEnd::triangulate_initial(int a, int b, const CamPose& A, const CamPose& B,
                                                const std::vector<std::pair<int, int>>& cm,
                                                const std::vector<std::uint8_t>& mask) const {
  InitialPoints points;
  for (std::size_t k = 0; k < cm.size(); ++k) {
    if (!mask[k]) continue;
    Eigen::Vector3d P;
    const int ka = cm[k].first, kb = cm[k].second;
    if (!triangulate(A, B, pixels_[a][ka], pixels_[b][kb], intrinsics_, inlier_px_, 0.0, P)) continue;
    points.angles.push_back(ray_angle(P - A.centre(), P - B.centre()));
    points.made.push_back({track_of_[a][ka], P});
  }
  return points;
}

void MonoFrontEnd::accept_initial_pair(int a, int b, const CamPose& A, const CamPose& B, const InitialPoints& points) {
  init_a_ = a;
  init_b_ = b;
  pose_[a] = A;
  pose_[b] = B;
  status_[a] = status_[b] = FrameStatus::Init;
  for (std::size_t k = 0; k < points.made.size(); ++k) {
    if (points.angles[k] < min_angle_rad_) continue;
    point_[points.made[k].first] = points.made[k].second;
    has_point_[points.made[k].first] = 1;
  }
  keyframes_ = {a, b};
  adjust(keyframes_, 2, options_.ba_iterations);  // points only
}

void MonoFrontEnd::register_frames(Progress& progress) {
  report_.init_frame_a = first_frame_ + init_a_;
  report_.init_frame_b = first_frame_ + init_b_;
  // Frames inside the initial pair, then before it (backwards), by PnP.
  for (int t = init_a_ + 1; t < init_b_; ++t) pose_by_pnp(t, t - 1, pairs_[t - 1].still);
  for (int t = init_a_ - 1; t >= 0; --t) pose_by_pnp(t, t + 1, pairs_[t].still);
  progress.tick(init_b_ + 1);
  int last_kf = init_b_;
  for (int t = init_b_ + 1; t < n_; ++t) {
    progress.tick();
    if (pairs_[t - 1].still) {
      pose_[t] = pose_[t - 1];
      status_[t] = FrameStatus::Still;
      continue;
    }
    register_next_frame(t);
    if (is_new_keyframe(t, last_kf)) {
      add_keyframe(t);
      last_kf = t;
    }
  }
}

/// Frame t of the initial pair's span or before it: its still neighbour's pose, else PnP from the
/// neighbour's pose, else bridged at the neighbour's pose.
void MonoFrontEnd::pose_by_pnp(int t, int neighbour, bool still_pair) {
  if (still_pair && status_[neighbour] != FrameStatus::None) {
    pose_[t] = pose_[neighbour];
    status_[t] = FrameStatus::Still;
    return;
  }
  CamPose P;
  if (pnp(t, pose_[neighbour], P)) {
    pose_[t] = P;
    status_[t] = FrameStatus::Pnp;
  } else {
    pose_[t] = pose_[neighbour];
    status_[t] = FrameStatus::Bridged;
  }
}

void MonoFrontEnd::register_next_frame(int t) {
  CamPose P;
  // Many of the local map's candidates are wrong at 1 Hz (with them in every PnP, 47 of 0016E5_00390's
  // 68 frames were posed, against 51 without them): they join PnP only when the frame's own tracks
  // cannot pose it, and join their tracks when the pose confirms them.
  const std::vector<MapCandidate> candidates = local_map_candidates(t);
  if (pnp(t, pose_[t - 1], P) || pnp(t, pose_[t - 1], P, candidates)) {
    pose_[t] = P;
    status_[t] = FrameStatus::Pnp;
    join_confirmed(t, candidates);
  } else {
    bridge_by_essential(t);
  }
}

/// Bridge by the essential matrix to the previous frame, with the previous step's length.
void MonoFrontEnd::bridge_by_essential(int t) {
  status_[t] = FrameStatus::Bridged;
  pose_[t] = pose_[t - 1];
  std::vector<cv::Point2d> qa, qb;
  for (const auto& d : matches_[t - 1]) {
    qa.emplace_back(pixels_[t - 1][d.queryIdx].x, pixels_[t - 1][d.queryIdx].y);
    qb.emplace_back(pixels_[t][d.trainIdx].x, pixels_[t][d.trainIdx].y);
  }
  if (qa.size() < 8) return;
  std::vector<std::uint8_t> mask;
  cv::Mat R, tv;
  if (relative_pose(qa, qb, mask, R, tv) < 15) return;
  Eigen::Matrix3d R_rel;
  Eigen::Vector3d t_rel;
  cv::cv2eigen(R, R_rel);
  cv::cv2eigen(tv, t_rel);
  const double step = last_step_length(t);
  pose_[t].R = R_rel * pose_[t - 1].R;
  pose_[t].t = R_rel * pose_[t - 1].t + step * t_rel;
}

/// The last step before frame t that moved (frames bridged without motion, e.g. across textureless
/// frames, would otherwise freeze the path for good).
double MonoFrontEnd::last_step_length(int t) const {
  double step = 0;
  for (int k = t - 1; k >= 1 && step == 0; --k)
    if (status_[k] != FrameStatus::Still) step = (pose_[k].centre() - pose_[k - 1].centre()).norm();
  return step;
}

bool MonoFrontEnd::is_new_keyframe(int t, int last_kf) const {
  const auto [motion, shared] = median_motion(last_kf, t);
  const bool weak = pnp_inliers_[t] < std::max(3 * options_.min_pnp_points, pnp_inliers_[last_kf] * 2 / 5);
  return motion >= options_.keyframe_motion_px || status_[t] == FrameStatus::Bridged ||
         (weak && motion >= 2 * options_.still_motion_px) || shared < 30;
}

void MonoFrontEnd::add_keyframe(int t) {
  triangulate_new(t);
  keyframes_.push_back(t);
  const int w = std::min<int>(options_.ba_window, static_cast<int>(keyframes_.size()));
  std::vector<int> window(keyframes_.end() - w, keyframes_.end());
  adjust(window, 2, options_.ba_iterations);
  if (status_[t] == FrameStatus::Bridged) pnp_inliers_[t] = 0;
}

// PnP from the frame's tracks with 3D points and the local-map candidates; `guess` seeds the
// iterative refinement.
bool MonoFrontEnd::pnp(int t, const CamPose& guess, CamPose& out, const std::vector<MapCandidate>& candidates) {
  const PnpProblem problem = pnp_correspondences(t, candidates);
  pnp_points_[t] = static_cast<int>(problem.obj.size());
  pnp_inliers_[t] = 0;
  if (static_cast<int>(problem.obj.size()) < options_.min_pnp_points) return false;
  cv::Mat Rg, rvec, tvec;
  cv::eigen2cv(guess.R, Rg);
  cv::Rodrigues(Rg, rvec);
  cv::eigen2cv(guess.t, tvec);
  std::vector<int> inl;
  bool ok = cv::solvePnPRansac(problem.obj, problem.img, K_, cv::noArray(), rvec, tvec, false, 300,
                               static_cast<float>(inlier_px_), 0.999, inl, cv::SOLVEPNP_EPNP);
  if (!ok || static_cast<int>(inl.size()) < options_.min_pnp_points) return false;
  const int confirmed = best_pnp_pose(problem, inl, Rg, guess, rvec, tvec, out);
  const int needed = std::max(options_.min_pnp_points, static_cast<int>(0.8 * static_cast<double>(inl.size())));
  if (confirmed < needed) return false;
  pnp_inliers_[t] = confirmed;
  return true;
}

PnpProblem MonoFrontEnd::pnp_correspondences(int t, const std::vector<MapCandidate>& candidates) const {
  PnpProblem problem;
  for (int i = 0; i < n_keypoints_[t]; ++i)
    if (has_point_[track_of_[t][i]]) problem.add(point_[track_of_[t][i]], pixels_[t][i]);
  for (const auto& c : candidates) problem.add(point_[c.track], pixels_[t][c.keypoint]);
  return problem;
}

/// Sets `out` to the best of the candidate poses (below) and returns how many RANSAC inliers it explains.
int MonoFrontEnd::best_pnp_pose(const PnpProblem& problem, const std::vector<int>& inl, const cv::Mat& Rg,
                                const CamPose& guess, const cv::Mat& rvec, const cv::Mat& tvec, CamPose& out) const {
  PnpProblem inliers;
  for (int k : inl) {
    inliers.obj.push_back(problem.obj[k]);
    inliers.img.push_back(problem.img[k]);
  }
  // Candidates: the RANSAC pose (OpenCV re-estimates it by EPnP on all inliers, which can come out
  // wrong, mirrored, with many far points as on CamVid), and Levenberg-Marquardt refinements on the
  // inliers started from it and from the guess (the previous frame's pose). The one explaining the
  // most RANSAC inliers within the threshold is kept.
  PoseChoice best;
  consider(rvec, tvec, problem, inl, best);
  cv::Mat rv = rvec.clone(), tv = tvec.clone();
  cv::solvePnPRefineLM(inliers.obj, inliers.img, K_, cv::noArray(), rv, tv);
  consider(rv, tv, problem, inl, best);
  cv::Mat rg, tg;
  cv::Rodrigues(Rg, rg);
  cv::eigen2cv(guess.t, tg);
  cv::solvePnPRefineLM(inliers.obj, inliers.img, K_, cv::noArray(), rg, tg);
  consider(rg, tg, problem, inl, best);
  if (best.confirmed >= 0) out = best.pose;
  return best.confirmed;
}

/// The pose of (rv, tv) replaces the best one if it explains more of the RANSAC inliers.
void MonoFrontEnd::consider(const cv::Mat& rv, const cv::Mat& tv, const PnpProblem& problem,
                            const std::vector<int>& inl, PoseChoice& best) const {
  CamPose P;
  if (!pose_from_cv(rv, tv, P)) return;
  const int c = explained(P, problem, inl);
  if (c > best.confirmed) {
    best.confirmed = c;
    best.pose = P;
  }
}

/// How many of the RANSAC inliers the pose reprojects within the threshold.
int MonoFrontEnd::explained(const CamPose& P, const PnpProblem& problem, const std::vector<int>& inl) const {
  int c = 0;
  for (int k : inl)
    c += reprojection_error(P, Eigen::Vector3d(problem.obj[k].x, problem.obj[k].y, problem.obj[k].z),
                            cv::Point2f(static_cast<float>(problem.img[k].x), static_cast<float>(problem.img[k].y)),
                            intrinsics_) <= inlier_px_;
  return c;
}

// Local-map candidates of frame t (sfm_map.hpp): the map points of the map_window frames before it.
std::vector<MapCandidate> MonoFrontEnd::local_map_candidates(int t) const {
  std::vector<int> window;
  for (int f = std::max(0, t - options_.map_window); f < t; ++f)
    if (status_[f] != FrameStatus::None) window.push_back(f);
  if (window.empty() || descriptors_[t].empty()) return std::vector<MapCandidate>();
  const double map_ratio = options_.lowe_ratio > 0 ? options_.lowe_ratio : 0.8;
  return sfm_map::match_local_map(t, window, tracks_, has_point_, descriptors_, descriptor_norm_, map_ratio);
}

// The candidates that the frame's pose confirms join their map track (the keypoint's whole track:
// its later frames then see the point too).
void MonoFrontEnd::join_confirmed(int t, const std::vector<MapCandidate>& candidates) {
  for (const auto& c : candidates)
    if (observation_error(t, c.keypoint, c.track) <= inlier_px_)
      report_.map_joins += tracks_.merge(track_of_[t][c.keypoint], c.track);
}

// Triangulates the tracks of frame t that have no point yet, from their first posed observation.
void MonoFrontEnd::triangulate_new(int t) {
  for (int i = 0; i < n_keypoints_[t]; ++i) {
    const int tr = track_of_[t][i];
    if (has_point_[tr] || track_obs_[tr].size() < 2) continue;
    for (const auto& [f, k] : track_obs_[tr]) {
      if (f >= t) break;
      if (status_[f] == FrameStatus::None) continue;
      triangulate_track(tr, f, k, t, i);
      break;  // only the first posed observation: the widest baseline
    }
  }
}

/// Gives track tr the point triangulated from keypoint ka of frame fa and kb of fb, if it passes the checks.
bool MonoFrontEnd::triangulate_track(int tr, int fa, int ka, int fb, int kb) {
  Eigen::Vector3d P;
  if (!triangulate(pose_[fa], pose_[fb], pixels_[fa][ka], pixels_[fb][kb], intrinsics_, inlier_px_, min_angle_rad_, P))
    return false;
  point_[tr] = P;
  has_point_[tr] = 1;
  return true;
}

// Local / global bundle adjustment over the given key frames, the first n_fixed held.
void MonoFrontEnd::adjust(const std::vector<int>& frames, int n_fixed, int iterations) {
  if (iterations <= 0 || frames.empty()) return;
  const auto t0 = Clock::now();
  BaProblem p = ba_problem(frames, n_fixed);
  BaOptions bo;
  bo.iterations = iterations;
  bo.huber_px = inlier_px_;
  bundle_adjust(p.cams, p.pts, p.obs, intrinsics_.f, intrinsics_.cx, intrinsics_.cy, bo);
  for (std::size_t c = 0; c < frames.size(); ++c) {
    pose_[frames[c]].R = p.cams[c].R;
    pose_[frames[c]].t = p.cams[c].t;
  }
  for (std::size_t j = 0; j < p.pts.size(); ++j) {
    point_[p.pt_track[j]] = p.pts[j];
    point_index_[p.pt_track[j]] = -1;
  }
  seconds_ba_ += since(t0);
}

BaProblem MonoFrontEnd::ba_problem(const std::vector<int>& frames, int n_fixed) {
  BaProblem p;
  p.cams.resize(frames.size());
  for (std::size_t c = 0; c < frames.size(); ++c) {
    const int t = frames[c];
    p.cams[c].R = pose_[t].R;
    p.cams[c].t = pose_[t].t;
    p.cams[c].fixed = static_cast<int>(c) < n_fixed;
    for (int i = 0; i < n_keypoints_[t]; ++i) {
      const int tr = track_of_[t][i];
      if (!has_point_[tr]) continue;
      // Gross outliers stay out of the adjustment.
      if (observation_error(t, i, tr) > 4 * inlier_px_) continue;
      if (point_index_[tr] < 0) {
        point_index_[tr] = static_cast<int>(p.pts.size());
        p.pts.push_back(point_[tr]);
        p.pt_track.push_back(tr);
      }
      p.obs.push_back({static_cast<int>(c), point_index_[tr], Eigen::Vector2d(pixels_[t][i].x, pixels_[t][i].y)});
    }
  }
  return p;
}

// ---- 6. final adjustment, re-posing, remaining points ----

void MonoFrontEnd::complete() {
  if (options_.final_ba && keyframes_.size() >= 3) adjust(keyframes_, 2, options_.final_ba_iterations);
  std::vector<char> is_kf(n_, 0);
  for (int k : keyframes_) is_kf[k] = 1;
  repose_other_frames(is_kf);
  copy_still_poses(is_kf);
  triangulate_remaining();
}

/// The frames that are not key frames: still ones take their neighbour's pose, the others PnP again.
void MonoFrontEnd::repose_other_frames(const std::vector<char>& is_kf) {
  for (int t = 0; t < n_; ++t) {
    if (is_kf[t]) continue;
    if (status_[t] == FrameStatus::Still) {
      const int nb = t < init_a_ ? t + 1 : t - 1;
      pose_[t] = pose_[nb];
      continue;
    }
    CamPose P;
    if (pnp(t, pose_[t], P)) {
      pose_[t] = P;
      if (status_[t] == FrameStatus::Bridged) status_[t] = FrameStatus::Pnp;
    }
  }
}

// Still frames again, in order (their neighbours may have moved).
void MonoFrontEnd::copy_still_poses(const std::vector<char>& is_kf) {
  for (int t = init_a_ - 1; t >= 0; --t)
    if (status_[t] == FrameStatus::Still) pose_[t] = pose_[t + 1];
  for (int t = init_a_ + 1; t < n_; ++t)
    if (status_[t] == FrameStatus::Still && !is_kf[t]) pose_[t] = pose_[t - 1];
}

/// Tracks still without a point, from their first and last observations.
void MonoFrontEnd::triangulate_remaining() {
  for (int tr = 0; tr < ntracks_; ++tr) {
    if (has_point_[tr] || track_obs_[tr].size() < 2) continue;
    const auto& [fa, ka] = track_obs_[tr].front();
    const auto& [fb, kb] = track_obs_[tr].back();
    if (status_[fa] == FrameStatus::None || status_[fb] == FrameStatus::None) continue;
    triangulate_track(tr, fa, ka, fb, kb);
  }
}

}  // namespace smseg::sfm::sfm_front_end
