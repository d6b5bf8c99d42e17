// Point-cloud features on analytic scenes (thesis 3.2.3): planes, a passing point, a moving point.
#include <gtest/gtest.h>

#include <random>

#include <Eigen/Geometry>

#include "smseg/stacks/point_features.hpp"

using namespace smseg::sequence;
using namespace smseg::stacks;

namespace {

constexpr double kF = 200.0, kCx = 159.5, kCy = 119.5;
const cv::Size kSize(320, 240);

// Camera looking along world -Z (camera x = world X, camera y = world -Y), centre c.
Pose camera_at(const Eigen::Vector3d& c) {
  Pose p;
  p.R = {1, 0, 0, 0, -1, 0, 0, 0, -1};
  p.t = {c.x(), c.y(), c.z()};
  return p;
}

Eigen::Vector3d to_camera(const Pose& p, const Eigen::Vector3d& w) {
  Eigen::Matrix3d R;
  R << p.R[0], p.R[1], p.R[2], p.R[3], p.R[4], p.R[5], p.R[6], p.R[7], p.R[8];
  return R.transpose() * (w - Eigen::Vector3d(p.t[0], p.t[1], p.t[2]));
}

// Adds an observation of world point w (track id) to frame f, if it projects inside the image.
bool observe(PointCloudVideo& v, int f, int track, const Eigen::Vector3d& w) {
  const Eigen::Vector3d c = to_camera(v.poses[f], w);
  if (c.z() <= 0.1) return false;
  Observation o;
  o.track = track;
  o.cam = c;
  o.x = static_cast<float>(kF * c.x() / c.z() + kCx);
  o.y = static_cast<float>(kF * c.y() / c.z() + kCy);
  if (o.x < 0 || o.y < 0 || o.x > kSize.width - 1 || o.y > kSize.height - 1) return false;
  v.observations[f].push_back(o);
  return true;
}

PointCloudVideo still_camera(int frames) {
  PointCloudVideo v;
  for (int f = 0; f < frames; ++f) v.poses.push_back(camera_at({0, 1, 0}));
  v.observations.resize(frames);
  return v;
}

}  // namespace

TEST(PointFeatures, HorizontalPlaneGivesItsHeight) {
  PointCloudVideo v = still_camera(1);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> ux(-2, 2), uz(-8, -2);
  int n = 0;
  for (int k = 0; k < 300; ++k) n += observe(v, 0, k, {ux(rng), 0.35, uz(rng)});
  ASSERT_GT(n, 100);
  const auto attrs = compute_point_attributes(v, {});
  const auto r = rasterise_features(v, attrs, 0, kSize);
  for (const auto& o : v.observations[0]) {
    const int x = static_cast<int>(std::lround(o.x)), y = static_cast<int>(std::lround(o.y));
    const double count = r[4].at<double>(y, x);
    EXPECT_NEAR(r[0].at<double>(y, x) / count, 0.35, 1e-9);  // fH per point
  }
  EXPECT_NEAR(cv::sum(r[4])[0], n, 1e-9);  // fD sums to the number of points
  EXPECT_NEAR(cv::sum(r[0])[0], 0.35 * n, 1e-6);
  EXPECT_EQ(cv::sum(r[5])[0], 0.0);  // a single frame: no residual
}

TEST(PointFeatures, OrientationOfPlanesWithKnownNormals) {
  // Floor (normal +Y), a wall at X = 1.5 (normal -X, facing the camera), and a tilted plane.
  struct Case {
    Eigen::Vector3d normal, point;
  };
  const Eigen::Vector3d tilted = Eigen::Vector3d(0.3, 0.5, 0.8).normalized();
  for (const Case& c : {Case{{0, 1, 0}, {0, 0, 0}}, Case{{-1, 0, 0}, {1.5, 0, 0}},
                        Case{tilted, {0, 1, -6}}}) {
    PointCloudVideo v = still_camera(1);
    std::mt19937 rng(2);
    std::uniform_real_distribution<double> u(-3, 3);
    // Two in-plane directions.
    const Eigen::Vector3d a = c.normal.unitOrthogonal(), b = c.normal.cross(a);
    // The foot of the perpendicular from (0, 1, -5) (in front of the camera) onto the plane.
    const Eigen::Vector3d ahead(0, 1, -5);
    const Eigen::Vector3d base = ahead - c.normal * c.normal.dot(ahead - c.point);
    int n = 0;
    for (int k = 0; k < 400; ++k) n += observe(v, 0, k, base + a * u(rng) + b * u(rng));
    ASSERT_GT(n, 30);
    const auto attrs = compute_point_attributes(v, {});
    const auto r = rasterise_features(v, attrs, 0, kSize);
    // The expected sign: the normal facing the camera.
    Eigen::Vector3d expect = c.normal;
    if (expect.dot(Eigen::Vector3d(0, 1, 0) - base) < 0) expect = -expect;
    // Pixels inside the hull: take the mean image position of the points.
    double mx = 0, my = 0;
    for (const auto& o : v.observations[0]) {
      mx += o.x;
      my += o.y;
    }
    const int x = static_cast<int>(mx / n), y = static_cast<int>(my / n);
    EXPECT_NEAR(r[2].at<double>(y, x), expect.x(), 1e-6);
    EXPECT_NEAR(r[3].at<double>(y, x), expect.y(), 1e-6);
  }
}

TEST(PointFeatures, StaticSceneHasNoResidualWhileAMovingPointStandsOut) {
  const int frames = 10;
  PointCloudVideo v;
  for (int f = 0; f < frames; ++f) v.poses.push_back(camera_at({0.02 * f, 1, -0.1 * f}));
  v.observations.resize(frames);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-2, 2), uy(0, 2.5), uz(-10, -4);
  std::vector<Eigen::Vector3d> world(100);
  for (auto& w : world) w = {ux(rng), uy(rng), uz(rng)};
  for (int f = 0; f < frames; ++f) {
    for (int k = 0; k < 100; ++k) observe(v, f, k, world[k]);
    observe(v, f, 1000, Eigen::Vector3d(-1 + 0.05 * f, 1.0, -6));  // a person walking 5 cm a frame
  }
  const auto attrs = compute_point_attributes(v, {});
  for (int f = 1; f < frames; ++f) {
    for (std::size_t i = 0; i < v.observations[f].size(); ++i) {
      if (v.observations[f][i].track == 1000) {
        EXPECT_NEAR(attrs.fR[f][i], 0.05, 1e-9);
      } else {
        EXPECT_NEAR(attrs.fR[f][i], 0.0, 1e-9);
      }
    }
  }
}

TEST(PointFeatures, ClosestApproachUsesTheFutureUnlessCausal) {
  // The camera drives along -Z at 10 cm a frame; a point 1.2 m to the side at Z = -5 is seen in the
  // first 10 frames only, but the camera passes it (at distance 1.2) at frame 50.
  const int frames = 80;
  PointCloudVideo v;
  for (int f = 0; f < frames; ++f) v.poses.push_back(camera_at({0, 1, -0.1 * f}));
  v.observations.resize(frames);
  const Eigen::Vector3d passed(1.2, 1, -5);
  for (int f = 0; f < 10; ++f) {
    ASSERT_TRUE(observe(v, f, 1, passed));
  }
  FeatureOptions def, causal;
  causal.causal = true;
  const auto a = compute_point_attributes(v, def);
  const auto c = compute_point_attributes(v, causal);
  for (int f = 0; f < 10; ++f) {
    EXPECT_NEAR(a.fC[f][0], 1.2, 1e-9);  // the future pass
    const double dist_now = (passed - Eigen::Vector3d(0, 1, -0.1 * f)).norm();
    EXPECT_NEAR(c.fC[f][0], dist_now, 1e-9);  // only the path so far
    EXPECT_GT(c.fC[f][0], a.fC[f][0] + 1.0);
  }
  // A camera that drives 8 frames towards a point and then backs away: the closest approach happens
  // while the point is seen, so at its last frame causal and default agree (the future does not matter).
  PointCloudVideo back;
  for (int f = 0; f < 30; ++f) back.poses.push_back(camera_at({0, 1, f < 8 ? -0.1 * f : -0.7 + 0.1 * (f - 7)}));
  back.observations.resize(30);
  const Eigen::Vector3d near(0.3, 1, -1.5);
  for (int f = 0; f < 8; ++f) ASSERT_TRUE(observe(back, f, 2, near)) << f;
  const auto ba = compute_point_attributes(back, def);
  const auto bc = compute_point_attributes(back, causal);
  EXPECT_NEAR(ba.fC[7][0], (near - Eigen::Vector3d(0, 1, -0.7)).norm(), 1e-9);
  EXPECT_NEAR(bc.fC[7][0], ba.fC[7][0], 1e-12);
  EXPECT_GT(bc.fC[0][0], ba.fC[0][0] + 0.5);  // but not in its first frame
  // Fewer future frames than needed to reach the point: the default cannot see the pass either.
  FeatureOptions short_future;
  short_future.future_frames = 20;
  const auto s = compute_point_attributes(v, short_future);
  EXPECT_NEAR(s.fC[0][0], (passed - Eigen::Vector3d(0, 1, -2.9)).norm(), 1e-9);  // frame 9 + 20
}

TEST(SummedAreaTables, RectangleSumsEqualBruteForceIncludingClippedOnes) {
  std::mt19937 rng(5);
  cv::Mat raster(37, 53, CV_64FC1);
  cv::randu(raster, -5, 5);
  const cv::Mat sat = summed_area_table(raster);
  ASSERT_EQ(sat.size(), cv::Size(54, 38));
  std::uniform_int_distribution<int> ux(-20, 70), uy(-20, 55);
  for (int k = 0; k < 2000; ++k) {
    int x0 = ux(rng), x1 = ux(rng), y0 = uy(rng), y1 = uy(rng);
    double brute = 0;
    for (int y = std::max(0, y0); y < std::min(37, y1); ++y)
      for (int x = std::max(0, x0); x < std::min(53, x1); ++x) brute += raster.at<double>(y, x);
    EXPECT_NEAR(rect_sum(sat, x0, y0, x1, y1), brute, 1e-9) << x0 << "," << y0 << "," << x1 << "," << y1;
  }
  // Every border.
  EXPECT_NEAR(rect_sum(sat, -5, -5, 100, 100), cv::sum(raster)[0], 1e-9);
}

TEST(PointFeatures, HeightsFromTheCameraFollowAPathThatDrifts) {
  // A camera path whose height drifts from 1 m to 3 m (a monocular reconstruction's drift), each frame
  // seeing points 1.2 m below its own camera (the road under the car) and 0.5 m above it. From the
  // ground plane their fH follows the drift; from the camera it is the cameras' median height (2 m)
  // minus 1.2 (or plus 0.5) in every frame. On a level path both references agree.
  const int frames = 5;
  PointCloudVideo v;
  for (int f = 0; f < frames; ++f) v.poses.push_back(camera_at({0, 1.0 + 0.5 * f, -1.0 * f}));
  v.observations.resize(frames);
  for (int f = 0; f < frames; ++f) {
    const double cy = v.poses[f].t[1], cz = v.poses[f].t[2];
    ASSERT_TRUE(observe(v, f, 2 * f, {0.3, cy - 1.2, cz - 4}));
    ASSERT_TRUE(observe(v, f, 2 * f + 1, {-0.3, cy + 0.5, cz - 6}));
  }
  FeatureOptions camera;
  camera.height_reference = HeightReference::Camera;
  const auto from_plane = compute_point_attributes(v, {});
  const auto from_camera = compute_point_attributes(v, camera);
  for (int f = 0; f < frames; ++f) {
    EXPECT_NEAR(from_plane.fH[f][0], 1.0 + 0.5 * f - 1.2, 1e-9);
    EXPECT_NEAR(from_camera.fH[f][0], 2.0 - 1.2, 1e-9) << "frame " << f;
    EXPECT_NEAR(from_camera.fH[f][1], 2.0 + 0.5, 1e-9) << "frame " << f;
    EXPECT_EQ(from_camera.fC[f], from_plane.fC[f]);  // only heights change
    EXPECT_EQ(from_camera.fR[f], from_plane.fR[f]);
  }
  // Causal features know only the frames so far: their reference is the first camera's height (1 m),
  // what a live stream takes (FeatureStream), not the run's median.
  camera.causal = true;
  EXPECT_EQ(reference_camera_height(camera, v.poses), 1.0);
  const auto causal = compute_point_attributes(v, camera);
  for (int f = 0; f < frames; ++f) EXPECT_NEAR(causal.fH[f][0], 1.0 - 1.2, 1e-9) << "frame " << f;
  camera.causal = false;
  PointCloudVideo level = still_camera(3);
  for (int f = 0; f < 3; ++f) ASSERT_TRUE(observe(level, f, f, {0.2 * f, 0.35, -3}));
  const auto a = compute_point_attributes(level, {}), b = compute_point_attributes(level, camera);
  for (int f = 0; f < 3; ++f) EXPECT_NEAR(a.fH[f][0], b.fH[f][0], 1e-12);
  EXPECT_EQ(height_reference_from_string("camera", "--height-reference"), HeightReference::Camera);
  EXPECT_EQ(to_string(HeightReference::Plane), "plane");
  EXPECT_THROW(height_reference_from_string("sky", "--height-reference"), smseg::Error);
}

TEST(PointFeatures, BadOptionsAreRefused) {
  FeatureOptions o;
  o.future_frames = -1;
  EXPECT_THROW(o.validate(), smseg::Error);
}
