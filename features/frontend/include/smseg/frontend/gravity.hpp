#pragma once
// Gravity and the ground plane of a stereo camera path.
//
// The stereo front end builds its world frame from the first camera: Y up along that camera's up axis,
// i.e. it assumes the first camera level. A camera that looks down at a table (the tabletop scene:
// 13.6 degrees of pitch) tilts the whole world by that much, and everything measured against world Y
// tilts with it: fH, the heights of GrabCutSFM's supporting plane, the camera's height along the path
// (1.15 -> 1.69 m on a level circle). estimate_gravity() finds the up direction instead from what the
// video shows:
//
// 1. the camera path. A camera carried, driven or flown at a steady height moves in a plane parallel
//    to the ground: when the path spans two directions and is flat (a turn, a circle: second principal
//    extent >= 0.2 of the first, third <= 0.25 of the second) the normal of its best-fit plane is the
//    up direction, and the answer; when it is nearly a line (driving straight) the prior is the
//    cameras' mean up axis with the motion direction taken out (the camera moves horizontally); when
//    the camera hardly moves, the cameras' mean up axis;
// 2. the ground plane: RANSAC over the tracks' 3D points well below the cameras (one point per track),
//    hypotheses restricted to normals within max_tilt_deg of the prior, the best refitted by least
//    squares (fit_ground_plane, also the SfM's). Unless the path was planar, its normal is the up direction
//    when it has at least min_inliers inliers (a line leaves the roll about the motion to the plane);
//    otherwise the prior is. A planar path wins over the plane because the plane's least-squares
//    normal tilts with the stereo depth noise (on the tabletop, 150 frames: the path's up within 0.6
//    degrees of gravity in every frame, the table top's within 2.7).
//
// level_world() then rotates the world about the first camera's centre so that the estimated up is +Y
// and the first camera's heading (its optical axis on the ground) stays +Z. The origin stays
// camera_height below the first camera: the stereo rig's metric scale needs no plane, and the plane
// found may be a table top rather than the floor, so its distance is reported, not used.
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "smseg/frontend/tracking.hpp"
#include "smseg/sequence/sequence.hpp"

namespace smseg::frontend {

/// A plane fitted by fit_ground_plane.
struct PlaneFit {
  Eigen::Vector3d normal{0, 1, 0};  ///< unit
  double d = 0;                     ///< plane: normal . x + d = 0
  int inliers = 0;
  bool ok = false;
};

/// RANSAC plane through points (3-point samples, deterministic for a seed), its normal within
/// max_tilt_deg of `up` (sign chosen to agree with up), refit by least squares on the inliers. A plane
/// with fewer than min_inliers inliers (at least 3) is none (ok = false): three points always fit one.
PlaneFit fit_ground_plane(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& up, double threshold,
                          double max_tilt_deg, int iterations, std::uint64_t seed, int min_inliers = 3);

enum class GravityMethod {
  Level,    ///< the first camera is level (the thesis's assumption, world Y = its up axis)
  Estimate  ///< estimate_gravity() and level_world()
};
GravityMethod parse_gravity_method(const std::string& name, const std::string& field);  ///< level | estimate
const char* gravity_method_name(GravityMethod m);

struct GravityOptions {
  GravityMethod method = GravityMethod::Level;
  double max_tilt_deg = 15;     ///< ground-plane normals searched within this of the path's prior
  double plane_threshold = 0.03;  ///< RANSAC inlier distance, share of the camera height
  double min_below = 0.25;      ///< candidates lie at least this share of the camera height below their camera
  int min_inliers = 50;         ///< fewer inliers: the path's prior is the answer
  int iterations = 500;         ///< RANSAC samples
  std::uint64_t seed = 1;
  void validate() const;        ///< Error naming the field
};

struct GravityEstimate {
  Eigen::Vector3d up{0, 1, 0};       ///< unit, in the world frame of the poses it was estimated from
  Eigen::Vector3d path_up{0, 1, 0};  ///< the camera path's prior (step 1)
  std::string source;                ///< "camera-path" (plane of the path), "ground-plane" (the plane, from
                                     ///< a line's or a still camera's prior), "camera-heading" (line: mean up
                                     ///< without the motion direction) or "cameras" (still)
  int candidates = 0;                ///< points offered to the plane fit
  int inliers = 0;                   ///< of the ground plane (0: no plane)
  double plane_below_first_camera = 0;  ///< metres from the first camera down to the plane (0: no plane)
  double correction_deg = 0;         ///< angle between up and the input world +Y
};

/// Up direction of the world of `poses` (camera-to-world, poses[i] is sequence frame first_frame + i)
/// from the camera path and the tracks' points (camera frame, metres). Deterministic for a seed.
GravityEstimate estimate_gravity(const std::vector<sequence::Pose>& poses, int first_frame, const std::vector<Track>& tracks,
                                 double camera_height, const GravityOptions& options);

/// Rotates every pose about the first camera's centre so that `up` becomes world +Y and the first
/// camera's optical axis, projected on the ground, stays along +Z. Camera-frame points do not change.
void level_world(std::vector<sequence::Pose>& poses, const Eigen::Vector3d& up);

}  // namespace smseg::frontend
