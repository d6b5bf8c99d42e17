// Rigid motion (Arun SVD, RANSAC) and the chained camera path.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "smseg/features/motion.hpp"

using namespace smseg;
using namespace smseg::features;

namespace {

Eigen::Matrix3d rotation(double angle_deg, Eigen::Vector3d axis) {
  return Eigen::AngleAxisd(angle_deg * M_PI / 180, axis.normalized()).toRotationMatrix();
}

double angle_deg(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  const double c = std::clamp(((A.transpose() * B).trace() - 1) / 2, -1.0, 1.0);
  return std::acos(c) * 180 / M_PI;
}

std::vector<Eigen::Vector3d> cloud(int n, std::uint64_t seed) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(-2, 2), z(1, 6);
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < n; ++i) p.emplace_back(u(g), u(g) * 0.5, z(g));
  return p;
}

std::vector<Eigen::Vector3d> moved(const std::vector<Eigen::Vector3d>& p, const Eigen::Matrix3d& R,
                                   const Eigen::Vector3d& t) {
  std::vector<Eigen::Vector3d> q;
  for (const auto& x : p) q.push_back(R * x + t);
  return q;
}

}  // namespace

TEST(Motion, ArunRecoversAKnownMotionExactly) {
  const Eigen::Matrix3d R = rotation(7.5, {0.2, 1, -0.3});
  const Eigen::Vector3d t(0.1, -0.05, 0.4);
  const auto p = cloud(25, 1);
  const RigidMotion m = fit_rigid(p, moved(p, R, t));
  EXPECT_LT((m.R - R).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((m.t - t).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(m.R.determinant(), 1.0, 1e-12);
}

TEST(Motion, ArunOnCoplanarAndMinimalSetsStaysAProperRotation) {
  // Coplanar points: H has rank 2 and the naive V U^T may be a reflection; the fix must give R.
  const Eigen::Matrix3d R = rotation(20, {1, 1, 0});
  const Eigen::Vector3d t(-0.3, 0.2, 0.1);
  std::vector<Eigen::Vector3d> plane;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) plane.emplace_back(i * 0.5, j * 0.3, 3.0);
  const RigidMotion m = fit_rigid(plane, moved(plane, R, t));
  EXPECT_NEAR(m.R.determinant(), 1.0, 1e-9);
  EXPECT_LT((m.R - R).cwiseAbs().maxCoeff(), 1e-9);
  // A mirrored copy cannot be fitted by a rotation; the result must still be a rotation, not a reflection.
  std::vector<Eigen::Vector3d> mirror;
  const auto p = cloud(10, 2);
  for (const auto& x : p) mirror.emplace_back(-x.x(), x.y(), x.z());
  const RigidMotion r = fit_rigid(p, mirror);
  EXPECT_NEAR(r.R.determinant(), 1.0, 1e-9);
  EXPECT_TRUE(r.t.allFinite());
}

TEST(Motion, StaticCameraGivesIdentityNotNaN) {
  const auto p = cloud(30, 3);
  const RigidMotion m = fit_rigid(p, p);
  EXPECT_LT((m.R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(m.t.norm(), 1e-12);
  // All points at one place: nothing to rotate, still finite.
  const std::vector<Eigen::Vector3d> same(5, Eigen::Vector3d(1, 2, 3));
  const RigidMotion s = fit_rigid(same, same);
  EXPECT_TRUE(s.R.allFinite() && s.t.allFinite());
  EXPECT_LT(s.t.norm(), 1e-12);
  RansacOptions o;
  const MotionEstimate e = estimate_motion(p, p, o, 0);
  EXPECT_TRUE(e.ok);
  EXPECT_EQ(e.inliers, 30);
  EXPECT_LT((e.motion.R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(e.motion.t.norm(), 1e-9);
  const MotionEstimate d = estimate_motion(same, same, o, 0);  // every sample degenerate
  EXPECT_TRUE(d.motion.R.allFinite() && d.motion.t.allFinite());
}

TEST(Motion, RansacWithNoiseAndThirtyPercentOutliers) {
  const Eigen::Matrix3d R = rotation(3, {0.1, 1, 0.05});
  const Eigen::Vector3d t(0.02, 0.0, -0.12);
  const int n = 200;
  auto p = cloud(n, 4);
  auto q = moved(p, R, t);
  std::mt19937_64 g(5);
  std::normal_distribution<double> noise(0, 0.005);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<bool> outlier(n, false);
  for (int i = 0; i < n; ++i) {
    if (i % 10 < 3) {  // 30% outliers: moved far away at random
      outlier[i] = true;
      q[i] += Eigen::Vector3d(u(g), u(g), u(g)) * 1.5 + Eigen::Vector3d(0.5, 0, 0);
    } else {
      q[i] += Eigen::Vector3d(noise(g), noise(g), noise(g));
    }
  }
  RansacOptions o;
  o.depth_exponent = 0;  // fixed 3 cm threshold: the noise is not depth dependent here
  const MotionEstimate e = estimate_motion(p, q, o, 42);
  ASSERT_TRUE(e.ok);
  EXPECT_LT(angle_deg(e.motion.R, R), 0.3);
  EXPECT_LT((e.motion.t - t).norm(), 0.01);
  int wrong = 0;
  for (int i = 0; i < n; ++i) wrong += (e.inlier_mask[i] != 0) == outlier[i];
  EXPECT_LT(wrong, n / 20);
  // Plain least squares over everything is far off: RANSAC is doing the work.
  const RigidMotion ls = fit_rigid(p, q);
  EXPECT_GT((ls.t - t).norm(), 0.05);
  // Deterministic for a given (seed, stream).
  const MotionEstimate e2 = estimate_motion(p, q, o, 42);
  EXPECT_EQ(e2.motion.R, e.motion.R);
  EXPECT_EQ(e2.motion.t, e.motion.t);
}

TEST(Motion, TooFewPointsIsABadPairNotACrash) {
  RansacOptions o;
  EXPECT_FALSE(estimate_motion({}, {}, o, 0).ok);
  const auto p = cloud(2, 6);
  EXPECT_FALSE(estimate_motion(p, p, o, 0).ok);
  const auto p5 = cloud(5, 7);
  EXPECT_FALSE(estimate_motion(p5, p5, o, 0).ok) << "5 points < min_inliers 8";
  EXPECT_THROW(estimate_motion(p5, p, o, 0), Error);
  o.min_inliers = 2;
  EXPECT_THROW(o.validate(), Error);
}

TEST(Motion, InitialPoseIsLevelAtCameraHeight) {
  const Pose p = initial_pose(1.2);
  // camera y (down) is world -Y; camera z (forward) is world +Z; centre above the origin.
  EXPECT_EQ(p.R[1], 0);
  EXPECT_EQ(p.R[4], -1);
  EXPECT_EQ(p.R[7], 0);
  EXPECT_EQ(p.R[8], 1);
  EXPECT_EQ(p.t[0], 0);
  EXPECT_EQ(p.t[1], 1.2);
  EXPECT_EQ(p.t[2], 0);
}

TEST(Motion, ChainedPathFollowsForwardMotionAndBridgesABadPair) {
  // Camera moving 0.5 m forward per frame: points move 0.5 m towards it (X' = X - (0, 0, 0.5)).
  RigidMotion fwd;
  fwd.t = Eigen::Vector3d(0, 0, -0.5);
  std::vector<PairMotion> pairs(5);
  for (auto& pm : pairs) pm.motion = fwd, pm.ok = true;
  pairs[2].ok = false;  // a frame with no points
  pairs[2].motion = RigidMotion{};
  pairs[2].motion.t = Eigen::Vector3d(9, 9, 9);  // garbage that must not be used
  const auto poses = chain_poses(pairs, 1.5);
  ASSERT_EQ(poses.size(), 6u);
  for (int f = 0; f < 6; ++f) {
    EXPECT_NEAR(poses[f].t[0], 0, 1e-12);
    EXPECT_NEAR(poses[f].t[1], 1.5, 1e-12);
    EXPECT_NEAR(poses[f].t[2], 0.5 * f, 1e-12) << "frame " << f;
  }
  EXPECT_TRUE(pairs[2].bridged);
  EXPECT_FALSE(pairs[3].bridged);
  // A bad first pair has no previous motion: identity (the camera is assumed still).
  std::vector<PairMotion> first_bad(2);
  first_bad[1].motion = fwd, first_bad[1].ok = true;
  const auto p2 = chain_poses(first_bad, 1.0);
  EXPECT_NEAR(p2[1].t[2], 0, 1e-12);
  EXPECT_NEAR(p2[2].t[2], 0.5, 1e-12);
  // Rotation chains too: turning 10 degrees about the vertical per frame.
  std::vector<PairMotion> turn(9);
  for (auto& pm : turn) pm.motion.R = rotation(10, {0, 1, 0}), pm.ok = true;
  const auto p3 = chain_poses(turn, 1.0);
  Eigen::Matrix3d R0, R9;
  for (int i = 0; i < 9; ++i) R0(i / 3, i % 3) = p3[0].R[i], R9(i / 3, i % 3) = p3[9].R[i];
  EXPECT_NEAR(angle_deg(R0, R9), 90, 1e-9);
}

TEST(Motion, PairMotionsFromTracks) {
  // Two frames, 20 tracks moved by a known motion: the pair gets it; frames are sequence indices.
  const Eigen::Matrix3d R = rotation(2, {0, 1, 0});
  const Eigen::Vector3d t(0, 0, -0.3);
  const auto p = cloud(20, 8);
  std::vector<Track> tracks;
  for (const auto& x : p) {
    Track tr;
    tr.frames = {10, 11};
    tr.points = {x, R * x + t};
    tr.pixels.resize(2);
    tr.disparities = {1, 1};
    tr.labels = {-1, -1};
    tracks.push_back(tr);
  }
  const auto pm = estimate_pair_motions(tracks, 10, 3, RansacOptions{});
  ASSERT_EQ(pm.size(), 2u);
  EXPECT_TRUE(pm[0].ok);
  EXPECT_EQ(pm[0].points, 20);
  EXPECT_LT((pm[0].motion.t - t).norm(), 1e-9);
  EXPECT_FALSE(pm[1].ok);
  EXPECT_EQ(pm[1].points, 0);
}
