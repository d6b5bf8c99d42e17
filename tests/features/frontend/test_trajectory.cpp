// Trajectory accuracy: Umeyama alignment, ATE, RPE, tracked depth error.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "smseg/frontend/trajectory.hpp"

using namespace smseg;
using namespace smseg::sequence;
using namespace smseg::frontend;

namespace {

Pose make_pose(const Eigen::Matrix3d& R, const Eigen::Vector3d& c) {
  Pose p;
  for (int i = 0; i < 9; ++i) p.R[i] = R(i / 3, i % 3);
  for (int i = 0; i < 3; ++i) p.t[i] = c[i];
  return p;
}

// A curving path of n poses, 0.1 m per frame.
std::vector<Pose> curve(int n) {
  std::vector<Pose> out;
  double yaw = 0;
  Eigen::Vector3d c(0, 1, 0);
  for (int i = 0; i < n; ++i) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix() *
                              Eigen::Vector3d(-1, -1, 1).asDiagonal();
    out.push_back(make_pose(R, c));
    c += 0.1 * (R * Eigen::Vector3d::UnitZ());
    yaw += 0.02;
  }
  return out;
}

std::vector<Pose> transformed(const std::vector<Pose>& in, const Similarity3& S) {
  std::vector<Pose> out;
  for (const auto& p : in) out.push_back(make_pose(S.R * pose_rotation(p), S.apply(pose_centre(p))));
  return out;
}

}  // namespace

TEST(Trajectory, UmeyamaRecoversASimilarity) {
  std::mt19937_64 g(1);
  std::uniform_real_distribution<double> u(-3, 3);
  std::vector<Eigen::Vector3d> a, b;
  Similarity3 S;
  S.R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  S.t = Eigen::Vector3d(1, -2, 0.5);
  S.s = 1.7;
  for (int i = 0; i < 20; ++i) a.emplace_back(u(g), u(g), u(g)), b.push_back(S.apply(a.back()));
  const Similarity3 f = umeyama(a, b, true);
  EXPECT_LT((f.R - S.R).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((f.t - S.t).norm(), 1e-9);
  EXPECT_NEAR(f.s, 1.7, 1e-9);
  const Similarity3 r = umeyama(a, b, false);
  EXPECT_EQ(r.s, 1);
  EXPECT_LT((r.R - S.R).cwiseAbs().maxCoeff(), 1e-9) << "rotation is scale-free";
  EXPECT_THROW(umeyama(a, {}, true), Error);
  EXPECT_THROW(umeyama({}, {}, true), Error);
}

TEST(Trajectory, AbsoluteErrorIsZeroUpToTheAlignmentAndMeasuresAnOffset) {
  const auto gt = curve(50);
  EXPECT_NEAR(path_length(gt), 4.9, 1e-9);
  Similarity3 S;
  S.R = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  S.t = Eigen::Vector3d(2, 0, -1);
  const auto rigid = transformed(gt, S);
  EXPECT_LT(absolute_path_error(rigid, gt, PathAlignment::Rigid).rmse, 1e-9);
  S.s = 0.8;
  const auto scaled = transformed(gt, S);
  const PathError sim = absolute_path_error(scaled, gt, PathAlignment::Similarity);
  EXPECT_LT(sim.rmse, 1e-9);
  EXPECT_NEAR(sim.scale, 1.25, 1e-9);
  EXPECT_GT(absolute_path_error(scaled, gt, PathAlignment::Rigid).rmse, 0.05);
  // Alternating +-5 cm lateral offsets cannot be aligned away: RMSE 5 cm.
  auto noisy = gt;
  for (std::size_t i = 0; i < noisy.size(); ++i) noisy[i].t[0] += (i % 2 ? 0.05 : -0.05);
  const PathError e = absolute_path_error(noisy, gt, PathAlignment::Rigid);
  EXPECT_NEAR(e.rmse, 0.05, 2e-3);
  EXPECT_NEAR(e.relative, e.rmse / 4.9, 1e-12);
  EXPECT_EQ(e.frames, 50);
  EXPECT_EQ(e.errors.size(), 50u);
  EXPECT_THROW(absolute_path_error(noisy, curve(49), PathAlignment::Rigid), Error);
  EXPECT_THROW(absolute_path_error(curve(1), curve(1), PathAlignment::Rigid), Error);
}

TEST(Trajectory, RelativeErrorSeesOneBadStep) {
  const auto gt = curve(20);
  Similarity3 S;
  S.R = Eigen::AngleAxisd(-1.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  S.t = Eigen::Vector3d(5, 0, 5);
  const auto moved = transformed(gt, S);
  const RelativeError z = relative_path_error(moved, gt);
  EXPECT_EQ(z.pairs, 19);
  EXPECT_LT(z.translation_max, 1e-9);
  EXPECT_LT(z.rotation_max_deg, 1e-6);
  // Frames 10.. shifted 3 cm: only pair (9, 10) is wrong, by 3 cm.
  auto bad = gt;
  for (std::size_t i = 10; i < bad.size(); ++i) bad[i].t[0] += 0.03;
  const RelativeError r = relative_path_error(bad, gt);
  EXPECT_NEAR(r.translation[9], 0.03, 1e-9);
  EXPECT_NEAR(r.translation_max, 0.03, 1e-9);
  EXPECT_LT(r.translation[8] + r.translation[10], 1e-9);
}

TEST(Trajectory, TrackedDepthError) {
  cv::Mat depth(10, 10, CV_32FC1, cv::Scalar(2.0f));
  depth.at<float>(5, 5) = 0;  // unknown
  Track tr;
  tr.frames = {3, 4, 5, 6};
  tr.pixels = {{1, 1}, {2, 2}, {5, 5}, {20, 20}};  // the last is outside the image
  tr.points = {{0, 0, 2.2}, {0, 0, 1.9}, {0, 0, 3}, {0, 0, 2}};
  std::vector<int> loaded;
  const DepthError e = tracked_depth_error({tr}, [&](int f) {
    loaded.push_back(f);
    return depth;
  });
  EXPECT_EQ(loaded, (std::vector<int>{3, 4, 5, 6}));
  EXPECT_EQ(e.observations, 4);
  EXPECT_EQ(e.evaluated, 2);
  EXPECT_NEAR(e.median_relative, 0.075, 1e-6);  // errors 10 % and 5 %
  EXPECT_NEAR(e.mean_relative, 0.075, 1e-6);
  EXPECT_NEAR(e.median_signed_relative, 0.025, 1e-6);
}
