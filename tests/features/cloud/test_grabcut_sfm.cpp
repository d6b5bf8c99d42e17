// GrabCutSFM (paper 001) and its baselines on a scene built here: a red box standing on a grey textured
// ground plane in front of a textured wall, seen by one camera (pixel noise sd 8); the image is ray-cast from the same
// geometry that the cloud is sampled from, so the truth mask is exact.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "smseg/common/error.hpp"
#include "smseg/cloud/grabcut_sfm.hpp"

using namespace smseg;
using namespace smseg::sequence;
using namespace smseg::frontend;
using namespace smseg::cloud;

namespace {

/// Grey texture in 10 cm cells: a hashed grey level in [base - amp, base + amp].
double texture(double a, double b, double base, double amp) {
  const auto ia = static_cast<long>(std::floor(a * 10)), ib = static_cast<long>(std::floor(b * 10));
  std::uint64_t h = std::uint64_t(ia * 73856093L) ^ std::uint64_t(ib * 19349663L);
  h = (h ^ (h >> 13)) * 0x5bd1e995ull;
  h ^= h >> 15;
  return base + amp * (double(h % 1000) / 500.0 - 1.0);
}

struct Scene {
  // Box: centre (bx, h / 2, bz), side s; ground y = 0 over x in [-3, 3], z in [0, 8]; wall z = 8.
  double bx = 0.0, bz = 2.4, s = 0.7;
  std::vector<Eigen::Vector3f> cloud;
  std::vector<int> cloud_label;  // 0 ground, 1 box, 2 wall
  cv::Mat image, truth;
  PinholeIntrinsics k{150, 150, 79.5, 59.5};
  Pose pose;
};

/// Camera at (0, 1.2, 0) looking along +Z, pitched down by `pitch` radians.
Pose camera(double pitch, double yaw = 0) {
  const double c = std::cos(pitch), s = std::sin(pitch), cy = std::cos(yaw), sy = std::sin(yaw);
  // Columns: camera x (right), y (down), z (forward) in the world (Y up); then a yaw about world Y.
  const Eigen::Matrix3d base = (Eigen::Matrix3d() << -1, 0, 0, 0, -c, -s, 0, -s, c).finished();
  const Eigen::Matrix3d yawm = (Eigen::Matrix3d() << cy, 0, sy, 0, 1, 0, -sy, 0, cy).finished();
  const Eigen::Matrix3d R = yawm * base;
  Pose p;
  for (int r = 0; r < 3; ++r)
    for (int q = 0; q < 3; ++q) p.R[std::size_t(r * 3 + q)] = R(r, q);
  p.t = {0, 1.2, 0};
  return p;
}

Scene make_scene(std::uint64_t seed = 5) {
  Scene sc;
  sc.pose = camera(0.35);
  const int W = 160, H = 120;
  const Eigen::Vector3d lo(sc.bx - sc.s / 2, 0, sc.bz - sc.s / 2), hi(sc.bx + sc.s / 2, sc.s, sc.bz + sc.s / 2);
  const Eigen::Matrix3d R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(sc.pose.R.data());
  const Eigen::Vector3d o(sc.pose.t[0], sc.pose.t[1], sc.pose.t[2]);
  sc.image.create(H, W, CV_8UC3);
  sc.truth = cv::Mat::zeros(H, W, CV_8UC1);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const Eigen::Vector3d d = R * Eigen::Vector3d((u - sc.k.cx) / sc.k.fx, (v - sc.k.cy) / sc.k.fy, 1);
      double best = 1e9;
      cv::Vec3b colour(200, 200, 200);  // sky
      // Box (slab test).
      double t0 = 0, t1 = 1e9;
      int axis = -1;
      for (int a = 0; a < 3; ++a) {
        if (std::abs(d[a]) < 1e-12) {
          if (o[a] < lo[a] || o[a] > hi[a]) t0 = 2e9;
          continue;
        }
        double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
        if (ta > tb) std::swap(ta, tb);
        if (ta > t0) {
          t0 = ta;
          axis = a;
        }
        t1 = std::min(t1, tb);
      }
      if (t0 <= t1 && t0 > 0 && t0 < best) {
        best = t0;
        const std::uint8_t shade = std::uint8_t(axis == 1 ? 210 : axis == 0 ? 170 : 190);
        colour = cv::Vec3b(40, 40, shade);  // BGR: red
        sc.truth.at<std::uint8_t>(v, u) = 255;
      }
      if (d.y() < 0) {  // ground
        const double t = -o.y() / d.y();
        const Eigen::Vector3d p = o + t * d;
        if (t < best && std::abs(p.x()) <= 3 && p.z() >= 0 && p.z() <= 8) {
          best = t;
          const auto g = std::uint8_t(texture(p.x(), p.z(), 120, 15));
          colour = cv::Vec3b(g, g, g);
          sc.truth.at<std::uint8_t>(v, u) = 0;
        }
      }
      if (d.z() > 0) {  // wall
        const double t = (8 - o.z()) / d.z();
        const Eigen::Vector3d p = o + t * d;
        if (t < best && std::abs(p.x()) <= 3 && p.y() >= 0 && p.y() <= 3) {
          best = t;
          const auto g = std::uint8_t(texture(p.x(), p.y(), 140, 15));
          colour = cv::Vec3b(std::uint8_t(g + 10), g, g);
          sc.truth.at<std::uint8_t>(v, u) = 0;
        }
      }
      sc.image.at<cv::Vec3b>(v, u) = colour;
    }
  // Camera noise: sd 8 grey levels per channel.
  cv::Mat noise(sc.image.size(), CV_16SC3);
  cv::RNG(seed).fill(noise, cv::RNG::NORMAL, 0, 8);
  cv::Mat img16;
  sc.image.convertTo(img16, CV_16SC3);
  cv::Mat(img16 + noise).convertTo(sc.image, CV_8UC3);
  // The cloud: ground, the box's five visible faces, the wall; 5 mm noise.
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  std::normal_distribution<double> N(0, 0.005);
  const auto add = [&](double x, double y, double z, int label) {
    sc.cloud.emplace_back(float(x + N(rng)), float(y + N(rng)), float(z + N(rng)));
    sc.cloud_label.push_back(label);
  };
  for (int i = 0; i < 1500; ++i) {
    const double x = -3 + 6 * U(rng), z = 8 * U(rng);
    if (x > lo.x() && x < hi.x() && z > lo.z() && z < hi.z()) continue;
    add(x, 0, z, 0);
  }
  for (int i = 0; i < 400; ++i) {
    const int face = int(U(rng) * 5);
    const double a = U(rng) * sc.s, b = U(rng) * sc.s;
    if (face == 0) add(lo.x() + a, hi.y(), lo.z() + b, 1);        // top
    else if (face == 1) add(lo.x() + a, b, lo.z(), 1);            // front
    else if (face == 2) add(lo.x() + a, b, hi.z(), 1);            // back
    else if (face == 3) add(lo.x(), b, lo.z() + a, 1);            // sides
    else add(hi.x(), b, lo.z() + a, 1);
  }
  for (int i = 0; i < 600; ++i) add(-3 + 6 * U(rng), 3 * U(rng), 8, 2);
  return sc;
}

// The supporting plane (the ground) and the 1 m band of points standing on it, Euclidean clusters: the
// box scene's parameters for the height-band tests.
GrabCutSfmParams standing_on_the_ground() {
  GrabCutSfmParams p = GrabCutSfmParams::paper();
  p.height_band = 1.0;
  p.support_radius = 0.3;
  p.euclidean = true;
  p.cluster_tolerance = 0.15;
  return p;
}

cv::Rect truth_box(const cv::Mat& truth) {
  std::vector<cv::Point> pts;
  cv::findNonZero(truth, pts);
  return cv::boundingRect(pts);
}

}  // namespace

TEST(GrabCutSfm, SceneHasAClearObject) {
  const Scene sc = make_scene();
  const int object = cv::countNonZero(sc.truth);
  EXPECT_GT(object, 1000);                      // about 10% of the 160 x 120 frame
  EXPECT_LT(object, 160 * 120 / 4);
  const cv::Rect b = truth_box(sc.truth);
  EXPECT_GT(b.x, 5);                            // framed, not touching the border
  EXPECT_LT(b.br().x, 155);
}

TEST(GrabCutSfm, SegmentsTheNearestObjectAndTheBaselinesToo) {
  const Scene sc = make_scene();
  GrabCutSfmParams p = GrabCutSfmParams::paper();
  GrabCutSfmReport rep;
  const cv::Mat mask = grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &rep);
  ASSERT_EQ(mask.size(), sc.image.size());
  ASSERT_EQ(mask.type(), CV_8UC1);
  const double f1 = mask_f1(mask, sc.truth);
  EXPECT_GE(f1, 0.9);

  // The plane removed is the ground: nearly all ground points, almost nothing else.
  int ground = 0;
  for (int l : sc.cloud_label) ground += l == 0;
  EXPECT_GE(rep.plane_inliers, int(0.95 * ground));
  EXPECT_LE(rep.plane_inliers, ground + 60);  // the box's bottom 5 cm band at most
  EXPECT_NEAR(std::abs(rep.plane[1]), 1.0, 0.01);  // normal along world Y
  EXPECT_EQ(int(rep.cluster_sizes.size()), 6);
  // The chosen cluster is the box's (about 2.5 m away; the wall is 8 m away).
  ASSERT_GE(rep.chosen, 0);
  EXPECT_LT(rep.cluster_distances[std::size_t(rep.chosen)], 3.5);
  // The box covers the object.
  const cv::Rect tb = truth_box(sc.truth);
  EXPECT_GE((rep.box & tb).area(), int(0.9 * tb.area()));
  EXPECT_GT(rep.seconds_total, 0);

  const double f1_box = mask_f1(grabcut_box(sc.image, tb, 5, 1), sc.truth);
  EXPECT_GE(f1_box, 0.9);
  cv::Mat clusters;
  const cv::Mat km = kmeans2_colour(sc.image, 1, &clusters);
  EXPECT_GE(mask_f1(km, sc.truth), 0.9);
  EXPECT_EQ(clusters.size(), sc.image.size());
  std::cout << "F1 on the box scene: grabcut-sfm " << f1 << ", kmeans2 " << mask_f1(km, sc.truth)
            << ", grabcut on the truth box " << f1_box << "\n";

  const cv::Mat overlay = grabcut_sfm_overlay(sc.image, mask, rep);
  EXPECT_EQ(overlay.size(), sc.image.size());
  EXPECT_EQ(overlay.type(), CV_8UC3);
}

TEST(GrabCutSfm, SameSeedSameMask) {
  const Scene sc = make_scene();
  GrabCutSfmParams p = GrabCutSfmParams::paper();
  p.seed = 9;
  GrabCutSfmReport a, b;
  const cv::Mat m1 = grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &a);
  const cv::Mat m2 = grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &b);
  EXPECT_EQ(cv::countNonZero(m1 != m2), 0);
  EXPECT_EQ(a.cluster_sizes, b.cluster_sizes);
  EXPECT_EQ(a.box, b.box);
  EXPECT_EQ(a.plane_inliers, b.plane_inliers);
}

TEST(GrabCutSfm, WithoutPlaneRemovalTheGroundJoinsTheNearestCluster) {
  // 001 III-B: the support surface's many points draw k-means off the object. Without plane removal the
  // nearest cluster mixes the box with the ground around it and its box grows well beyond the object's;
  // with it, the box fits the object (GrabCut's colour models still find this red box in either box).
  const Scene sc = make_scene();
  GrabCutSfmParams p = GrabCutSfmParams::paper();
  GrabCutSfmReport with, without;
  grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &with);
  p.plane_distance = 0;
  grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &without);
  EXPECT_EQ(without.plane_inliers, 0);
  const cv::Rect tb = truth_box(sc.truth);
  EXPECT_LT(with.box.area(), 2 * tb.area()) << with.box << " " << tb;
  EXPECT_GT(without.box.area(), 2 * tb.area()) << without.box << " " << tb;
}

TEST(GrabCutSfm, PlaneRansacFindsATiltedPlaneAmongOutliers) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> U(-1, 1);
  std::vector<Eigen::Vector3f> pts;
  const Eigen::Vector3d n = Eigen::Vector3d(0.2, 1, -0.3).normalized();
  const Eigen::Vector3d a = n.unitOrthogonal(), b = n.cross(a);
  for (int i = 0; i < 300; ++i) pts.push_back((U(rng) * a + U(rng) * b + 0.5 * n).cast<float>());
  for (int i = 0; i < 200; ++i) {  // off the plane by more than 0.05
    const double off = (0.1 + 0.9 * std::abs(U(rng))) * (U(rng) < 0 ? -1 : 1);
    pts.push_back((U(rng) * a + U(rng) * b + (0.5 + off) * n).cast<float>());
  }
  Eigen::Vector4d pl;
  const std::vector<char> in = ransac_plane(pts, 0.02, 200, 1, &pl);
  for (int i = 0; i < 500; ++i) EXPECT_EQ(bool(in[std::size_t(i)]), i < 300) << i;
  EXPECT_NEAR(std::abs(pl.head<3>().dot(n)), 1.0, 1e-6);
}

TEST(GrabCutSfm, KmeansSeparatesBlobsAndNumbersThemByFirstPoint) {
  std::mt19937_64 rng(4);
  std::normal_distribution<float> N(0, 0.1f);
  const float cx[3] = {0, 5, 0}, cy[3] = {0, 0, 5};
  std::vector<float> data;
  std::vector<int> truth;
  for (int i = 0; i < 300; ++i) {
    const int c = (i * 7) % 3;
    data.push_back(cx[c] + N(rng));
    data.push_back(cy[c] + N(rng));
    truth.push_back(c);
  }
  std::vector<float> centres;
  const std::vector<int> l = kmeans(data, 2, 3, 3, 50, 11, &centres);
  // Points 0, 1, 2 are in blobs 0, 1, 2 (i * 7 mod 3): labels 0, 1, 2 exactly.
  EXPECT_EQ(l, truth);
  EXPECT_NEAR(centres[2], 5, 0.05);  // cluster 1's x
  EXPECT_THROW(kmeans(std::vector<float>{1, 2}, 2, 3, 1, 10, 1), Error);
}

TEST(GrabCutSfm, RansacTwoDDropsFarProjections) {
  std::mt19937_64 rng(6);
  std::normal_distribution<float> N(0, 5);
  std::vector<cv::Point2f> pts;
  for (int i = 0; i < 100; ++i) pts.emplace_back(100 + N(rng), 80 + 2 * N(rng));
  pts.emplace_back(300, 80);
  pts.emplace_back(100, 300);
  pts.emplace_back(0, 0);
  const std::vector<char> in = compact_inliers_2d(pts, 3, 200, 1);
  int kept = 0;
  for (int i = 0; i < 100; ++i) kept += in[std::size_t(i)];
  EXPECT_GE(kept, 97);
  EXPECT_FALSE(in[100]);
  EXPECT_FALSE(in[101]);
  EXPECT_FALSE(in[102]);
}

TEST(GrabCutSfm, MaskF1IgnoresVoid) {
  cv::Mat truth = cv::Mat::zeros(2, 3, CV_8UC1), pred = truth.clone(), ignore = truth.clone();
  truth.at<std::uint8_t>(0, 0) = truth.at<std::uint8_t>(0, 1) = 255;
  pred.at<std::uint8_t>(0, 0) = pred.at<std::uint8_t>(1, 0) = pred.at<std::uint8_t>(1, 1) = 255;
  EXPECT_DOUBLE_EQ(mask_f1(pred, truth), 2.0 / 5.0);  // tp 1, fp 2, fn 1
  ignore.at<std::uint8_t>(1, 1) = 1;
  EXPECT_DOUBLE_EQ(mask_f1(pred, truth, ignore), 2.0 / 4.0);
  EXPECT_TRUE(std::isnan(mask_f1(cv::Mat::zeros(2, 3, CV_8UC1), cv::Mat::zeros(2, 3, CV_8UC1))));
  EXPECT_THROW(mask_f1(pred, cv::Mat::zeros(3, 3, CV_8UC1)), Error);
}

TEST(GrabCutSfm, BadInputIsAnError) {
  const Scene sc = make_scene();
  GrabCutSfmParams p = GrabCutSfmParams::paper();
  EXPECT_THROW(grabcut_sfm({}, sc.k, sc.pose, sc.image, p), Error);  // empty cloud
  try {  // looking away from the scene: every point behind the camera
    grabcut_sfm(sc.cloud, sc.k, camera(0.0, M_PI), sc.image, p);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.reason()).find("in front of the camera"), std::string::npos) << e.what();
  }
  std::vector<Eigen::Vector3f> few(sc.cloud.begin(), sc.cloud.begin() + 4);
  EXPECT_THROW(grabcut_sfm(few, sc.k, sc.pose, sc.image, p), Error);  // 4 points, k = 6
  p.k = 0;
  EXPECT_THROW(grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p), Error);
  EXPECT_THROW(grabcut_sfm(sc.cloud, PinholeIntrinsics{0, 0, 1, 1}, sc.pose, sc.image, GrabCutSfmParams::paper()), Error);
  EXPECT_THROW(grabcut_box(sc.image, cv::Rect(500, 500, 10, 10), 3, 1), Error);
}

TEST(GrabCutSfm, WindowCloudAveragesTheTracksSeenNearTheFrame) {
  // Six posed frames (camera f at world x = f, not rotated); track A seen in frames 0 and 1 at one world point,
  // track B only in frame 1, track C only in frame 5 (outside a window of 1 around frame 0), track D
  // without a 3D point (disparity 0).
  FrontEndResult fe;
  fe.first_frame = 0;
  fe.poses.resize(6);
  for (int f = 0; f < 6; ++f) fe.poses[std::size_t(f)].t = {double(f), 0, 0};
  const auto track = [](std::vector<int> frames, std::vector<Eigen::Vector3d> pts, float d = 1) {
    Track t;
    t.frames = frames;
    t.points = pts;
    t.disparities.assign(frames.size(), d);
    t.pixels.assign(frames.size(), cv::Point2f(0, 0));
    t.labels.assign(frames.size(), -1);
    return t;
  };
  fe.tracks.push_back(track({0, 1}, {{2, 0, 5}, {1, 0, 5}}));  // world (2, 0, 5) seen from x = 0 and x = 1
  fe.tracks.push_back(track({1}, {{0, 1, 3}}));                // world (1, 1, 3)
  fe.tracks.push_back(track({5}, {{0, 0, 1}}));
  fe.tracks.push_back(track({0}, {{0, 0, 1}}, 0.f));
  const std::vector<Eigen::Vector3f> c = window_cloud(fe, 0, 1);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_TRUE(c[0].isApprox(Eigen::Vector3f(2, 0, 5)));
  EXPECT_TRUE(c[1].isApprox(Eigen::Vector3f(1, 1, 3)));
  EXPECT_EQ(window_cloud(fe, 0, 10).size(), 3u);  // C joins; D never (no 3D point)
}

TEST(GrabCutSfm, PlaneRansacFacingUpSkipsALargerWall) {
  // A wall (x = 1, 400 points, off the floor) and a floor (y = 0, 200 points): unconstrained RANSAC takes the wall; with
  // normals restricted to within 30 degrees of +Y it takes the floor.
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<float> U(-1, 1);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 400; ++i) pts.emplace_back(1.f, 1.5f + U(rng), 2 + U(rng));  // 0.5-2.5 m high
  for (int i = 0; i < 200; ++i) pts.emplace_back(U(rng) * 0.9f, 0.f, 2 + U(rng));
  Eigen::Vector4d pl;
  const std::vector<char> any = ransac_plane(pts, 0.02, 200, 1, &pl);
  EXPECT_NEAR(std::abs(pl[0]), 1.0, 1e-6);
  EXPECT_TRUE(any[0]);
  const std::vector<char> up = ransac_plane(pts, 0.02, 200, 1, &pl, Eigen::Vector3d::UnitY(), std::cos(M_PI / 6));
  EXPECT_NEAR(std::abs(pl[1]), 1.0, 1e-6);
  for (int i = 0; i < 600; ++i) EXPECT_EQ(bool(up[std::size_t(i)]), i >= 400) << i;
}

TEST(GrabCutSfm, EuclideanClustersChainNeighboursAndDropSmallOnes) {
  // Two lines of points 2 cm apart, 1 m from each other, and two isolated points.
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 20; ++i) {
    pts.emplace_back(-1.f + 0.02f * float(i), 0.f, 0.f);  // line A (0.38 m long: chained, not within 3 cm end to end)
    pts.emplace_back(1.f, 0.02f * float(i), 0.f);        // line B
  }
  pts.emplace_back(0.f, 0.f, 5.f);
  pts.emplace_back(0.f, 0.5f, -5.f);
  const std::vector<int> l = euclidean_clusters(pts, 0.03, 5);
  ASSERT_EQ(l.size(), pts.size());
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(l[std::size_t(2 * i)], 0) << i;      // numbered by first point: line A is 0
    EXPECT_EQ(l[std::size_t(2 * i + 1)], 1) << i;  // line B is 1
  }
  EXPECT_EQ(l[40], -1);  // alone: below min_size
  EXPECT_EQ(l[41], -1);
  EXPECT_EQ(euclidean_clusters(pts, 0.01, 5), std::vector<int>(42, -1));  // 2 cm steps: nothing chains
}

TEST(GrabCutSfm, HeightBandKeepsThePointsStandingOnTheSupportingPlane) {
  // The ground faces up (the camera's up within 20 degrees): it is the supporting plane; the band 0.05-1 m
  // above it within 0.3 m of a ground point's foot holds the box and the wall's foot, not the wall above 1 m.
  const Scene sc = make_scene();
  GrabCutSfmParams p = standing_on_the_ground();
  GrabCutSfmReport rep;
  const cv::Mat mask = grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &rep);
  EXPECT_EQ(rep.support, 0);
  ASSERT_FALSE(rep.planes.empty());
  EXPECT_GT(rep.planes[0][1], 0.99);  // faces up, oriented towards the camera
  int box = 0, wall_low = 0;
  for (std::size_t i = 0; i < sc.cloud.size(); ++i) {
    box += sc.cloud_label[i] == 1 && sc.cloud[i].y() > 0.06f;
    wall_low += sc.cloud_label[i] == 2 && sc.cloud[i].y() <= 1.01f;
  }
  EXPECT_GE(rep.in_band, int(0.9 * box));
  EXPECT_LE(rep.in_band, box + wall_low + 20);
  ASSERT_GE(rep.chosen, 0);
  EXPECT_LT(rep.cluster_distances[std::size_t(rep.chosen)], 3.5);
  EXPECT_GE(mask_f1(mask, sc.truth), 0.9);
  // No plane can face up within 0 degrees: one clear error.
  p.max_tilt = 0;
  try {
    grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.reason()).find("supporting plane"), std::string::npos) << e.what();
  }
  p.max_tilt = 30;
  p.height_band = 0.01;  // not above --plane-distance
  EXPECT_THROW(grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p), Error);
}

TEST(GrabCutSfm, WorldUpFindsTheGroundWhereTheCamerasUpIsTooTilted) {
  // The camera looks 20 degrees down at level ground: within 10 degrees of the camera's up there is no
  // plane; within 10 degrees of world +Y (a world levelled by extract-features --gravity estimate) the
  // ground is found, by one-point hypotheses normal to +Y.
  const Scene sc = make_scene();
  GrabCutSfmParams p = standing_on_the_ground();
  p.max_tilt = 10;
  EXPECT_THROW(grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p), Error);
  p.world_up = true;
  GrabCutSfmReport rep;
  const cv::Mat mask = grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &rep);
  ASSERT_FALSE(rep.planes.empty());
  EXPECT_GT(rep.planes[0][1], std::cos(M_PI / 180));  // the ground, within a degree
  EXPECT_GE(mask_f1(mask, sc.truth), 0.9);
}

TEST(GrabCutSfm, PlaneRansacWithAKnownUpTakesTheFloorAndKeepsItsNormalClose) {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<float> U(-1, 1);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 400; ++i) pts.emplace_back(1.f, 1.5f + U(rng), 2 + U(rng));  // a larger wall
  for (int i = 0; i < 200; ++i) pts.emplace_back(U(rng) * 0.9f, 0.01f * U(rng), 2 + U(rng));  // a noisy floor
  Eigen::Vector4d pl;
  const std::vector<char> in = ransac_plane(pts, 0.02, 50, 1, &pl, Eigen::Vector3d::UnitY(), std::cos(M_PI / 90), true);
  EXPECT_GT(pl[1], std::cos(M_PI / 90));
  for (int i = 0; i < 600; ++i) EXPECT_EQ(bool(in[std::size_t(i)]), i >= 400) << i;
}

TEST(GrabCutSfm, BoxToPlaneReachesDownToTheObjectsFoot) {
  // Only the box's upper part (above 0.45 m of its 0.7 m) has points, as when its lower part is untracked:
  // the inlier box stops short of the object's bottom edge; with box_to_plane the feet of those points on
  // the ground plane take it down to the bottom of the object.
  Scene sc = make_scene();
  std::vector<Eigen::Vector3f> cloud;
  for (std::size_t i = 0; i < sc.cloud.size(); ++i)
    if (sc.cloud_label[i] != 1 || sc.cloud[i].y() > 0.45f) cloud.push_back(sc.cloud[i]);
  GrabCutSfmParams p = standing_on_the_ground();
  p.box_margin = 0;
  GrabCutSfmReport without, with;
  grabcut_sfm(cloud, sc.k, sc.pose, sc.image, p, &without);
  p.box_to_plane = true;
  grabcut_sfm(cloud, sc.k, sc.pose, sc.image, p, &with);
  const cv::Rect tb = truth_box(sc.truth);
  EXPECT_EQ(without.feet_in_box, 0);
  EXPECT_GT(with.feet_in_box, 0);
  EXPECT_LT(without.inlier_box.br().y, tb.br().y - 5);
  EXPECT_GE(with.box.br().y, tb.br().y - 2);
  EXPECT_GE((with.box & tb).area(), int(0.9 * tb.area()));
}

TEST(GrabCutSfm, DenseFrameCloudPutsEachSampledDepthPixelInTheWorld) {
  // The box scene's camera (1.2 m up, pitched 20 degrees down) seeing a depth of 2 m everywhere but a hole.
  const Scene sc = make_scene();
  Calibration c;
  c.fx = sc.k.fx;
  c.fy = sc.k.fy;
  c.cx = sc.k.cx;
  c.cy = sc.k.cy;
  cv::Mat depth(120, 160, CV_32FC1, cv::Scalar(2));
  depth.at<float>(0, 0) = 0;
  const std::vector<Eigen::Vector3f> all = dense_frame_cloud(depth, c, sc.pose, 1);
  EXPECT_EQ(all.size(), 160u * 120u - 1);
  const std::vector<Eigen::Vector3f> every4 = dense_frame_cloud(depth, c, sc.pose, 4);
  EXPECT_EQ(every4.size(), 40u * 30u - 1);  // (0, 0) is the hole
  // Each point lies at depth 2 m along the camera's optical axis and projects back onto its pixel.
  const Eigen::Matrix3d R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(sc.pose.R.data());
  const Eigen::Vector3d o(sc.pose.t[0], sc.pose.t[1], sc.pose.t[2]);
  const Eigen::Vector3d in_camera = R.transpose() * (every4[0].cast<double>() - o);  // pixel (4, 0)
  EXPECT_NEAR(in_camera.z(), 2, 1e-5);
  EXPECT_NEAR(sc.k.fx * in_camera.x() / in_camera.z() + sc.k.cx, 4, 1e-4);
  EXPECT_NEAR(sc.k.fy * in_camera.y() / in_camera.z() + sc.k.cy, 0, 1e-4);
  EXPECT_THROW(dense_frame_cloud(depth, c, sc.pose, 0), Error);
}

TEST(GrabCutSfm, SeveralPlanesTakeTheGroundThenTheWall) {
  // The ground first (the dominant plane), then the wall at z = 8 while it holds 10% of the points left;
  // a share of 1 stops after the ground.
  const Scene sc = make_scene();
  GrabCutSfmParams p = GrabCutSfmParams::paper();
  p.planes = 3;
  GrabCutSfmReport rep;
  grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &rep);
  ASSERT_GE(rep.planes.size(), 2u);
  EXPECT_GT(std::abs(rep.planes[0][1]), 0.99);  // ground: normal along Y
  EXPECT_GT(std::abs(rep.planes[1][2]), 0.99);  // wall: normal along Z
  int wall = 0;
  for (int l : sc.cloud_label) wall += l == 2;
  EXPECT_GE(rep.planes_inliers[1], int(0.9 * wall));
  EXPECT_EQ(rep.plane_inliers, rep.planes_inliers[0] + rep.planes_inliers[1] +
                                   (rep.planes.size() > 2 ? rep.planes_inliers[2] : 0));
  p.plane_min_share = 1;
  grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &rep);
  EXPECT_EQ(rep.planes.size(), 1u);
}

TEST(GrabCutSfm, PlaneRansacWithAnAgreeingCloudTakesThePlaneBothHold) {
  // Seen from above a table: the tracked cloud holds most points on a ledge 10 cm below the table top, the
  // dense one on the floor; each alone picks its own plane, together they pick the table (y = 0).
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<float> U(-1, 1);
  std::vector<Eigen::Vector3f> tracked, dense;
  for (int i = 0; i < 300; ++i) tracked.emplace_back(U(rng), -0.1f, 2 + 0.05f * U(rng));  // the ledge
  for (int i = 0; i < 200; ++i) tracked.emplace_back(U(rng), 0.f, 2 + U(rng));          // the table top
  for (int i = 0; i < 2000; ++i) dense.emplace_back(3 * U(rng), -0.75f, 2 + 2 * U(rng));  // the floor
  for (int i = 0; i < 1000; ++i) dense.emplace_back(U(rng), 0.f, 2 + U(rng));
  for (int i = 0; i < 50; ++i) dense.emplace_back(U(rng), -0.1f, 2 + 0.05f * U(rng));
  const Eigen::Vector3d up = Eigen::Vector3d::UnitY();
  const double min_cos = std::cos(M_PI / 36);
  Eigen::Vector4d pl;
  ransac_plane(tracked, 0.02, 100, 1, &pl, up, min_cos, true);
  EXPECT_NEAR(pl[3], 0.1, 1e-3);  // y = -0.1: the ledge
  ransac_plane(dense, 0.02, 100, 1, &pl, up, min_cos, true);
  EXPECT_NEAR(pl[3], 0.75, 1e-3);  // the floor
  const std::vector<char> in = ransac_plane(tracked, 0.02, 100, 1, &pl, up, min_cos, true, &dense);
  EXPECT_NEAR(pl[3], 0.0, 1e-3);  // the table
  for (int i = 0; i < 500; ++i) EXPECT_EQ(bool(in[std::size_t(i)]), i >= 300) << i;
}

TEST(GrabCutSfm, APlaneCloudFindsTheGroundWhereTheClusteredCloudSeesMoreOfALowerFloor) {
  // The clustered cloud also holds a large floor 0.6 m below the box's ground (as a frame's dense depth
  // sees the room's floor past a table): its own supporting plane is that floor and the band swallows the
  // ground. With the scene's own cloud as the plane cloud the ground is the supporting plane again, its
  // inliers go from the clustered cloud, and the box is found.
  const Scene sc = make_scene();
  std::vector<Eigen::Vector3f> cloud = sc.cloud;
  std::mt19937_64 rng(10);
  std::uniform_real_distribution<float> U(0, 1);
  for (int i = 0; i < 3000; ++i) cloud.emplace_back(-3 + 6 * U(rng), -0.6f, 8 * U(rng));
  GrabCutSfmParams p = standing_on_the_ground();
  p.world_up = true;
  p.max_tilt = 5;
  GrabCutSfmReport own, with;
  try {
    grabcut_sfm(cloud, sc.k, sc.pose, sc.image, p, &own);
    EXPECT_NEAR(own.planes.at(0)[3], 0.6, own.plane_distance);  // the lower floor
  } catch (const Error&) {  // or no cluster is left to choose: either way not the ground
  }
  const cv::Mat mask = grabcut_sfm(cloud, sc.k, sc.pose, sc.image, p, &with, &sc.cloud);
  ASSERT_FALSE(with.planes.empty());
  EXPECT_NEAR(with.planes[0][3], 0.0, with.plane_distance);  // the ground (within the inlier distance)
  EXPECT_GE(with.planes_inliers[0], 1400);     // its points, removed from the clustered cloud
  EXPECT_GE(mask_f1(mask, sc.truth), 0.9);
  const std::vector<Eigen::Vector3f> too_few(sc.cloud.begin(), sc.cloud.begin() + 2);
  EXPECT_THROW(grabcut_sfm(cloud, sc.k, sc.pose, sc.image, p, nullptr, &too_few), Error);
}

namespace {

/// A room seen from a camera 1.15 m above the floor and 1.5 m from a table: the floor (4 x 4 m, the
/// largest horizontal plane), a 1.2 x 0.8 m table top 0.75 m up, two boxes on it (one 0.2 m tall, one
/// 0.1 m) and a wall; points every 2 cm with 3 mm noise. With `walls_around`, the wall's rows are
/// `wall_rows` cm apart, it is 3 m wide and two more stand at the sides (x = +-2 m, 0.5 m clear of it).
std::vector<Eigen::Vector3f> room_with_a_table(std::uint64_t seed, bool walls_around = false, double wall_rows = 2) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> N(0, 0.003);
  std::vector<Eigen::Vector3f> c;
  const auto add = [&](double x, double y, double z) {
    c.emplace_back(float(x + N(rng)), float(y + N(rng)), float(z + N(rng)));
  };
  for (double x = -2; x <= 2; x += 0.02)
    for (double z = -2; z <= 2; z += 0.02)
      if (std::abs(x) > 0.6 || std::abs(z) > 0.4) add(x, 0, z);  // the floor, under the table hidden
  for (double x = -0.6; x <= 0.6; x += 0.02)
    for (double z = -0.4; z <= 0.4; z += 0.02) add(x, 0.75, z);  // the table top
  for (double a = 0; a <= 0.2; a += 0.02)
    for (double h = 0; h <= 0.2; h += 0.02) {
      add(-0.3 + a, 0.75 + h, -0.1);  // box 1's front face and top
      add(-0.3 + a, 0.95, -0.1 + h);
      add(0.2 + a, 0.75 + std::min(h, 0.1), 0.1);  // box 2, 10 cm tall
    }
  const double half_wall = walls_around ? 1.5 : 2;
  for (double x = -half_wall; x <= half_wall; x += 0.02)
    for (double y = 0; y <= 2.5; y += 0.01 * wall_rows) add(x, y, 2);  // a wall behind the table
  for (double z = -2; walls_around && z <= 1.5; z += 0.02)
    for (double y = 0; y <= 2.5; y += 0.01 * wall_rows) {
      add(-2, y, z);
      add(2, y, z);
    }
  return c;
}

}  // namespace

TEST(FindTable, TheTableIsTheHighestWidePatchWithPointsStandingOnItNotTheLargestPlane) {
  const auto cloud = room_with_a_table(3);
  const Eigen::Vector3d camera(0, 1.15, -1.5);
  const TablePlane t = find_table(cloud, camera, Eigen::Vector3d::UnitY());
  ASSERT_TRUE(t.found);
  EXPECT_NEAR(-t.plane[3] / t.plane[1], 0.75, 0.01);  // the table top, not the floor (y = 0)
  EXPECT_NEAR(t.camera_height, 0.40, 0.01);
  EXPECT_GT(t.standing, 100);                          // the boxes
  EXPECT_GT(t.width, 0.5);
  EXPECT_TRUE(t.under(Eigen::Vector3d(-0.2, 0.9, -0.05)));  // above a box: inside the table's outline
  EXPECT_FALSE(t.under(Eigen::Vector3d(1.5, 0.9, 0.0)));    // beside the table
  // The slab is a share of the distance from the camera (1.25-2 m here): 2-3 cm, not a set number of metres.
  EXPECT_GT(t.thickness, 0.015);
  EXPECT_LT(t.thickness, 0.04);
}

TEST(FindTable, ScalesWithTheScene) {
  // The same room twice as large, seen from twice as far: the same table, at twice the height.
  auto cloud = room_with_a_table(4);
  for (auto& p : cloud) p *= 2;
  const TablePlane t = find_table(cloud, Eigen::Vector3d(0, 2.3, -3.0), Eigen::Vector3d::UnitY());
  ASSERT_TRUE(t.found);
  EXPECT_NEAR(-t.plane[3] / t.plane[1], 1.5, 0.02);
  // Without a table (the table top and boxes gone) the largest plane is returned, not found as a table.
  std::vector<Eigen::Vector3f> floor_only;
  for (const auto& p : room_with_a_table(5))
    if (p.y() < 0.5 && p.z() < 1.9) floor_only.push_back(p);
  const TablePlane f = find_table(floor_only, Eigen::Vector3d(0, 1.15, -1.5), Eigen::Vector3d::UnitY());
  EXPECT_FALSE(f.found);
  EXPECT_GT(f.inliers, 1000);
}

TEST(FindTable, ATableBelowAWallFillingTheViewIsFound) {
  // Three walls with rows 1.2 cm apart: at the table's height they hold more points than the table (a
  // table seen far off, below walls that fill the frame). The table's count is then under twice the
  // count three slabs above and below, but its own points, beyond that, are many.
  const auto cloud = room_with_a_table(3, true, 1.2);
  const Eigen::Vector3d camera(0, 1.15, -1.5);
  const TablePlane t = find_table(cloud, camera, Eigen::Vector3d::UnitY());
  ASSERT_TRUE(t.found);
  EXPECT_NEAR(-t.plane[3] / t.plane[1], 0.75, 0.01);
  TableParams ratio_only;
  ratio_only.min_prominence = 2;
  const TablePlane r = find_table(cloud, camera, Eigen::Vector3d::UnitY(), ratio_only);
  EXPECT_FALSE(r.found && std::abs(-r.plane[3] / r.plane[1] - 0.75) < 0.05);
}

TEST(FindTable, ATableSeenFromALowCameraIsOnePatch) {
  // A dense depth seen from 0.2 m above the table top: one point every 7 mrad (a level pinhole camera's
  // pixel grid), ray-cast onto the floor,
  // the table top (1.2 x 0.8 m, 0.75 m up) and a 0.2 m box on it. Its rows on the table lie 4-12 cm
  // apart along the line of sight, more than two slabs: the table is still one wide patch.
  const Eigen::Vector3d camera(0, 0.95, -1.2);
  std::vector<Eigen::Vector3f> cloud;
  for (double v = 0.05; v < 0.6; v += 0.007)  // a level pinhole camera's pixel rows and columns
    for (double u = -0.6; u <= 0.6; u += 0.007) {
      const Eigen::Vector3d d = Eigen::Vector3d(u, -v, 1).normalized();
      double best = 1e9;
      const double to_box = (-0.1 - camera.z()) / d.z();  // the box's front face, z = -0.1
      const Eigen::Vector3d b = camera + to_box * d;
      if (std::abs(b.x()) < 0.1 && b.y() > 0.75 && b.y() < 0.95) best = to_box;
      const double to_top = (0.75 - camera.y()) / d.y();
      const Eigen::Vector3d q = camera + to_top * d;
      if (to_top < best && std::abs(q.x()) <= 0.6 && std::abs(q.z()) <= 0.4) best = to_top;
      const double to_floor = -camera.y() / d.y();
      if (to_floor < best && to_floor < 6) best = to_floor;
      if (best < 1e9) cloud.push_back((camera + best * d).cast<float>());
    }
  const TablePlane t = find_table(cloud, camera, Eigen::Vector3d::UnitY());
  ASSERT_TRUE(t.found);
  EXPECT_NEAR(-t.plane[3] / t.plane[1], 0.75, 0.01);
  EXPECT_GT(t.width, 0.5);
}

TEST(CloudSpacing, IsTheDistanceToTheKthNeighbourOfAGrid) {
  std::vector<Eigen::Vector3f> grid;
  for (int i = 0; i < 30; ++i)
    for (int j = 0; j < 30; ++j) grid.emplace_back(0.01f * float(i), 0.01f * float(j), 0.f);
  EXPECT_NEAR(cloud_spacing(grid, 4), 0.01, 1e-4);         // 4 neighbours at 1 cm
  EXPECT_NEAR(cloud_spacing(grid, 8), 0.01 * std::sqrt(2.0), 1e-4);  // then 4 diagonals
  EXPECT_EQ(cloud_spacing({}, 4), 0.0);
}

TEST(GrabCutSfm, TheDefaultsNeedNoDistanceInMetres) {
  // The defaults (support table): the ground is the supporting plane (the highest wide patch with the box
  // standing on it), the clusters at the cloud's own spacing, the same box as 001's recipe.
  const Scene sc = make_scene();
  GrabCutSfmParams p;
  p.up = Eigen::Vector3d::UnitY();
  GrabCutSfmReport rep;
  const cv::Mat mask = grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &rep);
  EXPECT_TRUE(rep.table.found);
  EXPECT_NEAR(rep.planes[0][3], 0.0, 0.02);  // the ground, y = 0
  EXPECT_GT(rep.cluster_tolerance, 0.0);
  EXPECT_GE(mask_f1(mask, sc.truth), 0.9);
  // Scaled by 3 (a larger scene farther away), the same mask.
  Scene big = sc;
  for (auto& q : big.cloud) q *= 3;
  for (double& t : big.pose.t) t *= 3;
  GrabCutSfmReport rep3;
  const cv::Mat mask3 = grabcut_sfm(big.cloud, big.k, big.pose, big.image, p, &rep3);
  EXPECT_NEAR(rep3.cluster_tolerance, 3 * rep.cluster_tolerance, 1e-3 * rep.cluster_tolerance + 1e-6);
  EXPECT_GE(mask_f1(mask3, sc.truth), 0.9);
}

TEST(GrabCutSfm, WithATableTheBoxTakesTheFeetOnlyOfAnObjectStandingOnIt) {
  // The defaults: the box standing on the ground reaches down to its points' feet; the same points lifted
  // 0.3 m (an object at another level than the plane found, as a parked car beside a road's patch) do
  // not stand on it, and their feet would stretch the box far below them.
  Scene sc = make_scene();
  GrabCutSfmParams p;
  p.up = Eigen::Vector3d::UnitY();
  GrabCutSfmReport standing, lifted;
  grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &standing);
  EXPECT_GT(standing.feet_in_box, 0);
  for (std::size_t i = 0; i < sc.cloud.size(); ++i)
    if (sc.cloud_label[i] == 1) sc.cloud[i].y() += 0.3f;
  grabcut_sfm(sc.cloud, sc.k, sc.pose, sc.image, p, &lifted);
  EXPECT_EQ(lifted.feet_in_box, 0);
  EXPECT_GE(lifted.cluster_sizes[std::size_t(lifted.chosen)], standing.cluster_sizes[std::size_t(standing.chosen)]);  // the box, now whole above the slab
}

TEST(NearestInstance, IsTheObjectWithTheSmallestMedianDepth) {
  cv::Mat inst = cv::Mat::zeros(4, 6, CV_8UC1), depth(4, 6, CV_32FC1, cv::Scalar(5.f));
  inst(cv::Rect(0, 0, 2, 4)) = 1;
  depth(cv::Rect(0, 0, 2, 4)) = 2.f;
  depth.at<float>(0, 0) = 0.5f;  // one near pixel does not make object 1 the nearest
  inst(cv::Rect(3, 0, 3, 4)) = 2;
  depth(cv::Rect(3, 0, 3, 4)) = 1.5f;
  EXPECT_EQ(nearest_instance(inst, depth), 2);
  EXPECT_EQ(nearest_instance(cv::Mat::zeros(4, 6, CV_8UC1), depth), 0);
  const cv::Mat largest = largest_region((inst == 2) | ((inst == 1) & (depth > 1.f)));
  EXPECT_EQ(cv::countNonZero(largest), 12);  // object 2 (12 pixels) over object 1 (7)
}

TEST(GrabCutSfm, PointsLowOnTheTableDoNotChainTwoObjectsIntoOneCluster) {
  // The table of room_with_a_table, box 1 and a third box of its size beside it, joined by a patch of
  // points 4 cm above the table top (stereo errors on the table between them): one Euclidean cluster
  // with chain_rise 0; with the default, their points above 3 slabs are two clusters, and so are they.
  auto cloud = room_with_a_table(3);
  for (double a = 0; a <= 0.2; a += 0.02)
    for (double h = 0; h <= 0.2; h += 0.02) {
      cloud.emplace_back(float(0.05 + a), float(0.75 + h), -0.1f);  // box 3's front face and top
      cloud.emplace_back(float(0.05 + a), 0.95f, float(-0.1 + h));
    }
  for (double x = -0.1; x <= 0.05; x += 0.01)
    for (double z = -0.1; z <= 0.1; z += 0.01) cloud.emplace_back(float(x), 0.79f, float(z));
  Pose pose = camera(0.23);
  pose.t = {0, 1.15, -1.5};
  const PinholeIntrinsics k{150, 150, 79.5, 59.5};
  const cv::Mat image(120, 160, CV_8UC3, cv::Scalar(90, 120, 150));
  GrabCutSfmParams p;
  p.up = Eigen::Vector3d::UnitY();
  GrabCutSfmReport unchained, chained;
  grabcut_sfm(cloud, k, pose, image, p, &unchained);
  p.table.chain_rise = 0;
  grabcut_sfm(cloud, k, pose, image, p, &chained);
  ASSERT_TRUE(chained.table.found);
  EXPECT_EQ(unchained.cluster_sizes.size(), chained.cluster_sizes.size() + 1);
  const int largest = *std::max_element(chained.cluster_sizes.begin(), chained.cluster_sizes.end());
  EXPECT_GT(largest, 2 * 242);  // both boxes and the patch
  EXPECT_LT(*std::max_element(unchained.cluster_sizes.begin(), unchained.cluster_sizes.end()), largest / 2 + 100);
}
