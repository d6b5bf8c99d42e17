// Gravity and the ground plane of a stereo camera path (gravity.hpp): levelling, the path's prior, the
// plane, and the stereo front end on the synthetic tabletop, whose camera looks down at the table.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <unistd.h>

#include <Eigen/Geometry>

#include "smseg/common/error.hpp"
#include "smseg/frontend/gravity.hpp"
#include "smseg/frontend/motion.hpp"
#include "smseg/frontend/tracks_io.hpp"
#include "smseg/frontend/trajectory.hpp"
#include "smseg/synth/synth.hpp"

using namespace smseg;
using namespace smseg::sequence;
using namespace smseg::frontend;

namespace {

double degrees(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

// A camera at `centre` looking along `forward` (horizontal in the true world, pitched down by `pitch_deg`).
Pose camera(const Eigen::Vector3d& centre, const Eigen::Vector3d& forward, double pitch_deg) {
  const Eigen::Vector3d z = (forward.normalized() * std::cos(pitch_deg * M_PI / 180) -
                             Eigen::Vector3d::UnitY() * std::sin(pitch_deg * M_PI / 180)).normalized();
  const Eigen::Vector3d x = (-Eigen::Vector3d::UnitY()).cross(z).normalized();  // camera y points down
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return make_pose(R, centre);
}

// A true world: cameras at height 1.2 m on `path`, pitched down 12 degrees, each seeing 40 floor points
// (one track each) ahead of it. Then the whole world as the front end would give it when it takes the
// first camera as level: rotated so that the first camera's up is +Y. `true_up` is where gravity ends up.
struct World {
  std::vector<Pose> poses;
  std::vector<Track> tracks;
  Eigen::Vector3d true_up;
};

World tilted_world(const std::vector<Eigen::Vector3d>& centres, const std::vector<Eigen::Vector3d>& forwards) {
  World w;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> noise(0, 0.005);
  std::vector<Pose> truth;
  for (std::size_t i = 0; i < centres.size(); ++i) truth.push_back(camera(centres[i], forwards[i], 12));
  // The "level first camera" world: R0' = diag(-1, -1, 1) as initial_pose, so Q = R0' R0^T.
  const Eigen::Matrix3d Q = pose_rotation(initial_pose(1.2)) * pose_rotation(truth[0]).transpose();
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const Eigen::Matrix3d R = pose_rotation(truth[i]);
    const Eigen::Vector3d c = pose_centre(truth[i]);
    w.poses.push_back(make_pose(Q * R, Q * c));
    for (int k = 0; k < 40; ++k) {
      const Eigen::Vector3d ahead = c + 3 * forwards[i].normalized() + Eigen::Vector3d(2 * u(rng), 0, 2 * u(rng));
      const Eigen::Vector3d floor(ahead.x(), noise(rng), ahead.z());
      Track t;
      t.frames = {static_cast<int>(i)};
      t.points = {R.transpose() * (floor - c)};
      w.tracks.push_back(t);
    }
  }
  w.true_up = Q * Eigen::Vector3d::UnitY();
  return w;
}

GravityOptions estimating() {
  GravityOptions o;
  o.method = GravityMethod::Estimate;
  return o;
}

}  // namespace

TEST(Gravity, LevellingPutsUpOnYKeepsTheFirstCameraAndTheRelativeMotion) {
  std::vector<Pose> poses = {camera({0, 1, 0}, {0, 0, 1}, 20), camera({0.5, 1.1, 2}, {1, 0, 1}, 5)};
  const Eigen::Vector3d up = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 0, 0.5).normalized()) * Eigen::Vector3d::UnitY();
  const std::vector<Pose> before = poses;
  level_world(poses, up);
  EXPECT_LT((pose_centre(poses[0]) - pose_centre(before[0])).norm(), 1e-12);
  // Relative motion unchanged.
  const Eigen::Matrix3d rel_before = pose_rotation(before[0]).transpose() * pose_rotation(before[1]);
  const Eigen::Matrix3d rel_after = pose_rotation(poses[0]).transpose() * pose_rotation(poses[1]);
  EXPECT_LT((rel_before - rel_after).norm(), 1e-9);
  EXPECT_NEAR((pose_centre(before[1]) - pose_centre(before[0])).norm(),
              (pose_centre(poses[1]) - pose_centre(poses[0])).norm(), 1e-9);
  // The first camera's optical axis on the ground points along +Z.
  const Eigen::Vector3d f = pose_rotation(poses[0]).col(2);
  EXPECT_NEAR(f.x(), 0, 1e-9);
  EXPECT_GT(f.z(), 0);
  // And `up` (a direction of the old world) is +Y of the new: the rotation applied to it.
  const Eigen::Matrix3d Q = pose_rotation(poses[0]) * pose_rotation(before[0]).transpose();
  EXPECT_LT(degrees(Q * up, Eigen::Vector3d::UnitY()), 1e-6);
}

TEST(Gravity, ACirclingCameraPitchedDownFindsGravityFromItsPath) {
  std::vector<Eigen::Vector3d> centres, forwards;
  for (int i = 0; i < 60; ++i) {
    const double a = i * 0.05;
    centres.emplace_back(2 * std::sin(a), 1.2, -2 * std::cos(a));
    forwards.emplace_back(-std::sin(a), 0, std::cos(a));  // towards the circle's centre
  }
  const World w = tilted_world(centres, forwards);
  ASSERT_GT(degrees(w.true_up, Eigen::Vector3d::UnitY()), 11);  // the level assumption is 12 degrees off
  const GravityEstimate g = estimate_gravity(w.poses, 0, w.tracks, 1.2, estimating());
  EXPECT_EQ(g.source, "camera-path");
  EXPECT_LT(degrees(g.up, w.true_up), 0.5);
  EXPECT_EQ(g.path_up, g.up);
  EXPECT_GT(g.inliers, 1000);  // the floor was found, and told
  EXPECT_NEAR(g.plane_below_first_camera, 1.2, 0.02);
  EXPECT_NEAR(g.correction_deg, degrees(w.true_up, Eigen::Vector3d::UnitY()), 0.5);
}

TEST(Gravity, AStraightPathTakesTheMotionOutOfTheCamerasUp) {
  std::vector<Eigen::Vector3d> centres, forwards;
  for (int i = 0; i < 60; ++i) {
    centres.emplace_back(0, 1.2, 0.1 * i);
    forwards.emplace_back(0, 0, 1);
  }
  World w = tilted_world(centres, forwards);
  // Without a floor: the prior alone, which knows the camera moves horizontally.
  const GravityEstimate prior = estimate_gravity(w.poses, 0, {}, 1.2, estimating());
  EXPECT_EQ(prior.source, "camera-heading");
  EXPECT_LT(degrees(prior.up, w.true_up), 0.5);
  const GravityEstimate g = estimate_gravity(w.poses, 0, w.tracks, 1.2, estimating());
  EXPECT_EQ(g.source, "ground-plane");
  EXPECT_LT(degrees(g.up, w.true_up), 0.5);
}

TEST(Gravity, AStillCameraKeepsItsOwnUpAndFewPointsMakeNoPlane) {
  const std::vector<Pose> poses(10, camera({0, 1.2, 0}, {0, 0, 1}, 12));
  GravityOptions o = estimating();
  const GravityEstimate g = estimate_gravity(poses, 0, {}, 1.2, o);
  EXPECT_EQ(g.source, "cameras");
  EXPECT_LT(degrees(g.up, -pose_rotation(poses[0]).col(1)), 1e-9);
  EXPECT_EQ(g.inliers, 0);
}

TEST(Gravity, AbsurdOptionsAreRefusedByName) {
  GravityOptions o;
  o.max_tilt_deg = 0;
  EXPECT_THROW(o.validate(), Error);
  o = {};
  o.plane_threshold = -1;
  EXPECT_THROW(o.validate(), Error);
  o = {};
  o.min_inliers = 2;
  EXPECT_THROW(o.validate(), Error);
  EXPECT_THROW(parse_gravity_method("tilted", "--gravity"), Error);
  EXPECT_EQ(parse_gravity_method("estimate", "--gravity"), GravityMethod::Estimate);
}

// The stereo front end on the synthetic tabletop (150 frames, 320x240, half a circle round the table):
// the camera looks down at the table, 13.6 degrees below level in the first frame. With the level
// assumption world +Y is that far from gravity in every frame; with gravity estimated (the path's
// plane) it is within 2 degrees in every frame (0.6 at most measured).
TEST(Gravity, TiltedTabletopWorldUpWithinTwoDegreesOfTruthInEveryFrame) {
  const fs::path scratch = fs::temp_directory_path() / ("smseg_test_gravity_" + std::to_string(::getpid()));
  synth::SynthOptions so;
  so.scene = "tabletop";
  so.frames = 150;
  so.seed = 1;
  synth::make_sequence(so, scratch / "seq");
  const Sequence seq = load_sequence(scratch / "seq");
  ASSERT_EQ(seq.gt_poses.size(), 150u);
  FrontEndOptions o;
  o.progress = false;
  const auto world_up_error = [&](const FrontEndResult& r, int f) {
    // Gravity in the camera's frame, estimated and true.
    return degrees(pose_rotation(r.poses[f]).transpose() * Eigen::Vector3d::UnitY(),
                   pose_rotation(seq.gt_poses[f]).transpose() * Eigen::Vector3d::UnitY());
  };
  const FrontEndResult level = run_stereo_front_end(seq, o);
  o.gravity.method = GravityMethod::Estimate;
  const FrontEndResult est = run_stereo_front_end(seq, o);
  ASSERT_TRUE(est.summary.gravity);
  EXPECT_EQ(est.summary.gravity->source, "camera-path");
  EXPECT_GT(world_up_error(level, 0), 10);
  for (int f = 0; f < 150; ++f) EXPECT_LT(world_up_error(est, f), 2) << "frame " << f;
  // tracks.json keeps the estimate.
  write_tracks(scratch / "tracks.json", est, seq.name, seq.size, front_end_options_to_json(o));
  const TracksFile back = read_tracks(scratch / "tracks.json", {});
  ASSERT_TRUE(back.result.summary.gravity);
  EXPECT_EQ(back.result.summary.gravity->source, "camera-path");
  EXPECT_LT((back.result.summary.gravity->up - est.summary.gravity->up).norm(), 1e-9);
  EXPECT_EQ(back.result.summary.gravity->inliers, est.summary.gravity->inliers);
  std::error_code ec;
  fs::remove_all(scratch, ec);
}
