#pragma once
// Accuracy of an estimated camera path and of tracked 3D points against ground truth (synthetic
// sequences carry both: Sequence::gt_poses and load_gt_depth).
//
// - Absolute trajectory error (ATE, Sturm et al. 2012): the estimated camera centres are aligned to the
//   ground-truth centres by the least-squares rigid motion (Rigid) or similarity (Similarity, scale
//   fitted too), Umeyama 1991; the ATE is the RMS of the remaining centre differences, reported also as
//   a share of the ground-truth path length (the sum of consecutive centre distances).
// - Relative pose error (RPE) per frame pair: the difference between the estimated and the true
//   frame-to-frame motion, as a translation (metres) and a rotation angle (degrees). It tells drift
//   in rotation from drift in translation, which the ATE mixes.
// - Depth error of tracked points: per observation, |Z - Z_gt| / Z_gt with Z_gt the ground-truth
//   z-depth at the observation's nearest pixel (observations over unknown ground truth, 0, are
//   skipped); median, mean and 90th percentile.
//
// The names avoid the ones sfm.hpp uses for its own ATE (Alignment, TrajectoryError,
// absolute_trajectory_error), which this module can replace.

#include <functional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "smseg/sequence/sequence.hpp"
#include "smseg/frontend/tracking.hpp"

namespace smseg::frontend {

enum class PathAlignment { Rigid, Similarity };

/// y = s R x + t.
struct Similarity3 {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double s = 1;
  Eigen::Vector3d apply(const Eigen::Vector3d& x) const { return s * (R * x) + t; }
};

/// Least-squares transform mapping src[i] onto dst[i] (Umeyama 1991): rotation (det +1), translation
/// and, with `with_scale`, the scale. Error when the sizes differ or are 0. A single point gives the
/// identity rotation and scale 1; fewer than three non-collinear points give a non-unique rotation.
Similarity3 umeyama(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                    bool with_scale);

struct PathError {
  int frames = 0;
  double rmse = 0;         ///< metres, camera centres after alignment
  double max_error = 0;    ///< metres, largest centre difference after alignment
  double path_length = 0;  ///< metres, of the ground-truth path
  double relative = 0;     ///< rmse / path_length (0 when the path length is 0)
  double scale = 1;        ///< fitted estimate-to-truth scale (1 for Rigid)
  Similarity3 alignment;   ///< maps estimated centres onto ground truth
  std::vector<double> errors;  ///< per frame, metres after alignment
};

/// Camera centre of a pose (its t) and its camera-to-world rotation, as Eigen types.
Eigen::Vector3d pose_centre(const sequence::Pose& p);
Eigen::Matrix3d pose_rotation(const sequence::Pose& p);
/// The pose with camera-to-world rotation R and camera centre c (the inverse of the two above).
sequence::Pose make_pose(const Eigen::Matrix3d& R, const Eigen::Vector3d& c);

/// Ground-truth path length: sum of distances between consecutive centres.
double path_length(const std::vector<sequence::Pose>& poses);

/// ATE of `estimate` against `truth` (same size >= 2, frame i to frame i; Error otherwise).
PathError absolute_path_error(const std::vector<sequence::Pose>& estimate, const std::vector<sequence::Pose>& truth,
                              PathAlignment alignment);

struct RelativeError {
  int pairs = 0;
  double translation_rmse = 0;   ///< metres per frame pair
  double rotation_rmse_deg = 0;  ///< degrees per frame pair
  double translation_max = 0, rotation_max_deg = 0;
  std::vector<double> translation, rotation_deg;  ///< per pair (i, i+1)
};

/// RPE over consecutive frames: E_i = (T_i^-1 T_{i+1})^-1 (G_i^-1 G_{i+1}) with T estimated and G true
/// camera-to-world transforms; translation = |trans(E_i)|, rotation = angle(rot(E_i)). Error when the
/// sizes differ.
RelativeError relative_path_error(const std::vector<sequence::Pose>& estimate, const std::vector<sequence::Pose>& truth);

struct DepthError {
  long observations = 0;  ///< all observations offered
  long evaluated = 0;     ///< with ground truth (> 0) at the pixel and a positive estimated depth
  double median_relative = 0, mean_relative = 0, p90_relative = 0;
  double median_signed_relative = 0;  ///< median of (Z - Z_gt) / Z_gt: bias
};

/// Relative depth error of every track observation; `gt_depth(frame)` gives the frame's ground-truth
/// z-depth (CV_32FC1, metres, 0 = unknown), and is called once per frame, in ascending order.
/// Observations outside the image or in frames whose depth is empty are skipped.
DepthError tracked_depth_error(const std::vector<Track>& tracks, const std::function<cv::Mat(int)>& gt_depth);

}  // namespace smseg::frontend
