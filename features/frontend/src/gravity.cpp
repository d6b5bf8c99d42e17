// Gravity and the ground plane of a stereo camera path: see gravity.hpp.
#include "smseg/frontend/gravity.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "smseg/common/error.hpp"
#include "smseg/common/names.hpp"
#include "smseg/frontend/trajectory.hpp"

namespace smseg::frontend {
namespace {

// A path is "planar" when its second principal extent is at least kPlanarShare of its first and its
// third at most kFlatShare of its second, and "moving" when its first is at least kMovingShare of the
// camera height (below: the camera stands).
constexpr double kPlanarShare = 0.2;
constexpr double kFlatShare = 0.25;
constexpr double kMovingShare = 0.05;

double degrees_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

// Step 1 of gravity.hpp: the up direction the camera path suggests.
Eigen::Vector3d path_prior(const std::vector<sequence::Pose>& poses, double camera_height, std::string& source) {
  Eigen::Vector3d cam_up = Eigen::Vector3d::Zero(), mean = Eigen::Vector3d::Zero();
  for (const sequence::Pose& p : poses) {
    cam_up -= pose_rotation(p).col(1);  // camera y points down
    mean += pose_centre(p);
  }
  cam_up.normalize();
  mean /= static_cast<double>(poses.size());
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (const sequence::Pose& p : poses) {
    const Eigen::Vector3d d = pose_centre(p) - mean;
    C += d * d.transpose();
  }
  C /= static_cast<double>(poses.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);  // eigenvalues ascending
  const double first = std::sqrt(std::max(0.0, es.eigenvalues()(2)));
  const double second = std::sqrt(std::max(0.0, es.eigenvalues()(1)));
  const double third = std::sqrt(std::max(0.0, es.eigenvalues()(0)));
  if (first < kMovingShare * camera_height) {
    source = "cameras";
    return cam_up;
  }
  if (second >= kPlanarShare * first && third <= kFlatShare * second) {
    Eigen::Vector3d n = es.eigenvectors().col(0);
    if (n.dot(cam_up) < 0) n = -n;
    // A path plane far from the cameras' up (a camera moved up and down a wall) is not the ground's.
    if (degrees_between(n, cam_up) <= 45) {
      source = "camera-path";
      return n.normalized();
    }
  }
  const Eigen::Vector3d along = es.eigenvectors().col(2);
  Eigen::Vector3d up = cam_up - cam_up.dot(along) * along;
  if (!(up.norm() > 1e-6)) {
    source = "cameras";
    return cam_up;
  }
  source = "camera-heading";
  return up.normalized();
}

// One point per track, the world position of its first observation, when it lies well below the
// camera that saw it (candidates for the ground).
std::vector<Eigen::Vector3d> ground_candidates(const std::vector<sequence::Pose>& poses, int first_frame,
                                               const std::vector<Track>& tracks, const Eigen::Vector3d& up,
                                               double min_below) {
  std::vector<Eigen::Vector3d> out;
  for (const Track& t : tracks) {
    if (t.frames.empty() || t.points.empty()) continue;
    const int i = t.frames[0] - first_frame;
    if (i < 0 || i >= static_cast<int>(poses.size())) continue;
    const Eigen::Vector3d c = pose_centre(poses[i]);
    const Eigen::Vector3d x = pose_rotation(poses[i]) * t.points[0] + c;
    if (x.allFinite() && (c - x).dot(up) >= min_below) out.push_back(x);
  }
  return out;
}

}  // namespace

namespace {
constexpr std::array<EnumName<GravityMethod>, 2> kGravityMethodNames{
    {{GravityMethod::Level, "level"}, {GravityMethod::Estimate, "estimate"}}};
}  // namespace

GravityMethod parse_gravity_method(const std::string& name, const std::string& field) {
  return value_named(kGravityMethodNames, name, field);
}
const char* gravity_method_name(GravityMethod m) { return name_of(kGravityMethodNames, m); }

void GravityOptions::validate() const {
  if (!(max_tilt_deg > 0 && max_tilt_deg <= 45)) throw Error("", "gravity.max_tilt_deg", "must be in (0, 45] degrees");
  if (!(plane_threshold > 0 && plane_threshold <= 1))
    throw Error("", "gravity.plane_threshold", "must be in (0, 1] (share of the camera height)");
  if (!(min_below >= 0 && min_below <= 10)) throw Error("", "gravity.min_below", "must be in [0, 10]");
  if (min_inliers < 3) throw Error("", "gravity.min_inliers", "must be >= 3");
  if (iterations < 1 || iterations > 1000000) throw Error("", "gravity.iterations", "must be 1..1000000");
}

GravityEstimate estimate_gravity(const std::vector<sequence::Pose>& poses, int first_frame, const std::vector<Track>& tracks,
                                 double camera_height, const GravityOptions& o) {
  GravityEstimate g;
  if (poses.empty()) {
    g.source = "cameras";
    return g;
  }
  g.path_up = path_prior(poses, camera_height, g.source);
  g.up = g.path_up;
  const std::vector<Eigen::Vector3d> cand =
      ground_candidates(poses, first_frame, tracks, g.path_up, o.min_below * camera_height);
  g.candidates = static_cast<int>(cand.size());
  const PlaneFit plane = fit_ground_plane(cand, g.path_up, o.plane_threshold * camera_height, o.max_tilt_deg,
                                          o.iterations, o.seed, o.min_inliers);
  if (plane.ok) {
    g.inliers = plane.inliers;
    g.plane_below_first_camera = plane.normal.dot(pose_centre(poses.front())) + plane.d;
    // A planar path's normal wins: it rests on every camera centre, while the plane's least-squares
    // normal tilts with the depth noise of a few metres of stereo points (tabletop, 150 frames: the
    // path's up within 0.6 degrees of gravity in every frame, the table top's within 2.7).
    if (g.source != "camera-path") {
      g.up = plane.normal;
      g.source = "ground-plane";
    }
  }
  g.correction_deg = degrees_between(g.up, Eigen::Vector3d::UnitY());
  return g;
}

void level_world(std::vector<sequence::Pose>& poses, const Eigen::Vector3d& up) {
  if (poses.empty() || !(up.norm() > 0)) return;
  const Eigen::Matrix3d tilt = Eigen::Quaterniond::FromTwoVectors(up.normalized(), Eigen::Vector3d::UnitY()).toRotationMatrix();
  // Heading: turn about +Y so that the first camera's optical axis, on the ground, points along +Z
  // as before (a camera looking straight down keeps the tilt's heading).
  const Eigen::Vector3d forward = tilt * pose_rotation(poses.front()).col(2);
  const double yaw = std::hypot(forward.x(), forward.z()) > 1e-9 ? std::atan2(forward.x(), forward.z()) : 0.0;
  const Eigen::Matrix3d Q = Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitY()).toRotationMatrix() * tilt;
  const Eigen::Vector3d pivot = pose_centre(poses.front());
  for (sequence::Pose& p : poses) p = make_pose(Q * pose_rotation(p), Q * (pose_centre(p) - pivot) + pivot);
}

}  // namespace smseg::frontend
