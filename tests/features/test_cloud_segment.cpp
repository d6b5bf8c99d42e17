// Point-cloud segmentation by graph cuts: synthetic tabletops, cloud files, centroid min-cut (paper 003).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "smseg/error.hpp"
#include "smseg/features/cloud_segment.hpp"

using namespace smseg;
using namespace smseg::features;
namespace fs = std::filesystem;

namespace {

fs::path temp(const std::string& name) {
  return fs::temp_directory_path() / ("smseg_cloud_" + std::to_string(::getpid()) + "_" + name);
}

std::vector<int> object_truth(const ColouredCloud& c, int object) {
  std::vector<int> t(c.size());
  for (std::size_t i = 0; i < t.size(); ++i) t[i] = c.labels[i] == object ? 1 : 0;
  return t;
}

}  // namespace

TEST(CloudSegment, TabletopHasItsObjectsOnTheTable) {
  TabletopCloudOptions o;
  o.points = 5000;
  o.objects = 3;
  const ColouredCloud c = make_tabletop_cloud(o);
  ASSERT_EQ(c.size(), 5000u);
  ASSERT_EQ(c.labels.size(), c.size());
  std::vector<int> count(4, 0);
  for (std::size_t i = 0; i < c.size(); ++i) {
    ++count[std::size_t(c.labels[i])];
    if (c.labels[i] == 0) EXPECT_NEAR(c.points[i].y(), 0.0f, 0.02f);  // the table top
    else EXPECT_GT(c.points[i].y(), -0.02f);                           // objects stand on it
  }
  for (int k = 1; k <= 3; ++k) EXPECT_GT(count[std::size_t(k)], 500);
  // Same seed, same cloud.
  const ColouredCloud d = make_tabletop_cloud(o);
  EXPECT_EQ(c.points, d.points);
  EXPECT_EQ(c.labels, d.labels);
}

TEST(CloudSegment, F1CountsOneLabel) {
  const std::vector<int> truth = {1, 1, 0, 0, -1}, pred = {1, 0, 1, 0, 1};
  EXPECT_DOUBLE_EQ(f1_score(truth, pred, 1), 2.0 / 4.0);  // tp 1, fp 1, fn 1; the void point ignored
  EXPECT_TRUE(std::isnan(f1_score(std::vector<int>{0, 0}, std::vector<int>{0, 0}, 1)));
}

TEST(CloudSegment, CloudFilesKeepPointsColoursAndLabels) {
  TabletopCloudOptions o;
  o.points = 400;
  o.objects = 2;
  const ColouredCloud c = make_tabletop_cloud(o);
  for (const std::string ext : {".pcd", ".ply"}) {
    const fs::path p = temp("roundtrip" + ext);
    write_labelled_cloud(p, c, c.labels);
    const ColouredCloud r = read_coloured_cloud(p);
    ASSERT_EQ(r.size(), c.size()) << ext;
    EXPECT_EQ(r.points, c.points) << ext;
    EXPECT_EQ(r.colours, c.colours) << ext;
    EXPECT_EQ(r.labels, c.labels) << ext;
    fs::remove(p);
  }
}

TEST(CloudSegment, BadCloudFilesAreErrors) {
  EXPECT_THROW(read_coloured_cloud(temp("missing.pcd")), Error);
  EXPECT_THROW(read_coloured_cloud(temp("cloud.txt")), Error);
  const fs::path p = temp("garbage.pcd");
  std::ofstream(p) << "this is not a point cloud\n";
  EXPECT_THROW(read_coloured_cloud(p), Error);
  fs::remove(p);
  ColouredCloud empty;
  EXPECT_THROW(write_labelled_cloud(temp("x.pcd"), empty, std::vector<int>{1}), Error);
}

TEST(CloudSegment, CentroidMinCutSeparatesTheObjectFromTheTable) {
  TabletopCloudOptions o;
  o.points = 20000;
  const ColouredCloud c = make_tabletop_cloud(o);
  CentroidMinCutParams p;
  p.radius = 0.35;  // reaches the box's top corners from the centroid, a little above the table
  CentroidMinCutReport rep;
  const std::vector<int> labels = centroid_mincut(c, p, &rep);
  const double f1 = f1_score(object_truth(c, 1), labels, 1);
  EXPECT_GE(f1, 0.9);
  EXPECT_GT(rep.seeds, 0);
  EXPECT_GT(rep.sigma, 0);
  EXPECT_NEAR(rep.centroid.x(), 0.0f, 0.05f);
  // Without smoothness the cut is the ball of radius R exactly; smoothness must not make it worse here.
  p.lambda = 0;
  const std::vector<int> ball = centroid_mincut(c, p);
  for (std::size_t i = 0; i < c.size(); ++i)
    ASSERT_EQ(ball[i], (c.points[i] - rep.centroid).norm() <= 0.35f ? 1 : 0);
  EXPECT_GE(f1, f1_score(object_truth(c, 1), ball, 1) - 1e-9);
}

TEST(CloudSegment, PclMinCutSeparatesTheObjectFromTheTable) {
  TabletopCloudOptions o;
  o.points = 8000;
  const ColouredCloud c = make_tabletop_cloud(o);
  CentroidMinCutParams p;
  p.radius = 0.27;
  p.solver = MinCutSolver::Pcl;
  p.up = 1;
  const std::vector<int> labels = centroid_mincut(c, p);
  EXPECT_GE(f1_score(object_truth(c, 1), labels, 1), 0.9);
}

TEST(CloudSegment, BadSeedsAndEmptyCloudsAreErrors) {
  TabletopCloudOptions o;
  o.points = 2000;
  ColouredCloud c = make_tabletop_cloud(o);
  CentroidMinCutParams p;
  p.radius = 0.35;
  EXPECT_THROW(centroid_mincut(ColouredCloud{}, p), Error);
  // The centroid of a ring lies in empty space: no seed within a small radius.
  ColouredCloud ring;
  for (int i = 0; i < 500; ++i)
    ring.points.emplace_back(std::cos(i * 0.0126f), 0.0f, std::sin(i * 0.0126f));
  p.radius = 0.5;
  EXPECT_THROW(centroid_mincut(ring, p), Error);
  p.radius = 0;
  EXPECT_THROW(centroid_mincut(c, p), Error);
  p.radius = 0.35;
  p.neighbours = 0;
  EXPECT_THROW(centroid_mincut(c, p), Error);
  ColouredCloud tiny;
  tiny.points = {{0, 0, 0}, {0.1f, 0, 0}};
  p.neighbours = 10;
  EXPECT_THROW(centroid_mincut(tiny, p), Error);
  c.points[5].x() = NAN;
  EXPECT_THROW(centroid_mincut(c, p), Error);
}
