// The monocular SfM front end (see sfm.hpp for the pipeline and its decisions): its steps 1, 2 and 7
// and the result; the incremental reconstruction is in sfm_reconstruction.cpp.

#include "smseg/sfm/sfm.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/video/tracking.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "smseg/common/progress.hpp"
#include "smseg/frontend/trajectory.hpp"
#include "sfm_front_end.hpp"
#include "sfm_map.hpp"
#include "sfm_matching.hpp"

namespace smseg::sfm {

namespace sfm_front_end {

using namespace sfm_matching;

namespace {

constexpr int kChunk = 32;  // frames detected before their pairs are matched

double mean(const std::vector<double>& v, int denom) {
  return denom > 0 ? std::accumulate(v.begin(), v.end(), 0.0) / denom : 0.0;
}

}  // namespace

MonoFrontEnd::MonoFrontEnd(const sequence::Sequence& seq, const SfmOptions& options, Clock::time_point wall0)
    : seq_(seq), options_(options), wall_start_(wall0) {
  const std::string manifest = seq.manifest.string();
  if (options_.tracker == SfmTracker::Descriptors && options_.tracking.detector == frontend::KeypointMethod::Gftt)
    throw Error(manifest, "tracking.detector",
                "gftt corners have no descriptors, and this sequence's frames call for descriptor matching; use "
                "--tracker klt or another detector");
  const std::optional<double> height = options_.camera_height ? options_.camera_height : seq.camera_height;
  if (!height)
    throw Error(manifest, "camera_height",
                "monocular SfM takes its metric scale from the camera height (give it in the manifest or as an "
                "option)");
  height_ = *height;
  first_frame_ = options_.first_frame;
  n_ = seq.range_end(first_frame_, options_.last_frame) - first_frame_;
  descriptor_norm_ = frontend::descriptor_norm(options_.tracking.detector);
  report_.tracker = options_.tracker;
  const int n_pairs = std::max(0, n_ - 1);
  pixels_.resize(n_);
  matches_.resize(n_pairs);
  pairs_.resize(n_pairs);
  seconds_keypoints_.assign(n_, 0.0);
  seconds_matching_.assign(n_pairs, 0.0);
  descriptors_.resize(n_);
  pose_.resize(n_);
  status_.assign(n_, FrameStatus::None);
  pnp_points_.assign(n_, 0);
  pnp_inliers_.assign(n_, 0);
}

frontend::FrontEndResult MonoFrontEnd::run() {
  if (options_.tracker == SfmTracker::Klt)
    track_klt();
  else
    match_descriptors();
  chain_tracks();
  sfm_start_ = Clock::now();
  choose_focal_length();
  reconstruct();
  filter_observations();
  count_frames_and_points();
  place_in_world();
  return assemble_result();
}

// ---- 1. keypoints, matches, geometric verification (parallel per frame / pair) ----

void MonoFrontEnd::track_klt() {
  // Detection in parallel (positions only), then sequential KLT propagation.
  const std::vector<std::vector<cv::Point2f>> detected = detect_positions();
  Progress progress("sfm tracking", n_, options_.progress);
  cv::Mat prev_img;
  for (int t = 0; t < n_; ++t) {
    const cv::Mat img = seq_.load_left_gray(first_frame_ + t);
    const auto t0 = Clock::now();
    std::vector<cv::DMatch> m;
    pixels_[t] = frontend::klt_step(prev_img, t > 0 ? pixels_[t - 1] : std::vector<cv::Point2f>(), img, detected[t],
                          options_.tracking.max_keypoints, options_.klt, m);
    if (t > 0) {
      pairs_[t - 1] = verify_pair(m, pixels_[t - 1], pixels_[t], options_);
      matches_[t - 1] = std::move(m);
      seconds_matching_[t - 1] = since(t0);
    }
    prev_img = img;
    progress.tick();
  }
  progress.finish();
}

std::vector<std::vector<cv::Point2f>> MonoFrontEnd::detect_positions() {
  std::vector<std::vector<cv::Point2f>> detected(n_);
  Progress progress("sfm keypoints", n_, options_.progress);
  tbb::parallel_for(tbb::blocked_range<int>(0, n_, 1), [this, &detected, &progress](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i) {
      detect_frame(i, detected[i]);
      progress.tick();
    }
  });
  progress.finish();
  return detected;
}

// Descriptors: frames detected kChunk at a time (in parallel), then the chunk's pairs matched (in parallel)
// with the pair that joins it to the chunk before.
void MonoFrontEnd::match_descriptors() {
  Progress progress("sfm keypoints", n_, options_.progress);
  for (int c0 = 0; c0 < n_; c0 += kChunk) {
    const int c1 = std::min(n_, c0 + kChunk);
    detect_with_descriptors(c0, c1, progress);
    if (c0 > 0) match_pair(c0 - 1);
    tbb::parallel_for(tbb::blocked_range<int>(c0, c1 - 1, 1), [this](const tbb::blocked_range<int>& r) {
      for (int t = r.begin(); t < r.end(); ++t) match_pair(t);
    });
  }
  progress.finish();
}

void MonoFrontEnd::detect_with_descriptors(int c0, int c1, Progress& progress) {
  tbb::parallel_for(tbb::blocked_range<int>(c0, c1, 1), [this, &progress](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i) {
      descriptors_[i] = detect_frame(i, pixels_[i]).descriptors;
      progress.tick();
    }
  });
}

/// Detects frame i's keypoints, appending their positions; times the detection.
frontend::FrameKeypoints MonoFrontEnd::detect_frame(int i, std::vector<cv::Point2f>& positions) {
  const auto t0 = Clock::now();
  frontend::FrameKeypoints kp = frontend::detect_keypoints(seq_.load_left_gray(first_frame_ + i), options_.tracking);
  for (const auto& k : kp.keypoints) positions.push_back(k.pt);
  seconds_keypoints_[i] = since(t0);
  return kp;
}

/// Matches the descriptors of frames t and t + 1 and verifies the matches.
void MonoFrontEnd::match_pair(int t) {
  const SfmOptions& o = options_;
  const int norm = descriptor_norm_;
  const cv::Mat& a = descriptors_[t];
  const cv::Mat& b = descriptors_[t + 1];
  const auto t0 = Clock::now();
  std::vector<cv::DMatch> m =
      o.match_radius_px > 0 ? match_gated(a, pixels_[t], b, pixels_[t + 1], norm, o.match_radius_px, o.lowe_ratio)
      : o.lowe_ratio > 0    ? match_ratio(a, b, norm, o.lowe_ratio)
                            : frontend::match_symmetric(a, b, norm);
  frontend::drop_far_matches(m, pixels_[t], pixels_[t + 1], o.tracking);
  pairs_[t] = verify_pair(m, pixels_[t], pixels_[t + 1], o);
  if (o.epipolar_ratio > 0 && pairs_[t].has_f) {
    // Guided matching along the verified pair's epipolar lines, then verified again (the
    // fundamental matrix is re-estimated from the larger set).
    m = match_epipolar(a, pixels_[t], b, pixels_[t + 1], pairs_[t].F, norm, o.fundamental_threshold_px,
                       o.epipolar_ratio);
    frontend::drop_far_matches(m, pixels_[t], pixels_[t + 1], o.tracking);
    pairs_[t] = verify_pair(m, pixels_[t], pixels_[t + 1], o);
  }
  matches_[t] = std::move(m);
  seconds_matching_[t] = since(t0);
}

void MonoFrontEnd::chain_tracks() {
  n_keypoints_.resize(n_);
  for (int i = 0; i < n_; ++i) {
    n_keypoints_[i] = static_cast<int>(pixels_[i].size());
    total_keypoints_ += n_keypoints_[i];
  }
  tracks_.tid = frontend::chain_matches(n_keypoints_, matches_, &ntracks_);
  tracks_.tobs.resize(ntracks_);
  for (int t = 0; t < n_; ++t)
    for (int i = 0; i < n_keypoints_[t]; ++i) tracks_.tobs[track_of_[t][i]].push_back({t, i});
}

// ---- 2. focal length ----

void MonoFrontEnd::choose_focal_length() {
  const sequence::Calibration camera = sfm_camera(seq_, 1);  // its principal point; the focal is found below
  intrinsics_.cx = camera.cx;
  intrinsics_.cy = camera.cy;
  if (options_.focal) {
    intrinsics_.f = *options_.focal;
    report_.focal_source = FocalSource::Option;
  } else if (seq_.calibration.fx && *seq_.calibration.fx > 0) {
    intrinsics_.f = *seq_.calibration.fx;
    report_.focal_source = FocalSource::Manifest;
  } else {
    self_calibrate();
  }
  report_.focal = intrinsics_.f;
  K_ = intrinsics_.K();
  inlier_px_ = options_.reprojection_threshold_px;
  min_angle_rad_ = options_.min_triangulation_angle_deg * M_PI / 180;
}

void MonoFrontEnd::self_calibrate() {
  const auto f = estimate_focal_from_fundamentals(focal_fundamentals(), seq_.size, &report_.focal_pairs);
  if (f) {
    intrinsics_.f = *f;
    report_.focal_source = FocalSource::Estimated;
  } else {
    intrinsics_.f = seq_.size.width;
    report_.focal_source = FocalSource::Fallback;
  }
}

std::vector<cv::Matx33d> MonoFrontEnd::focal_fundamentals() const {
  // Fundamental matrices between frames a and b up to 30 frames later that share >= 50 tracks and
  // moved >= 10 px (median), sampled along the sequence, plus every consecutive verified pair.
  std::vector<cv::Matx33d> Fs;
  for (const auto& p : pairs_)
    if (p.has_f && p.median_motion >= 10) Fs.push_back(p.F);
  const int step = std::max(1, n_ / 40);
  for (int a = 0; a + 1 < n_; a += step) {
    std::vector<cv::Point2f> best_a, best_b;
    moving_pair_from(a, best_a, best_b);
    if (best_a.size() < 50) continue;
    std::vector<std::uint8_t> mask;
    const cv::Mat F =
        cv::findFundamentalMat(best_a, best_b, cv::FM_RANSAC, options_.fundamental_threshold_px, 0.999, 2000, mask);
    if (F.rows == 3 && F.cols == 3 && cv::countNonZero(mask) >= 30) Fs.push_back(cv::Matx33d(F.ptr<double>()));
  }
  return Fs;
}

/// The common tracks' keypoints in a and b for the last frame b of the run of frames after a (up to 30)
/// sharing >= 50 tracks with it whose median motion from a is >= 10 px; left empty if none.
void MonoFrontEnd::moving_pair_from(int a, std::vector<cv::Point2f>& best_a, std::vector<cv::Point2f>& best_b) const {
  for (int b = a + 1; b < std::min(n_, a + 31); ++b) {
    std::vector<cv::Point2f> qa, qb;
    std::vector<double> mv;
    for (const auto& [i, k] : common(a, b)) {
      qa.push_back(pixels_[a][i]);
      qb.push_back(pixels_[b][k]);
      mv.push_back(cv::norm(pixels_[b][k] - pixels_[a][i]));
    }
    if (qa.size() < 50) break;
    if (median(mv) >= 10) {
      best_a = std::move(qa);
      best_b = std::move(qb);
    }
  }
}

// ---- Final observation filter ----

void MonoFrontEnd::filter_observations() {
  keep_.resize(n_);
  double sq = 0;
  long kept = 0;
  keep_reprojected(sq, kept);
  drop_lone_points(sq, kept);
  report_.observations = kept;
  report_.reprojection_rms_px = kept > 0 ? std::sqrt(std::max(0.0, sq) / static_cast<double>(kept)) : 0;
}

/// Keeps the observations of posed frames that their point reprojects within the threshold; sums their
/// squared errors.
void MonoFrontEnd::keep_reprojected(double& sq, long& kept) {
  for (int t = 0; t < n_; ++t) {
    keep_[t].assign(n_keypoints_[t], 0);
    if (status_[t] == FrameStatus::None) continue;
    for (int i = 0; i < n_keypoints_[t]; ++i) {
      const int tr = track_of_[t][i];
      if (!has_point_[tr]) continue;
      const double e = observation_error(t, i, tr);
      if (e <= inlier_px_) {
        keep_[t][i] = 1;
        sq += e * e;
        ++kept;
      }
    }
  }
}

// A track needs at least two kept observations to count as a 3D point.
void MonoFrontEnd::drop_lone_points(double& sq, long& kept) {
  for (int tr = 0; tr < ntracks_; ++tr) {
    if (!has_point_[tr]) continue;
    int k = 0;
    for (const auto& [f, i] : track_obs_[tr]) k += keep_[f][i];
    if (k >= 2) continue;
    for (const auto& [f, i] : track_obs_[tr])
      if (keep_[f][i]) {
        const double e = observation_error(f, i, tr);
        sq -= e * e;
        --kept;
        keep_[f][i] = 0;
      }
    has_point_[tr] = 0;
  }
}

void MonoFrontEnd::count_frames_and_points() {
  report_.points_3d = std::count(has_point_.begin(), has_point_.end(), 1);
  report_.keyframes = static_cast<int>(keyframes_.size());
  for (auto s : status_) {
    report_.still_frames += s == FrameStatus::Still;
    report_.pnp_frames += s == FrameStatus::Pnp;
    report_.bridged_frames += s == FrameStatus::Bridged || s == FrameStatus::None;
  }
}

// ---- 7. ground plane, metric scale, world frame ----

void MonoFrontEnd::place_in_world() {
  if (init_b_ >= 0)
    level_on_ground();
  else
    stand_at_first_pose();
  report_.scale = scale_;
}

void MonoFrontEnd::level_on_ground() {
  const Eigen::Vector3d up = mean_up();
  std::vector<Eigen::Vector3d> cand;
  std::vector<double> below;
  collect_ground_candidates(cand, below);
  report_.ground_candidates = static_cast<int>(cand.size());
  const double h_typ = median(below);
  const frontend::PlaneFit plane = frontend::fit_ground_plane(cand, up, options_.ground_threshold * h_typ, options_.ground_max_tilt_deg,
                                          options_.ground_iterations, options_.seed, options_.ground_min_inliers);
  Eigen::Vector3d n_up = up;
  double d = 0;
  if (plane.ok) {
    n_up = plane.normal;
    d = plane.d;
    report_.ground_inliers = plane.inliers;
    std::vector<double> hs;
    for (int t = 0; t < n_; ++t)
      if (status_[t] != FrameStatus::None) hs.push_back(n_up.dot(pose_[t].centre()) + d);
    const double h = median(hs);
    if (h > 0) scale_ = height_ / h;
  } else if (cand.size() >= 5 && h_typ > 0) {
    // No plane to trust: the candidates' median depth below the cameras stands for the camera height.
    d = -n_up.dot(pose_[0].centre()) + h_typ;
    scale_ = height_ / h_typ;
  } else {
    // Nothing below the cameras: keep the reconstruction's scale, the ground one unit below the first
    // camera.
    d = -n_up.dot(pose_[0].centre()) + 1.0;
    scale_ = height_;
  }
  report_.ground_normal = n_up;
  set_world_axes(n_up, d);
}

/// The mean of the posed cameras' up directions (camera -y in the world), unit.
Eigen::Vector3d MonoFrontEnd::mean_up() const {
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (int t = 0; t < n_; ++t)
    if (status_[t] != FrameStatus::None) up += -pose_[t].R.transpose().col(1);  // camera -y in the world
  up.normalize();
  return up;
}

// Only well-triangulated points: the rays of the first and last kept observations must be at
// least ground_min_angle_deg apart (depth errors of far points would bias the plane).
bool MonoFrontEnd::well_triangulated(int tr) const {
  int fa = -1, fb = -1;
  for (const auto& [f, i] : track_obs_[tr])
    if (keep_[f][i]) {
      if (fa < 0) fa = f;
      fb = f;
    }
  if (fa < 0) return false;
  const double angle = ray_angle(point_[tr] - pose_[fa].centre(), point_[tr] - pose_[fb].centre());
  return !(angle < options_.ground_min_angle_deg * M_PI / 180);
}

/// The well-triangulated points that their first kept observation sees low in the image, in front of
/// the camera and below it, and how far below.
void MonoFrontEnd::collect_ground_candidates(std::vector<Eigen::Vector3d>& cand, std::vector<double>& below) const {
  for (int tr = 0; tr < ntracks_; ++tr) {
    if (!has_point_[tr] || !well_triangulated(tr)) continue;
    for (const auto& [f, i] : track_obs_[tr]) {
      if (!keep_[f][i]) continue;
      const Eigen::Vector3d xc = pose_[f].R * point_[tr] + pose_[f].t;
      const Eigen::Vector3d c_up = -pose_[f].R.transpose().col(1);
      const double h = (pose_[f].centre() - point_[tr]).dot(c_up);
      if (pixels_[f][i].y > intrinsics_.cy + options_.ground_min_row_share * seq_.size.height && xc.z() > 0 && h > 0) {
        cand.push_back(point_[tr]);
        below.push_back(h);
      }
      break;
    }
  }
}

/// World Y along n_up, Z along the first camera's viewing direction levelled, the origin on the ground
/// plane n_up . x + d = 0 under the first camera.
void MonoFrontEnd::set_world_axes(const Eigen::Vector3d& n_up, double d) {
  const Eigen::Vector3d c0 = pose_[0].centre();
  origin_ = c0 - (n_up.dot(c0) + d) * n_up;
  Eigen::Vector3d z = pose_[0].R.transpose().col(2);
  z -= z.dot(n_up) * n_up;
  if (!(z.norm() > 1e-6)) z = Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ().dot(n_up) * n_up;
  z.normalize();
  world_axes_.row(1) = n_up.transpose();
  world_axes_.row(2) = z.transpose();
  world_axes_.row(0) = n_up.cross(z).transpose();
}

// Never initialised: every frame at the first pose of the stereo convention.
void MonoFrontEnd::stand_at_first_pose() {
  const sequence::Pose p0 = frontend::initial_pose(height_);
  Eigen::Matrix3d R0;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) R0(r, k) = p0.R[3 * r + k];
  for (auto& p : pose_) {
    p.R = R0.transpose();
    p.t = Eigen::Vector3d::Zero();
  }
  world_axes_ = Eigen::Matrix3d::Identity();
  origin_ = Eigen::Vector3d(0, -height_, 0);
  scale_ = 1;
}

// ---- output ----

frontend::FrontEndResult MonoFrontEnd::assemble_result() {
  frontend::FrontEndResult res;
  res.first_frame = first_frame_;
  res.poses.resize(n_);
  for (int t = 0; t < n_; ++t) res.poses[t] = frontend::make_pose(world_rotation(t), world_centre(t));
  frontend::FilterCounts fc;
  res.tracks = frontend::build_tracks(frame_observations(), matches_, options_.filters, fc);
  for (auto& tr : res.tracks)
    for (int& f : tr.frames) f += first_frame_;
  fill_pair_motions(res);
  const double t_sfm = since(sfm_start_);
  summarise(res, fc, t_sfm);
  return res;
}

/// Camera-to-world rotation of frame t.
Eigen::Matrix3d MonoFrontEnd::world_rotation(int t) const { return world_axes_ * pose_[t].R.transpose(); }

/// Camera centre of frame t in the world, metres.
Eigen::Vector3d MonoFrontEnd::world_centre(int t) const { return scale_ * world_axes_ * (pose_[t].centre() - origin_); }

/// Per frame its keypoints, their labels (labelled frames) and, where kept, their 3D points in the
/// camera (metres) and inverse depths.
std::vector<frontend::FrameObservations> MonoFrontEnd::frame_observations() const {
  std::vector<frontend::FrameObservations> fobs(n_);
  for (int t = 0; t < n_; ++t) {
    auto& fo = fobs[t];
    fo.pixels = pixels_[t];
    fo.disparities.assign(n_keypoints_[t], frontend::kInvalidDisparity);
    fo.points.assign(n_keypoints_[t], Eigen::Vector3d::Zero());
    const cv::Mat labels = seq_.is_labelled(first_frame_ + t) ? seq_.load_labels(first_frame_ + t) : cv::Mat();
    if (!labels.empty()) fo.labels.assign(n_keypoints_[t], -1);
    for (int i = 0; i < n_keypoints_[t]; ++i) {
      if (!labels.empty()) {
        const int x = std::clamp(static_cast<int>(std::lround(pixels_[t][i].x)), 0, labels.cols - 1);
        const int y = std::clamp(static_cast<int>(std::lround(pixels_[t][i].y)), 0, labels.rows - 1);
        const std::uint8_t l = labels.at<std::uint8_t>(y, x);
        fo.labels[i] = l == sequence::kVoid ? -1 : l;
      }
      if (!keep_[t][i] || !has_point_[track_of_[t][i]]) continue;
      const Eigen::Vector3d xc = scale_ * (pose_[t].R * point_[track_of_[t][i]] + pose_[t].t);
      fo.points[i] = xc;
      fo.disparities[i] = static_cast<float>(1.0 / xc.z());
    }
  }
  return fobs;
}

void MonoFrontEnd::fill_pair_motions(frontend::FrontEndResult& res) const {
  res.pair_motions.resize(std::max(0, n_ - 1));
  for (int t = 0; t + 1 < n_; ++t) {
    auto& pm = res.pair_motions[t];
    const Eigen::Matrix3d Ra = world_rotation(t), Rb = world_rotation(t + 1);
    const Eigen::Vector3d ca = world_centre(t), cb = world_centre(t + 1);
    pm.motion.R = Rb.transpose() * Ra;
    pm.motion.t = Rb.transpose() * (ca - cb);
    pm.points = pnp_points_[t + 1];
    pm.inliers = pnp_inliers_[t + 1];
    pm.bridged = status_[t + 1] == FrameStatus::Bridged || status_[t + 1] == FrameStatus::None;
    pm.ok = !pm.bridged;
  }
}

// Summary (as the stereo front end's).
void MonoFrontEnd::summarise(frontend::FrontEndResult& res, const frontend::FilterCounts& fc, double t_sfm) {
  frontend::FrontEndSummary& s = res.summary;
  s.frames = n_;
  s.keypoints = total_keypoints_;
  s.filters = fc;
  frontend::summarise_tracks_and_motion(res, n_, [this, &res](std::size_t k) {
    return status_[k + 1] != FrameStatus::Still && res.pair_motions[k].points > 0;
  });
  s.seconds.keypoints = mean(seconds_keypoints_, n_);
  s.seconds.matching = mean(seconds_matching_, n_);
  s.seconds.motion = n_ > 0 ? t_sfm / n_ : 0;
  s.seconds.total_wall = since(wall_start_);
  report_.seconds_sfm = s.seconds.motion;
  report_.seconds_ba = n_ > 0 ? seconds_ba_ / n_ : 0;
  s.own = std::make_shared<SfmSummary>(sfm_summary(report_));
}

}  // namespace sfm_front_end

sequence::Calibration sfm_camera(const sequence::Sequence& seq, double focal) {
  sequence::Calibration c = seq.calibration;
  c.fx = c.fy = focal;
  if (c.cx == 0 && c.cy == 0) {
    c.cx = (seq.size.width - 1) / 2.0;
    c.cy = (seq.size.height - 1) / 2.0;
  }
  return c;
}

frontend::FrontEndResult run_mono_front_end(const sequence::Sequence& seq, const SfmOptions& options, SfmReport* report_out) {
  const auto wall0 = sfm_front_end::Clock::now();
  options.validate();
  sfm_front_end::MonoFrontEnd front_end(seq, resolve_tracker(options, seq), wall0);
  frontend::FrontEndResult res = front_end.run();
  if (report_out) *report_out = front_end.report();
  return res;
}

}  // namespace smseg::sfm
