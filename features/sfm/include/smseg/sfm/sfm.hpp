#pragma once
// Monocular structure from motion (thesis 3.2.6, Brostow et al. 2008's input; docs/design.md section 4
// "Monocular SfM"): the same FrontEndResult as the stereo front end, from the left images alone.
//
// The pipeline (run_mono_front_end):
//   1. Keypoints per frame (tracking.hpp's detect_keypoints, SIFT by default), symmetric nearest-
//      neighbour matches between consecutive frames, gated to candidates within match_radius_px (the
//      gate removes most ambiguity of repetitive texture; 0 = whole image, match_symmetric, for wide
//      baselines such as CamVid's 1 Hz runs, optionally with Lowe's ratio test), each pair verified
//      geometrically by a fundamental-matrix RANSAC (seeded, focal independent); with the descriptor
//      tracker the pair is then matched again along its epipolar lines (epipolar_ratio;
//      sfm_matching.hpp, match_epipolar) and verified again. Chains of matches are tracks (chain_matches).
//   2. Focal length: the option if given, else the manifest's fx, else estimated from the sequence by
//      Mendonca & Cipolla's self-calibration (1999): with the principal point at the image centre,
//      square pixels and zero skew, E = K^T F K must have two equal singular values; the focal that
//      minimises sum over frame pairs of (s1 - s2) / (s1 + s2) on a log-spaced grid of
//      [0.3, 4] x image width, then refined by golden-section search. Pairs that do not constrain f
//      (pure translation, too little motion) give flat costs and are skipped. The value used and its
//      source are reported.
//   3. Still camera: when the median motion of the matched keypoints between a frame and the previous
//      one is below still_motion_px the camera is taken to stand still and the previous pose is reused.
//   4. Initial pair: the first frame and the first later frame whose median keypoint motion from it is
//      at least init_motion_px; relative pose from the essential matrix (findEssentialMat RANSAC +
//      recoverPose), triangulation of the common tracks, accepted when the median triangulation angle is
//      at least init_min_angle_deg (else the next frame is tried).
//   5. Every later frame: pose from 2D-3D matches (its tracks with a 3D point; when they cannot pose
//      it, with the descriptor tracker, also its other keypoints matched to the 3D points of the last
//      map_window frames, sfm_map.hpp; the matches the pose confirms join those points' tracks either
//      way), by solvePnPRansac (EPnP inside; of its pose and the Levenberg-Marquardt refinements on
//      the inliers started from it and from the previous frame's pose, the one explaining most
//      inliers: OpenCV's final EPnP on all inliers can come out mirrored with many far points, as on
//      CamVid). A frame becomes a key frame when the median motion of its tracks since
//      the last key frame exceeds keyframe_motion_px; at key frames new tracks are triangulated between
//      their first posed observation and the key frame (angle >= min_triangulation_angle_deg, positive
//      depth, reprojection error below reprojection_threshold_px in both views) and a local bundle
//      adjustment refines the last ba_window key frames and their points (the two oldest key frames of
//      the window held fixed: the gauge, scale included). If PnP fails, the frame is bridged by the
//      essential matrix to the previous frame, its translation as long as the last step that moved.
//      Bundle adjustment is bundle_adjust (Ceres, below).
//   6. At the end, an optional global bundle adjustment over every key frame (the first two fixed),
//      then motion-only refinement of the other frames; tracks that still have no 3D point are
//      triangulated from their widest-angle pair of posed observations; observations reprojecting
//      worse than reprojection_threshold_px are dropped.
//   7. Scale and world frame: a plane is fitted by RANSAC (seeded) to the points below the cameras
//      (in the lower part of the image, below the optical centre), its normal within
//      ground_max_tilt_deg of the mean camera "up", with at least ground_min_inliers inliers; the
//      reconstruction is scaled so that the median camera height above the plane is camera_height
//      (without a plane: the median height of the cameras over the candidates, along the mean "up"), and rotated so that the plane normal is world
//      +Y, the first camera's optical axis projected on the plane is world +Z, and the origin is the
//      first camera centre's foot on the plane (docs/design.md 3.2).
//
// Output: FrontEndResult as run_stereo_front_end gives it, the summary's own part an SfmSummary
// (sfm_summary.hpp). Per observation, `points` is the track's
// 3D point in that frame's camera (metres); `disparities` holds the inverse depth 1/Z in 1/metres (mono
// has no stereo disparity; it is > 0 exactly where the observation has a 3D point). The filter counts
// reuse the stereo names: "no disparity" means "no (consistent) 3D point". pair_motions are derived from
// the poses (X_{t+1} = R X_t + t); points/inliers are the PnP correspondences of frame t+1; `bridged`
// marks frames posed by the essential-matrix fallback or not posed at all.
//
// Deterministic: every RANSAC draws from cv::RNG reseeded from (seed, frame); the sequential stages
// do not depend on the thread count (keypoint detection and matching run in parallel per frame).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "smseg/frontend/gravity.hpp"  // fit_ground_plane
#include "smseg/frontend/motion.hpp"
#include "smseg/sequence/sequence.hpp"
#include "smseg/frontend/tracking.hpp"
#include "smseg/sfm/sfm_summary.hpp"

namespace smseg::sfm {

/// SIFT with up to 1500 keypoints per frame and a lower contrast threshold (0.01) than the stereo
/// default: monocular SfM needs more and longer tracks.
inline frontend::TrackingOptions sfm_default_tracking() {
  frontend::TrackingOptions t;
  t.max_keypoints = 1500;
  t.sift_contrast_threshold = 0.01;
  return t;
}

/// How keypoints are followed from frame to frame.
enum class SfmTracker {
  Auto,        ///< Descriptors (whole image, Lowe 0.8) when frames are > 0.25 s apart (median), else Klt
  Klt,         ///< pyramidal Lucas-Kanade from each keypoint, forward-backward checked; new keypoints fill gaps
  Descriptors  ///< independent detection per frame and descriptor matching (wide baselines, e.g. 1 Hz)
};

struct SfmOptions {
  SfmTracker tracker = SfmTracker::Auto;
  frontend::KltOptions klt;                       ///< KLT window, forward-backward check, spacing of new keypoints
  frontend::TrackingOptions tracking = sfm_default_tracking();
  frontend::TrackFilterOptions filters;
  std::optional<double> focal;          ///< pixels; overrides the manifest and the estimate
  std::optional<double> camera_height;  ///< metres; overrides the sequence's (one of them is required)
  int first_frame = 0;                  ///< frames [first_frame, last_frame) are processed
  int last_frame = -1;                  ///< -1: to the end
  /// Consecutive frames are matched among keypoints at most this far apart (pixels; symmetric nearest
  /// neighbour inside the gate); 0 = over the whole image (match_symmetric, for wide baselines).
  double match_radius_px = 40;
  double lowe_ratio = 0;                ///< (0, 1): also require best < ratio * second best (wide baseline); 0 = off
  /// Descriptor tracker: once a pair's fundamental matrix is known, its keypoints are matched again among
  /// the candidates within fundamental_threshold_px of their epipolar lines, with this ratio test
  /// (sfm_matching.hpp, match_epipolar); 0 = off (the first matches only).
  double epipolar_ratio = 0.9;
  double fundamental_threshold_px = 1.5;  ///< matches farther from their epipolar line are dropped
  double still_motion_px = 0.5;         ///< median keypoint motion below this: the camera stands still
  double init_motion_px = 12;           ///< median motion needed for the initial pair
  double init_min_angle_deg = 1.0;      ///< median triangulation angle needed for the initial pair
  double keyframe_motion_px = 8;        ///< median track motion since the last key frame that makes a key frame
  double min_triangulation_angle_deg = 1.0;  ///< new points need at least this angle between their rays
  double reprojection_threshold_px = 2.0;    ///< inlier threshold of PnP, triangulation and the final filter
  int min_pnp_points = 12;              ///< fewer 2D-3D inliers: the frame is bridged
  /// Descriptor tracker: each frame's keypoints without a 3D point are also matched (Lowe's ratio, the
  /// option's or 0.8) to the 3D points seen in this many frames before it; the matches PnP confirms join
  /// their point's track. 0 = off (only consecutive matches make tracks).
  int map_window = 3;
  int ba_window = 8;                    ///< key frames refined by the local bundle adjustment (>= 3)
  int ba_iterations = 10;               ///< Levenberg-Marquardt iterations per local adjustment
  bool final_ba = true;                 ///< global adjustment over every key frame at the end
  int final_ba_iterations = 30;
  double ground_min_angle_deg = 3;      ///< ground candidates need this angle between their extreme rays
  double ground_min_row_share = 0.25;   ///< ground candidates are seen at least this share of the height below the centre
  double ground_threshold = 0.08;       ///< ground-plane RANSAC inlier distance, as a share of camera_height
  double ground_max_tilt_deg = 10;      ///< the plane normal must be this close to the cameras' mean "up"
  int ground_iterations = 500;          ///< RANSAC samples for the ground plane
  /// A plane with fewer inliers is no evidence (three points always fit one): the scale then comes from
  /// the median height of the cameras over the ground candidates, or stays arbitrary without candidates.
  int ground_min_inliers = 10;
  std::uint64_t seed = 1;               ///< RANSAC seeds derive from (seed, frame)
  bool progress = true;                 ///< smseg::Progress on stderr
  /// Throws Error("", "sfm.<field>", reason) for an out-of-range value.
  void validate() const;
};

/// Where the focal length came from.
/// Fallback: nothing constrained the estimate (e.g. pure forward motion); the focal is the image width
/// (a 53-degree horizontal field of view) and the report says so.
enum class FocalSource { Option, Manifest, Estimated, Fallback };
const char* focal_source_name(FocalSource s);

/// What the SfM did, beyond the common front-end summary.
struct SfmReport {
  SfmTracker tracker = SfmTracker::Klt;  ///< the tracker used (Auto resolved)
  double focal = 0;                 ///< pixels, the value used (fx = fy)
  FocalSource focal_source = FocalSource::Manifest;
  int focal_pairs = 0;              ///< frame pairs that constrained the estimate (Estimated only)
  int init_frame_a = -1, init_frame_b = -1;  ///< the initial pair (sequence indices); -1: never initialised
  int keyframes = 0;
  int still_frames = 0;             ///< frames that reused the previous pose
  int pnp_frames = 0;               ///< frames posed by PnP (the initial pair not included)
  long map_joins = 0;               ///< tracks joined to a map point by local-map matching (map_window)
  int bridged_frames = 0;           ///< frames posed by the essential-matrix fallback or not at all
  long points_3d = 0;               ///< tracks with a 3D point
  double reprojection_rms_px = 0;   ///< over every kept observation, after the final filter
  long observations = 0;            ///< kept observations (the RMS is over these)
  double scale = 0;                 ///< metres per reconstruction unit
  Eigen::Vector3d ground_normal{0, 0, 0};  ///< in the reconstruction frame, before the world rotation
  int ground_inliers = 0, ground_candidates = 0;
  double seconds_sfm = 0;           ///< per frame: initialisation, PnP, triangulation, BA, scale
  double seconds_ba = 0;            ///< per frame: bundle adjustment alone (included in seconds_sfm)
};

const char* sfm_tracker_name(SfmTracker t);
SfmTracker parse_sfm_tracker(const std::string& name, const std::string& field);  ///< auto | klt | descriptors

/// The options with SfmTracker::Auto resolved for this sequence (see SfmTracker). Auto picks
/// Descriptors for a median frame interval above 0.25 s, and then matches over the whole image
/// (match_radius_px = 0) with Lowe's ratio 0.8 unless lowe_ratio is already set; else Klt.
SfmOptions resolve_tracker(const SfmOptions& options, const sequence::Sequence& seq);

/// The options as JSON (provenance in the work folder; extract-features compares them to resume).
Json sfm_options_to_json(const SfmOptions& options);

/// The report as it goes into the front-end summary (its own part, FrontEndSummary::own).
SfmSummary sfm_summary(const SfmReport& report);

/// Runs monocular SfM over the sequence (mono, or the left images of a stereo sequence). Errors
/// (missing camera height, no usable focal length, bad frame range, unreadable image) name the file and
/// field. A sequence without enough motion is not an error: every frame keeps the first pose, no
/// track has a 3D point, and report->init_frame_a == -1.
frontend::FrontEndResult run_mono_front_end(const sequence::Sequence& seq, const SfmOptions& options, SfmReport* report = nullptr);

/// The pinhole camera an SfM run of `seq` uses with this focal length (pixels): fx = fy = focal, the
/// manifest's principal point, or the image centre when the manifest gives none (cx = cy = 0). What
/// reads the SfM's poses with the images (the plane sweep of --dense) needs the same camera.
sequence::Calibration sfm_camera(const sequence::Sequence& seq, double focal);

// ---------------------------------------------------------------------------------------------
// Building blocks, public for tests and benchmarks.

/// Focal length (pixels) from fundamental matrices of frame pairs of a w x h camera whose principal
/// point is the image centre (see the header comment). Returns nullopt when no pair constrains it.
/// `pairs_used` receives the number of pairs that did.
std::optional<double> estimate_focal_from_fundamentals(const std::vector<cv::Matx33d>& fundamentals, cv::Size size,
                                                       int* pairs_used = nullptr);

/// A pinhole camera for the bundle adjustment: world-to-camera X_c = R X_w + t.
struct BaCamera {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  bool fixed = false;
};
struct BaObservation {
  int camera = 0, point = 0;
  Eigen::Vector2d pixel;
};
struct BaOptions {
  int iterations = 10;    ///< Ceres iterations (successful and unsuccessful steps)
  double huber_px = 1.5;  ///< robust loss width (pixels)
  void validate() const;  ///< Error("", "ba.<field>", reason)
};
struct BaSummary {
  double initial_rms = 0, final_rms = 0;  ///< pixels, over every observation (unweighted)
  int iterations = 0;
};

/// Bundle adjustment of the reprojection error with a Huber loss, by Ceres (Levenberg-Marquardt, the
/// points eliminated by the Schur complement; one thread, deterministic). Cameras with `fixed` stay put;
/// points seen by no observation stay put; observations behind their camera at the start contribute no
/// residual, and a step that would move a point behind a camera is rejected.
BaSummary bundle_adjust(std::vector<BaCamera>& cameras, std::vector<Eigen::Vector3d>& points,
                        const std::vector<BaObservation>& observations, double focal, double cx, double cy,
                        const BaOptions& options = {});

/// What the solver libraries under the bundle adjustment (Ceres, its glog, SuiteSparse's CHOLMOD) may
/// print on stderr; process-wide. By default errors only: their warnings ("Linear solver failure",
/// CHOLMOD's "matrix not positive definite") are steps that Ceres rejects and retries, noise to a user.
/// Verbose (a tool's -v): glog's warnings and info, CHOLMOD's messages, and one line per adjustment
/// (Ceres's brief report).
void set_solver_verbose(bool verbose);
bool solver_verbose();

}  // namespace smseg::sfm
