// Rigid motion (Arun SVD, RANSAC) and the chained camera path.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "smseg/frontend/motion.hpp"

using namespace smseg;
using namespace smseg::sequence;
using namespace smseg::frontend;

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

// ---------------------------------------------------------------------------------------------
// Reprojection refinement and the moving-object guard.

namespace {

StereoCamera rig() {
  StereoCamera c;
  c.fx = c.fy = 246.4;
  c.cx = 159.5;
  c.cy = 119.5;
  c.baseline = 0.12;
  return c;
}

// Points spread over 1.5 .. 15 m in front of the camera, inside the image.
std::vector<Eigen::Vector3d> deep_cloud(int n, std::uint64_t seed) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(-0.5, 0.5), inv(1 / 15.0, 1 / 1.5);
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < n; ++i) {
    const double z = 1 / inv(g);
    p.emplace_back(u(g) * z, u(g) * 0.7 * z, z);
  }
  return p;
}

}  // namespace

TEST(MotionRefine, ReprojectionRefinementBeatsTheUnweighted3DFit) {
  const StereoCamera cam = rig();
  const Eigen::Matrix3d R = rotation(1.5, {0, 1, 0});
  const Eigen::Vector3d t(0.01, 0, -0.04);
  std::mt19937_64 g(11);
  std::normal_distribution<double> px(0, 0.3);
  double arun_t = 0, refined_t = 0, arun_r = 0, refined_r = 0;
  for (int trial = 0; trial < 10; ++trial) {
    const auto X = deep_cloud(150, 100 + trial);
    std::vector<Eigen::Vector3d> ma, mb, P, Q;
    for (const auto& x : X) {
      Eigen::Vector3d a = cam.project(x), b = cam.project(R * x + t);
      for (auto* m : {&a, &b}) *m += Eigen::Vector3d(px(g), px(g), px(g));
      if (a.z() < 1 || b.z() < 1) continue;
      ma.push_back(a), mb.push_back(b), P.push_back(cam.backproject(a)), Q.push_back(cam.backproject(b));
    }
    const RigidMotion arun = fit_rigid(P, Q);
    std::vector<std::uint8_t> in;
    double rms = 0;
    const RigidMotion m = refine_motion(arun, ma, mb, cam, RefineOptions{}, {}, &in, &rms);
    arun_t += (arun.t - t).norm(), refined_t += (m.t - t).norm();
    arun_r += angle_deg(arun.R, R), refined_r += angle_deg(m.R, R);
    EXPECT_NEAR(m.R.determinant(), 1.0, 1e-9);
    EXPECT_LT(rms, 1.0);
    int k = 0;
    for (auto v : in) k += v;
    EXPECT_GT(k, static_cast<int>(0.9 * static_cast<double>(ma.size())));
  }
  EXPECT_LT(refined_t, 0.5 * arun_t) << "mean translation error, Arun " << arun_t / 10 << " refined " << refined_t / 10;
  EXPECT_LT(refined_r, 0.5 * arun_r) << "mean rotation error, Arun " << arun_r / 10 << " refined " << refined_r / 10;
  EXPECT_LT(refined_t / 10, 0.01);
  // Exact measurements: the exact motion back from a perturbed start.
  const auto X = deep_cloud(60, 7);
  std::vector<Eigen::Vector3d> ma, mb;
  for (const auto& x : X) ma.push_back(cam.project(x)), mb.push_back(cam.project(R * x + t));
  RigidMotion start;
  start.R = rotation(0.5, {1, 0, 0}) * R;
  start.t = t + Eigen::Vector3d(0.05, -0.02, 0.03);
  RefineOptions o;
  o.iterations = 50;
  const RigidMotion m = refine_motion(start, ma, mb, cam, o);
  EXPECT_LT(angle_deg(m.R, R), 1e-5);  // acos resolution near 0 is ~1e-6 degrees
  EXPECT_LT((m.t - t).norm(), 1e-6);
  // Too few usable correspondences: the start is returned.
  const RigidMotion same = refine_motion(start, {ma[0], ma[1]}, {mb[0], mb[1]}, cam, o);
  EXPECT_EQ(same.t, start.t);
  o.huber_px = 0;
  EXPECT_THROW(o.validate(), Error);
}

TEST(MotionRefine, AMovingObjectHoldingMostPointsDoesNotTakeOverThePath) {
  // Camera: 4 cm forward per frame. Frame pair 0 sees only the static scene; in pairs 1..3 an object
  // with 70 points (against 30 static ones) moves sideways 10 cm per frame.
  const StereoCamera cam = rig();
  RigidMotion cam_step;  // static points: X' = X - (0, 0, 0.04)
  cam_step.t = Eigen::Vector3d(0, 0, -0.04);
  const Eigen::Vector3d object_step(0.10, 0, 0);
  std::vector<Track> tracks;
  auto add_track = [&](Eigen::Vector3d x, int f0, int f1, bool moving) {
    Track tr;
    for (int f = f0; f <= f1; ++f) {
      const Eigen::Vector3d uvd = cam.project(x);
      tr.frames.push_back(f);
      tr.pixels.emplace_back(static_cast<float>(uvd.x()), static_cast<float>(uvd.y()));
      tr.disparities.push_back(static_cast<float>(uvd.z()));
      tr.points.push_back(cam.backproject(Eigen::Vector3d(tr.pixels.back().x, tr.pixels.back().y, tr.disparities.back())));
      tr.labels.push_back(-1);
      x = cam_step.apply(x) + (moving ? object_step : Eigen::Vector3d::Zero());
    }
    tracks.push_back(tr);
  };
  for (const auto& x : deep_cloud(60, 21)) add_track(x, 0, 1, false);  // pair 0
  for (const auto& x : deep_cloud(30, 22)) add_track(x, 1, 4, false);
  std::mt19937_64 g(23);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  for (int i = 0; i < 70; ++i) add_track(Eigen::Vector3d(u(g), u(g), 2.5 + u(g)), 1, 4, true);
  const auto pm = estimate_pair_motions(tracks, 0, 5, RansacOptions{}, cam, RefineOptions{});
  ASSERT_EQ(pm.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_TRUE(pm[k].ok) << "pair " << k;
    EXPECT_LT((pm[k].motion.t - cam_step.t).norm(), 1e-3) << "pair " << k;
    EXPECT_LT(angle_deg(pm[k].motion.R, Eigen::Matrix3d::Identity()), 0.05) << "pair " << k;
  }
  // Without the guard, the largest rigid set (the object) wins: the test is not vacuous.
  RefineOptions plain;
  plain.second_hypothesis = false;
  const auto pm2 = estimate_pair_motions(tracks, 0, 5, RansacOptions{}, cam, plain);
  EXPECT_GT((pm2[2].motion.t - cam_step.t).norm(), 0.05);
  // Deterministic.
  const auto pm3 = estimate_pair_motions(tracks, 0, 5, RansacOptions{}, cam, RefineOptions{});
  for (int k = 0; k < 4; ++k) EXPECT_EQ(pm3[k].motion.t, pm[k].motion.t);
}
