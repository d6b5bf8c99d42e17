#pragma once
// Camera motion from stereo point tracks (thesis 3.2.2, docs/design.md section 4 "Motion"), and the whole
// stereo front end: disparity -> keypoints -> matching -> tracks -> filters -> motion -> camera path.
//
// Per consecutive frame pair (t, t+1), the rigid motion M_t = (R, T) with X_{t+1} = R X_t + T maps the
// 3D points of frame t's camera onto frame t+1's. Three stages:
//
//  1. Hypotheses and inliers (the thesis method): Arun, Huang & Blostein 1987 (SVD of the 3x3
//     cross-covariance, with the reflection fix) on 3-point samples inside RANSAC; inlier threshold in
//     metres growing with depth (stereo depth error ~ Z^2), refit on the inliers.
//  2. Refinement (when the stereo camera is known, estimate_pair_motions with a StereoCamera): the 3D
//     fit weights every point alike, but a point's depth error grows with Z^2 (Z = fx B / d, and fx B
//     is only ~30 px m on the synthetic rig), so far points dominate it and the path zig-zags.
//     Instead the motion minimises the symmetric stereo reprojection error: each correspondence is
//     measured as (u, v, d) (left pixel and disparity) in both frames; frame t's point moved by M is
//     projected into frame t+1 as (u, v, d) and compared with that frame's measurement, and frame
//     t+1's point moved by M^-1 into frame t likewise (libviso2-style, both directions, so neither
//     frame's triangulation is trusted more). Residuals are in pixels, where the measurement noise
//     is roughly uniform, so near and far points get their proper weight. Levenberg-Marquardt on the
//     6 motion parameters (left-multiplied increment, rotation as a rotation vector), Huber weights
//     (RefineOptions::huber_px), starting from the RANSAC motion; then every correspondence (not only
//     the 3D inliers) whose symmetric reprojection error is under inlier_px is an inlier and the
//     motion is refined again on those, twice.
//  3. Moving objects (RefineOptions::second_hypothesis): a walking person with a striped shirt can
//     hold most of a pair's keypoints, and then the largest rigid set is the person, not the scene
//     (the corridor's worst pairs: 2-7 degrees and 10-17 cm wrong). So each pair gets up to three
//     hypotheses: the stage 1+2 motion; the same on its outliers; and, sequentially, the refinement
//     started from the previous pair's chosen motion on the correspondences it already explains
//     within 3 inlier_px. Each needs max(min_inliers, second_min_share of the points) inliers; the
//     path takes the hypothesis closest to the previous pair's chosen motion (constant velocity;
//     distance = |dt| in metres + rotation angle in radians). The first good pair takes stage 1+2.
//     Caveat: a wrong choice propagates as the next prediction until the scene dominates again.
//
// The path chains the motions:
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
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "smseg/sequence/sequence.hpp"
#include "smseg/frontend/disparity_offset.hpp"
#include "smseg/frontend/gravity.hpp"
#include "smseg/frontend/stereo.hpp"
#include "smseg/frontend/tracking.hpp"

namespace smseg::frontend {

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

/// A rectified stereo rig: (u, v, d) = (fx X/Z + cx, fy Y/Z + cy, fx B / Z).
struct StereoCamera {
  double fx = 0, fy = 0, cx = 0, cy = 0, baseline = 0;
  static StereoCamera from(const sequence::Calibration& calib);  ///< Error without fx or baseline
  Eigen::Vector3d project(const Eigen::Vector3d& X) const;  ///< (u, v, d)
  Eigen::Vector3d backproject(const Eigen::Vector3d& uvd) const;
};

struct RefineOptions {
  bool enabled = true;     ///< false: the RANSAC (Arun) motion is final
  int iterations = 15;     ///< Levenberg-Marquardt iterations per refinement
  double huber_px = 1.0;   ///< Huber threshold of the reprojection residuals, pixels
  double inlier_px = 2.0;  ///< after refinement: inlier when both directions reproject within this
  double disparity_weight = 1.0;  ///< weight of the disparity residual against u, v
  /// A second motion hypothesis per pair, from the first one's outliers (RANSAC and refinement
  /// again); the path takes, pair after pair, the hypothesis closest to the previous pair's motion
  /// (constant velocity). Guards against an independently moving object that fills the view.
  bool second_hypothesis = true;
  double second_min_share = 0.2;  ///< the second hypothesis needs this share of the pair's points as inliers
  void validate() const;  ///< Error("", "refine.<field>", reason)
};

/// Refines `initial` (X_b = R X_a + T) by minimising the symmetric stereo reprojection error of the
/// correspondences uvd_a[i] <-> uvd_b[i] (pixel and disparity in frames a and b; disparity > 0) with
/// `use[i]` set (all when empty); see the header comment. Returns the refined motion; `inliers`
/// (optional) receives, for every correspondence, whether its error is within inlier_px, and
/// `rms_px` the RMS reprojection error over those. Fewer than 3 usable correspondences: `initial`.
RigidMotion refine_motion(const RigidMotion& initial, const std::vector<Eigen::Vector3d>& uvd_a,
                          const std::vector<Eigen::Vector3d>& uvd_b, const StereoCamera& camera,
                          const RefineOptions& options, const std::vector<std::uint8_t>& use = {},
                          std::vector<std::uint8_t>* inliers = nullptr, double* rms_px = nullptr);

/// Per frame pair (t, t+1) the motion used for the path, and whether it was bridged.
struct PairMotion {
  RigidMotion motion;
  int points = 0, inliers = 0;
  bool ok = false;       ///< estimated from this pair
  bool bridged = false;  ///< !ok: previous good motion reused (or identity)
  double rms = 0;        ///< RMS 3D residual over the inliers, metres
  double rms_px = 0;     ///< RMS symmetric reprojection error over the inliers, pixels (refined only)
};

/// The first camera pose (see the world-frame assumption above).
sequence::Pose initial_pose(double camera_height);

/// Chains the pair motions (pairs.size() == frames - 1) into camera-to-world poses; bad pairs are
/// bridged in place (their motion replaced, bridged = true).
std::vector<sequence::Pose> chain_poses(std::vector<PairMotion>& pairs, double camera_height);

/// Estimates every pair's motion from tracks (observations of one track in frames t and t+1), in
/// parallel over pairs; deterministic. Frames first_frame .. first_frame + frame_count - 1; the pair
/// (first_frame + k, first_frame + k + 1) is result[k] and uses random stream first_frame + k.
std::vector<PairMotion> estimate_pair_motions(const std::vector<Track>& tracks, int first_frame, int frame_count,
                                              const RansacOptions& options);

/// The same, then each good pair's motion refined by reprojection error (stage 2) and chosen among
/// hypotheses by constant velocity (stage 3). Tracks need pixels and disparities. Deterministic: the
/// per-pair work is parallel with per-pair random streams, the choice sequential.
std::vector<PairMotion> estimate_pair_motions(const std::vector<Track>& tracks, int first_frame, int frame_count,
                                              const RansacOptions& options, const StereoCamera& camera,
                                              const RefineOptions& refine);

// ---------------------------------------------------------------------------------------------
// The front end.

/// The stereo front end's keypoints by default: Shi-Tomasi corners for its default KLT tracker.
inline TrackingOptions stereo_default_tracking() {
  TrackingOptions t;
  t.detector = default_keypoints(FrameTracker::Klt);
  return t;
}

/// The stereo front end's disparity by default: bm's matching and checks at the tracked points only (the
/// front end reads the disparity nowhere else), without a dense pass or bm's speckle filter. KITTI streams
/// 1.7x faster with it and the camera paths and forests are as good (docs/stereo.md, "Matchers").
inline StereoOptions stereo_default_stereo() {
  StereoOptions s;
  s.method = StereoMethod::Sparse;
  return s;
}

struct FrontEndOptions {
  StereoOptions stereo = stereo_default_stereo();
  TrackingOptions tracking = stereo_default_tracking();
  /// klt (the default: lower path error and better forests than the thesis's descriptor
  /// matching on the synthetic corridor, lab and KITTI; docs/stereo.md) or descriptors (the thesis)
  FrameTracker tracker = FrameTracker::Klt;
  KltOptions klt;                                    ///< used by the klt tracker
  TrackFilterOptions filters;
  RansacOptions motion;
  RefineOptions refine;                 ///< motion refinement by reprojection error (enabled by default)
  GravityOptions gravity;               ///< level first camera (default) or gravity from path and ground (gravity.hpp)
  std::optional<double> camera_height;  ///< overrides the sequence's; one of them is required
  /// Pixels added to every computed disparity: auto (the calibration's plus the self-calibrated extra
  /// from the first frames, disparity_offset.hpp), the calibration's as it is, or a number of pixels
  DisparityOffsetChoice disparity_offset;
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

/// A front end's own figures beyond the shared ones (structure from motion's: sfm_summary.hpp). The
/// front end that made them writes them: they go into tracks.json's summary under key(), the front
/// end's name; reading them back is the front end's too (summary_from_json's readers).
class SummaryPart {
 public:
  virtual ~SummaryPart() = default;
  virtual std::string_view key() const = 0;
  virtual Json to_json() const = 0;
};

/// Reads a front end's own part of a summary, by its key: an Error naming the place of a bad value.
using SummaryPartReader = std::function<std::shared_ptr<const SummaryPart>(const JsonView& part)>;
using SummaryPartReaders = std::map<std::string, SummaryPartReader, std::less<>>;

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
  std::shared_ptr<const SummaryPart> own;  ///< the front end's own figures (SfM runs), or none
  std::optional<GravityEstimate> gravity;  ///< stereo runs with GravityMethod::Estimate only
  double disparity_offset = 0;        ///< stereo: pixels added to every computed disparity (the one used)
  std::optional<OffsetEstimate> offset_estimate;  ///< stereo runs with disparity_offset auto only
};

struct FrontEndResult {
  int first_frame = 0;                 ///< sequence index of frames[0]
  std::vector<Track> tracks;           ///< after all filters; frames are sequence indices
  std::vector<sequence::Pose> poses;             ///< one per processed frame (camera-to-world)
  std::vector<PairMotion> pair_motions;  ///< one per consecutive pair of processed frames
  FrontEndSummary summary;
};

/// The summary figures both front ends share, from res.tracks and res.pair_motions over the n frames
/// from res.first_frame: valid points per frame (mean, min), track lengths (mean, median, max), bridged
/// pairs, and the motion inlier ratio (mean, min) over the pairs that are not bridged and for which
/// `counted(k)` holds (all of them when it is empty; a pair with no points counts as 0).
void summarise_tracks_and_motion(FrontEndResult& res, int n,
                                 const std::function<bool(std::size_t)>& counted = {});

/// Runs the stereo front end over the sequence. Bad input (mono sequence, missing calibration or
/// camera height, missing images) is an Error naming file and field; frames with no valid disparity
/// or no keypoints are not errors: they give no observations and bridged motion (see the summary).
FrontEndResult run_stereo_front_end(const sequence::Sequence& seq, const FrontEndOptions& options);

}  // namespace smseg::frontend
