#pragma once
// Camera motion from stereo point tracks (thesis 3.2.2, DESIGN section 4 "Motion"), and the whole
// stereo front end: disparity -> keypoints -> matching -> tracks -> filters -> motion -> camera path.
//
// Per consecutive frame pair (t, t+1), the rigid motion M_t = (R, T) with X_{t+1} = R X_t + T maps the
// 3D points of frame t's camera onto frame t+1's (Arun, Huang & Blostein 1987: SVD of the 3x3
// cross-covariance, with the reflection fix), inside RANSAC (3-point samples, inlier threshold in
// metres growing with depth, refit on the inliers). The path chains the motions:
//   R_{t+1} = R_t R^T,  c_{t+1} = c_t - R_{t+1} T     (camera-to-world R, camera centre c).
// A pair with too few points or inliers is a bad pair: it is reported and bridged with the previous
// good motion (constant velocity; identity before any good pair), and the path recovers at the next
// good pair.
//
// World frame: Y up, origin on the ground under the first camera. ASSUMPTION: the first camera is
// level, its y axis pointing straight down and its optical axis horizontal; its centre is at
// (0, camera_height, 0), looking along world +Z, so its x axis (right) is world -X:
// R_0 = diag(-1, -1, 1). (This is the synthetic generator's convention for a camera heading +Z.)

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "smseg/features/sequence.hpp"
#include "smseg/features/stereo.hpp"
#include "smseg/features/tracking.hpp"

namespace smseg::features {

/// X' = R X + t.
struct RigidMotion {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Vector3d apply(const Eigen::Vector3d& x) const { return R * x + t; }
};

/// Least-squares rigid motion mapping p[i] onto q[i] (Arun et al. 1987), a proper rotation (det +1).
/// Needs p.size() == q.size() >= 1 (Error otherwise); degenerate sets (fewer than 3 points,
/// collinear) give a rotation that fits them exactly but is not unique. Never NaN for finite input.
RigidMotion fit_rigid(const std::vector<Eigen::Vector3d>& p, const std::vector<Eigen::Vector3d>& q);

struct RansacOptions {
  int max_iterations = 300;          ///< upper bound on 3-point samples
  double confidence = 0.999;         ///< adaptive stop once this sure of an all-inlier sample
  double inlier_threshold = 0.03;    ///< metres, at depth <= reference_depth
  double reference_depth = 1.0;      ///< metres
  double depth_exponent = 2.0;       ///< threshold * max(1, Z/reference_depth)^exponent (stereo error ~ Z^2)
  int min_inliers = 8;               ///< fewer: the pair is bad
  double min_inlier_ratio = 0.3;     ///< lower inliers/points: the pair is bad
  std::uint64_t seed = 1;            ///< combined with the pair index: one generator per pair
  void validate() const;             ///< Error("", "motion.<field>", reason)
};

struct MotionEstimate {
  RigidMotion motion;
  int points = 0;    ///< correspondences offered
  int inliers = 0;
  bool ok = false;   ///< enough points and inliers
  double rms = 0;    ///< RMS residual over the inliers, metres
  std::vector<std::uint8_t> inlier_mask;  ///< one per correspondence
};

/// RANSAC around fit_rigid for p[i] -> q[i]; the per-point threshold uses p[i].z() as depth.
/// `stream` selects the random stream (the frame pair index), so results do not depend on threads.
MotionEstimate estimate_motion(const std::vector<Eigen::Vector3d>& p, const std::vector<Eigen::Vector3d>& q,
                               const RansacOptions& options, std::uint64_t stream);

/// Per frame pair (t, t+1) the motion used for the path, and whether it was bridged.
struct PairMotion {
  RigidMotion motion;
  int points = 0, inliers = 0;
  bool ok = false;       ///< estimated from this pair
  bool bridged = false;  ///< !ok: previous good motion reused (or identity)
  double rms = 0;
};

/// The first camera pose (see the world-frame assumption above).
Pose initial_pose(double camera_height);

/// Chains the pair motions (pairs.size() == frames - 1) into camera-to-world poses; bad pairs are
/// bridged in place (their motion replaced, bridged = true).
std::vector<Pose> chain_poses(std::vector<PairMotion>& pairs, double camera_height);

/// Estimates every pair's motion from tracks (observations of one track in frames t and t+1), in
/// parallel over pairs; deterministic. Frames first_frame .. first_frame + frame_count - 1; the pair
/// (first_frame + k, first_frame + k + 1) is result[k] and uses random stream first_frame + k.
std::vector<PairMotion> estimate_pair_motions(const std::vector<Track>& tracks, int first_frame, int frame_count,
                                              const RansacOptions& options);

// ---------------------------------------------------------------------------------------------
// The front end.

struct FrontEndOptions {
  StereoOptions stereo;
  TrackingOptions tracking;
  TrackFilterOptions filters;
  RansacOptions motion;
  std::optional<double> camera_height;  ///< overrides the sequence's; one of them is required
  int first_frame = 0;                   ///< frames [first_frame, last_frame) are processed
  int last_frame = -1;                   ///< -1: to the end
  bool progress = true;                  ///< smseg::Progress on stderr
  /// Called after each frame's per-frame stage (frames done, total); may be called from any thread.
  std::function<void(int, int)> on_frame;
  void validate() const;
};

struct StageSeconds {
  double disparity = 0, keypoints = 0, matching = 0, tracks = 0, motion = 0;  ///< per frame, mean
  double total_wall = 0;  ///< wall-clock seconds of the whole run
};

struct FrontEndSummary {
  int frames = 0;
  long keypoints = 0;                 ///< detected, all frames
  FilterCounts filters;
  double valid_points_per_frame_mean = 0;  ///< observations kept per frame (after all filters)
  int valid_points_per_frame_min = 0;
  double track_length_mean = 0;
  int track_length_median = 0, track_length_max = 0;
  double inlier_ratio_mean = 0;       ///< over good pairs
  double inlier_ratio_min = 0;
  int bad_pairs = 0;
  std::vector<int> bridged_pairs;     ///< t of each bridged pair (t, t+1)
  StageSeconds seconds;
};

struct FrontEndResult {
  int first_frame = 0;                 ///< sequence index of frames[0]
  std::vector<Track> tracks;           ///< after all filters; frames are sequence indices
  std::vector<Pose> poses;             ///< one per processed frame (camera-to-world)
  std::vector<PairMotion> pair_motions;  ///< one per consecutive pair of processed frames
  FrontEndSummary summary;
};

/// Runs the stereo front end over the sequence. Bad input (mono sequence, missing calibration or
/// camera height, missing images) is an Error naming file and field; frames with no valid disparity
/// or no keypoints are not errors: they give no observations and bridged motion (see the summary).
FrontEndResult run_stereo_front_end(const Sequence& seq, const FrontEndOptions& options);

}  // namespace smseg::features
