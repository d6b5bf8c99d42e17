// GrabCutSFM's scene-relative defaults on clouds built here: a table top cut into pieces by the object
// standing on it (find_table joins them through the object's feet); what GrabCut's result says of the
// chosen cluster: a sheet of stereo errors with no object under it (passed over), two boxes chained by
// errors on the wall between them (only the nearer one's region kept), a farther object inside the box
// (its pixels dropped).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "smseg/cloud/grabcut_sfm.hpp"

using namespace smseg;
using namespace smseg::sequence;
using namespace smseg::cloud;

namespace {

/// Points every 2 cm with 3 mm noise.
struct Cloud {
  std::mt19937_64 rng{7};
  std::normal_distribution<double> noise{0, 0.003};
  std::vector<Eigen::Vector3f> points;
  void add(double x, double y, double z) {
    points.emplace_back(float(x + noise(rng)), float(y + noise(rng)), float(z + noise(rng)));
  }
  /// A box standing on the table top (y = 0.75) from x0 to x0 + 0.2: its front face (z = -0.1) from
  /// `lowest` up, and its top (in rows 4 cm apart: seen from 0.4 m above the table, at a grazing angle).
  void box(double x0, double lowest = 0, double z0 = -0.1) {
    for (double a = 0; a <= 0.2; a += 0.02)
      for (double h = 0; h <= 0.2; h += 0.02) {
        if (h >= lowest) add(x0 + a, 0.75 + h, z0);
        if (h <= 0.1) add(x0 + a, 0.95, z0 + 2 * h);
      }
  }
};

/// A 4 x 4 m floor (y = 0) and a 1.2 x 0.8 m table top 0.75 m up, without the parts of the table top
/// whose x lies in (gap_from, gap_to) (hidden behind an object seen from low).
Cloud floor_and_table(double gap_from = 1, double gap_to = 1) {
  Cloud c;
  for (double x = -2; x <= 2; x += 0.02)
    for (double z = -2; z <= 2; z += 0.02)
      if (std::abs(x) > 0.6 || std::abs(z) > 0.4) c.add(x, 0, z);
  for (double x = -0.6; x <= 0.6; x += 0.02)
    for (double z = -0.4; z <= 0.4; z += 0.02)
      if (x <= gap_from || x >= gap_to) c.add(x, 0.75, z);
  return c;
}

Pose camera_at(double pitch, double x, double y, double z) {
  const double c = std::cos(pitch), s = std::sin(pitch);
  const Eigen::Matrix3d R = (Eigen::Matrix3d() << -1, 0, 0, 0, -c, -s, 0, -s, c).finished();
  Pose p;
  for (int r = 0; r < 3; ++r)
    for (int q = 0; q < 3; ++q) p.R[std::size_t(r * 3 + q)] = R(r, q);
  p.t = {x, y, z};
  return p;
}

/// A wall's fine pattern, the same everywhere (GrabCut finds nothing in it unlike its surroundings).
cv::Mat wall_image() {
  cv::Mat image(120, 160, CV_8UC3);
  cv::RNG rng(3);
  rng.fill(image, cv::RNG::UNIFORM, cv::Scalar(150, 160, 170), cv::Scalar(190, 200, 210));
  return image;
}

/// Paints the front face of Cloud::box(x0, 0, z0) seen from `pose` in `colour`; returns its outline.
std::vector<cv::Point> paint_front(cv::Mat& image, const Pose& pose, const PinholeIntrinsics& k, double x0, double z0,
                                   const cv::Scalar& colour) {
  std::vector<cv::Point> corners, hull;
  for (double a : {0.0, 0.2})
    for (double h : {0.0, 0.2}) {
      cv::Point2f px;
      project_point(Eigen::Vector3f(float(x0 + a), float(0.75 + h), float(z0)), pose, k, &px);
      corners.emplace_back(px);
    }
  cv::convexHull(corners, hull);
  cv::fillConvexPoly(image, hull, colour);
  return hull;
}

}  // namespace

TEST(FindTable, ATableCutIntoPiecesByTheObjectOnItIsJoinedThroughItsFeet) {
  // The table top in two pieces, 0.4 m wide each, and a 0.2 m box standing in the middle of the 0.4 m
  // between them (the table around a box seen from low is hidden): no piece has anything standing on it,
  // so alone neither is a table and the floor below is taken. The box's feet join them into one table.
  Cloud c = floor_and_table(-0.2, 0.2);
  c.box(-0.1, 0.05);  // its lowest 5 cm untracked (no point of it in the table's slab)
  const Eigen::Vector3d camera(0, 1.15, -1.5);
  const TablePlane t = find_table(c.points, camera, Eigen::Vector3d::UnitY());
  ASSERT_TRUE(t.found);
  EXPECT_NEAR(-t.plane[3] / t.plane[1], 0.75, 0.01);
  EXPECT_TRUE(t.under(Eigen::Vector3d(0.0, 0.9, 0.0)));  // above the box: inside the joined table's outline
  EXPECT_GT(t.standing, 100);
  TableParams pieces;
  pieces.join_through_feet = false;
  const TablePlane p = find_table(c.points, camera, Eigen::Vector3d::UnitY(), pieces);
  EXPECT_FALSE(p.found && std::abs(-p.plane[3] / p.plane[1] - 0.75) < 0.05);
}

TEST(GrabCutSfm, ANearerSheetWithNoObjectUnderItIsPassedOverForTheNextCluster) {
  // A sheet of points standing on the table nearer than a box (a plain wall given the table edge's depth
  // by the stereo): the nearest cluster, but the image under it is the wall's pattern, like the pixels
  // around it, and GrabCut keeps none of it. The box, red in the image, is taken instead.
  Cloud c = floor_and_table();
  c.box(0.1);
  for (double x = -0.45; x <= -0.25; x += 0.02)
    for (double h = 0.03; h <= 0.13; h += 0.02) c.add(x, 0.75 + h, -0.3);
  const PinholeIntrinsics k{150, 150, 79.5, 59.5};
  const Pose pose = camera_at(0.23, 0, 1.15, -1.5);
  cv::Mat image = wall_image();
  const std::vector<cv::Point> hull = paint_front(image, pose, k, 0.1, -0.1, cv::Scalar(30, 30, 200));
  GrabCutSfmParams p;
  p.up = Eigen::Vector3d::UnitY();
  GrabCutSfmReport supported, nearest;
  const cv::Mat mask = grabcut_sfm(c.points, k, pose, image, p, &supported);
  p.table.min_image_support = -1;
  grabcut_sfm(c.points, k, pose, image, p, &nearest);
  ASSERT_TRUE(nearest.table.found);
  EXPECT_NEAR(nearest.cluster_sizes[std::size_t(nearest.chosen)], 60, 10);  // the sheet (66 points, its lowest in the slab), nearest
  EXPECT_TRUE(nearest.unsupported.empty());
  ASSERT_EQ(supported.unsupported.size(), 1u);
  EXPECT_EQ(supported.unsupported[0], nearest.chosen);
  EXPECT_NE(supported.chosen, nearest.chosen);
  cv::Mat red(image.size(), CV_8UC1, cv::Scalar(0));
  cv::fillConvexPoly(red, hull, cv::Scalar(255));
  EXPECT_GT(mask_f1(mask, red), 0.9);
}

TEST(GrabCutSfm, TwoObjectsChainedByErrorsOnTheWallBetweenThemKeepOnlyTheNearersRegion) {
  // A red box and, 15 cm farther, a green one, one cluster through a row of points at their top's height
  // between them (the wall's pixels given their depth by the stereo; the splits of the clusters off). The
  // box takes both; GrabCut keeps both boxes, not the wall between them, and the cluster's points in its
  // foreground fall apart into the two boxes: only the nearer one's region is kept.
  Cloud c = floor_and_table();
  c.box(-0.3);
  c.box(0.05, 0, 0.05);
  for (double t = 0; t <= 1; t += 0.07) c.add(-0.1 + 0.15 * t, 0.93, -0.1 + 0.15 * t);
  const PinholeIntrinsics k{150, 150, 79.5, 59.5};
  const Pose pose = camera_at(0.23, 0, 1.15, -1.5);
  cv::Mat image = wall_image();
  const std::vector<cv::Point> near = paint_front(image, pose, k, -0.3, -0.1, cv::Scalar(30, 30, 200));
  paint_front(image, pose, k, 0.05, 0.05, cv::Scalar(40, 180, 40));
  GrabCutSfmParams p;
  p.up = Eigen::Vector3d::UnitY();
  p.median_distance = p.median_depth = true;
  p.table.chain_rise = 0;
  GrabCutSfmReport kept, both;
  const cv::Mat mask = grabcut_sfm(c.points, k, pose, image, p, &kept);
  p.table.nearest_region = false;
  const cv::Mat whole = grabcut_sfm(c.points, k, pose, image, p, &both);
  cv::Mat truth(image.size(), CV_8UC1, cv::Scalar(0));
  cv::fillConvexPoly(truth, near, cv::Scalar(255));
  EXPECT_EQ(both.regions_dropped, 0);
  EXPECT_EQ(kept.regions_dropped, 1);
  EXPECT_LT(mask_f1(whole, truth), 0.8);  // both boxes
  EXPECT_GT(mask_f1(mask, truth), 0.9);
}

TEST(GrabCutSfm, ForegroundPixelsWhoseDepthLiesFarBehindTheObjectAreDropped) {
  // A red box, and 0.35 m behind it a green one seen above and beside it: the box around the red one (a wide margin)
  // holds part of the green one, which GrabCut keeps too (it is unlike the wall around the box). Its
  // pixels' cloud depth lies far behind the red box's points: dropped.
  Cloud c = floor_and_table();
  c.box(-0.1);
  c.box(0.0, 0, 0.25);
  const PinholeIntrinsics k{150, 150, 79.5, 59.5};
  const Pose pose = camera_at(0.23, 0, 1.15, -1.5);
  cv::Mat image = wall_image();
  paint_front(image, pose, k, 0.0, 0.25, cv::Scalar(40, 180, 40));
  const std::vector<cv::Point> near = paint_front(image, pose, k, -0.1, -0.1, cv::Scalar(30, 30, 200));
  GrabCutSfmParams p;
  p.up = Eigen::Vector3d::UnitY();
  p.median_distance = p.median_depth = true;
  p.box_margin = 0.4;
  GrabCutSfmReport trimmed, whole;
  const cv::Mat mask = grabcut_sfm(c.points, k, pose, image, p, &trimmed);
  p.table.mask_depth_share = 0;
  const cv::Mat all = grabcut_sfm(c.points, k, pose, image, p, &whole);
  cv::Mat truth(image.size(), CV_8UC1, cv::Scalar(0));
  cv::fillConvexPoly(truth, near, cv::Scalar(255));
  EXPECT_EQ(whole.farther_pixels, 0);
  EXPECT_GT(trimmed.farther_pixels, 20);
  EXPECT_LT(mask_f1(all, truth), 0.9);  // 0.85: part of the green box with it
  EXPECT_GT(mask_f1(mask, truth), 0.93);  // 0.95: its outline
}
