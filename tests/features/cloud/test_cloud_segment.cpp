// Point-cloud segmentation by graph cuts: synthetic tabletops, cloud files, centroid min-cut (paper 003).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "smseg/common/error.hpp"
#include "smseg/cloud/cloud_segment.hpp"

using namespace smseg;
using namespace smseg::cloud;
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

// ---- Multi-class MRF (paper 000) ----

namespace {

// The best F1 per ground-truth object, the predicted labels mapped to truth through their seeds.
std::vector<double> mrf_f1(const ColouredCloud& c, const MrfSeeds& seeds, const std::vector<int>& labels, int objects) {
  const std::vector<int> map = seed_truth(c, seeds);
  std::vector<int> mapped(labels.size());
  for (std::size_t i = 0; i < labels.size(); ++i) mapped[i] = map[std::size_t(labels[i])];
  std::vector<double> f1;
  for (int k = 0; k <= objects; ++k) f1.push_back(f1_score(c.labels, mapped, k));
  return f1;
}

}  // namespace

TEST(CloudMrf, PlaneSeedsFindTheTableAndEachObject) {
  TabletopCloudOptions o;
  o.points = 12000;
  o.objects = 3;
  const ColouredCloud c = make_tabletop_cloud(o);
  const MrfSeeds s = plane_seeds(c, {});
  ASSERT_EQ(s.regions.size(), 4u);
  const std::vector<int> truth = seed_truth(c, s);
  EXPECT_EQ(truth[0], 0);  // the plane is the table
  std::vector<int> objects(truth.begin() + 1, truth.end());
  std::sort(objects.begin(), objects.end());
  EXPECT_EQ(objects, (std::vector<int>{1, 2, 3}));
}

TEST(CloudMrf, SeparatesThreeObjectsAndTheTable) {
  TabletopCloudOptions o;
  o.points = 12000;
  o.objects = 3;
  const ColouredCloud c = make_tabletop_cloud(o);
  const MrfSeeds s = plane_seeds(c, {});
  MrfReport rep;
  const std::vector<int> labels = mrf_segment(c, s, {}, &rep);
  for (double f : mrf_f1(c, s, labels, 3)) EXPECT_GE(f, 0.9);
  ASSERT_FALSE(rep.energies.empty());
  EXPECT_GT(rep.beta, 0);
}

TEST(CloudMrf, SmoothnessCleansColourNoiseThatUnariesAloneGetWrong) {
  // Heavy colour noise: the colour models alone mislabel many points; the k-NN Potts term fixes most.
  TabletopCloudOptions o;
  o.points = 12000;
  o.objects = 2;
  o.colour_noise = 70;
  const ColouredCloud c = make_tabletop_cloud(o);
  const MrfSeeds s = plane_seeds(c, {.colour_tolerance = 400});
  MrfParams p;
  p.lambda = 0;
  const auto alone = mrf_f1(c, s, mrf_segment(c, s, p), 2);
  p.lambda = 4;
  const auto smooth = mrf_f1(c, s, mrf_segment(c, s, p), 2);
  for (int k = 1; k <= 2; ++k) {
    EXPECT_GT(smooth[std::size_t(k)], alone[std::size_t(k)] + 0.2) << "object " << k;
    EXPECT_GE(smooth[std::size_t(k)], 0.9) << "object " << k;
  }
}

TEST(CloudMrf, SeedFilesAndBadSeeds) {
  TabletopCloudOptions o;
  o.points = 6000;
  o.objects = 2;
  const ColouredCloud c = make_tabletop_cloud(o);
  const fs::path f = temp("seeds.json");
  // Object 1 at the centre (a box 0.3 m tall), object 2 on the ring at angle 0 (a sphere).
  write_file_atomic(f, R"({"format": "smseg-seeds", "version": 1, "radius": 0.08,
    "seeds": [{"label": 0, "position": [-0.8, 0, -0.8]}, {"label": 0, "position": [0.8, 0, 0.8]},
              {"label": 1, "position": [0, 0.3, 0]}, {"label": 2, "position": [0.68, 0.35, 0]}]})");
  const MrfSeeds s = file_seeds(c, f);
  ASSERT_EQ(s.regions.size(), 3u);
  EXPECT_EQ(seed_truth(c, s), (std::vector<int>{0, 1, 2}));
  const auto f1 = mrf_f1(c, s, mrf_segment(c, s, {}), 2);
  for (double v : f1) EXPECT_GE(v, 0.9);
  // A seed in empty space, a missing label, a broken file.
  write_file_atomic(f, R"({"format": "smseg-seeds", "version": 1, "radius": 0.05,
    "seeds": [{"label": 0, "position": [-0.8, 0, -0.8]}, {"label": 1, "position": [5, 5, 5]}]})");
  EXPECT_THROW(file_seeds(c, f), Error);
  write_file_atomic(f, R"({"format": "smseg-seeds", "version": 1, "radius": 0.08,
    "seeds": [{"label": 0, "position": [-0.8, 0, -0.8]}, {"label": 2, "position": [0, 0.3, 0]}]})");
  EXPECT_THROW(file_seeds(c, f), Error);
  write_file_atomic(f, R"({"format": "smseg-seeds", "version": 1, "seeds": []})");
  EXPECT_THROW(file_seeds(c, f), Error);
  fs::remove(f);
  // No colours, empty clouds, one label.
  ColouredCloud grey = c;
  grey.colours.clear();
  EXPECT_THROW(mrf_segment(grey, s, {}), Error);
  EXPECT_THROW(mrf_segment(ColouredCloud{}, s, {}), Error);
  MrfSeeds one = s;
  one.regions.resize(1);
  EXPECT_THROW(mrf_segment(c, one, {}), Error);
}

// Found by fuzz_cloud: PCL 1.13's PCDReader crashed (a null pointer) on a header line with a keyword it
// does not know; our header check now refuses it, naming the line.
TEST(CloudSegment, PcdHeaderLineOfUnknownKeywordIsRefused) {
  const fs::path p = temp("unknown-keyword.pcd");
  std::ofstream(p) << "# .PCD v0.7\nVERSION 0.7\nFOO 1\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                      "WIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n1 2 3\n";
  try {
    read_coloured_cloud(p);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), p.string() + ": not a PCD file (header line \"FOO 1\" out of place or unknown)");
  }
  // Without the stray line the same file is read.
  std::ofstream(p) << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                      "WIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n1 2 3\n";
  EXPECT_EQ(read_coloured_cloud(p).size(), 1u);
  fs::remove(p);
}

// A point count the file cannot hold is refused before PCL allocates for it (a 3-line PLY claiming 4e9
// vertices made PCL ask for 80 GB).
TEST(CloudSegment, CountsBeyondTheFileSizeAreRefused) {
  const fs::path ply = temp("huge-count.ply");
  std::ofstream(ply) << "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\n"
                        "property float z\nend_header\n1 2 3\n";
  EXPECT_THROW(
      {
        try {
          read_coloured_cloud(ply);
        } catch (const Error& e) {
          EXPECT_NE(std::string(e.what()).find("element vertex: is 4000000000, more than the file's"), std::string::npos)
              << e.what();
          throw;
        }
      },
      Error);
  const fs::path pcd = temp("huge-count.pcd");
  std::ofstream(pcd) << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1000000000\nHEIGHT 1\n"
                        "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1000000000\nDATA ascii\n1 2 3\n";
  EXPECT_THROW(read_coloured_cloud(pcd), Error);
  fs::remove(ply);
  fs::remove(pcd);
}

// Found by fuzz_cloud: PCL 1.13's PLYReader failed an assertion (the process aborted) on a vertex
// property it did not know ("uchar rfd" before "uint label"). Our reader reads past such properties
// (other tools write quality, confidence, ...) and keeps the ones after them.
TEST(CloudSegment, PlyVertexPropertyOfUnknownNameIsSkipped) {
  const fs::path p = temp("unknown-property.ply");
  std::ofstream(p) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                      "property float z\nproperty uchar rfd\nproperty uint label\nend_header\n1 2 3 4 5\n";
  const ColouredCloud c = read_coloured_cloud(p);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c.points[0], Eigen::Vector3f(1, 2, 3));
  ASSERT_TRUE(c.has_labels());
  EXPECT_EQ(c.labels[0], 5);
  EXPECT_FALSE(c.has_colours());
  fs::remove(p);
}

// Found by fuzz_cloud: a PLY with "element vertex 0" reached PCL's conversion, which indexed an empty
// vector (UBSan: reference binding to a null pointer); it is refused as an empty cloud, like a PCD.
TEST(CloudSegment, PlyWithNoVertexIsAnEmptyCloud) {
  const fs::path p = temp("no-vertex.ply");
  std::ofstream(p) << "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                      "property float z\nend_header\n";
  try {
    read_coloured_cloud(p);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), p.string() + ": points: the cloud is empty");
  }
  fs::remove(p);
}

// Found by fuzz_cloud: PCL 1.13 aborts (an assertion in vertexScalarPropertyCallback<unsigned int>) on a
// header with a damaged "property" line followed by green and blue without red. Both are refused first,
// each on its own.
TEST(CloudSegment, PlyHeaderLinesThatAreNotPlyAndPartialColoursAreRefused) {
  const fs::path p = temp("damaged-header.ply");
  std::ofstream(p) << "ply\nformat binary_little_endian 1.0\nelement vertex 9\nproperty float x\n"
                      "propertIEWPOINT 0 0 0 1 0 0 0\nPOINTS 9\nproperty uchar green\nproperty uchar blue\n"
                      "property uint label\nend_header\n";
  try {
    read_coloured_cloud(p);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              p.string() + ": header: line 5 (\"propertIEWPOINT 0 0 0 1 0 0 0\"): is not a PLY header line");
  }
  std::ofstream(p) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                      "property float z\nproperty uchar green\nproperty uchar blue\nend_header\n1 2 3 4 5\n";
  try {
    read_coloured_cloud(p);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              p.string() + ": element vertex: has some of the colour properties red, green, blue but not all three");
  }
  // Found by fuzz_cloud next: a damaged property line whose last word is a known name.
  std::ofstream(p) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                      "property float z\nproperty uchar property uchar red\nproperty uchar green\n"
                      "property uchar blue\nend_header\n1 2 3 4 5 6\n";
  try {
    read_coloured_cloud(p);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), p.string() + ": header: line 7 (\"property uchar property uchar red\"): "
                                                  "expected property TYPE NAME (no lists in a vertex)");
  }
  fs::remove(p);
}

// Found by fuzz_cloud: an overflowing SIZE in a PCD header made PCL allocate gigabytes; SIZE, TYPE and
// COUNT take only the format's values.
TEST(CloudSegment, PcdFieldSizesTypesAndCountsOutsideTheFormatAreRefused) {
  const fs::path p = temp("bad-size.pcd");
  std::ofstream(p) << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 42222222222222222222\nTYPE F F F\nCOUNT 1 1 1\n"
                      "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n";
  try {
    read_coloured_cloud(p);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), p.string() + ": SIZE: \"42222222222222222222\" is not a value of the PCD format");
  }
  fs::remove(p);
}
