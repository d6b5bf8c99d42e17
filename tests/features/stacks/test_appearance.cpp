// Appearance channels (extract-features --appearance): each raster says what it claims on images whose
// answer is known, and the work folder carries them after the six structure-and-motion features.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "smseg/common/error.hpp"
#include "smseg/stacks/appearance.hpp"
#include "smseg/stacks/extract.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/synth/synth.hpp"
#include "named_rasters.hpp"
#include "small_corridor.hpp"
#include "temp_dir.hpp"

namespace {

using namespace smseg;
using namespace smseg::sequence;
using namespace smseg::stacks;
namespace fs = std::filesystem;

std::vector<cv::Mat> rasters_of(const cv::Mat& bgr) {
  std::vector<cv::Mat> out;
  append_appearance_rasters(bgr, out);
  return out;
}

double at(const std::vector<cv::Mat>& r, const std::string& name, int y, int x) {
  return test::raster_at(r, appearance_feature_names(), name, y, x);
}

}  // namespace

TEST(Appearance, NineRastersOfTheImageSizeInZeroToOne) {
  cv::Mat bgr(24, 40, CV_8UC3);
  cv::randu(bgr, 0, 256);
  const auto r = rasters_of(bgr);
  ASSERT_EQ(r.size(), appearance_feature_names().size());
  ASSERT_EQ(r.size(), 9u);
  for (const cv::Mat& m : r) {
    ASSERT_EQ(m.size(), bgr.size());
    ASSERT_EQ(m.type(), CV_64FC1);
    double lo = 0, hi = 0;
    cv::minMaxLoc(m, &lo, &hi);
    EXPECT_GE(lo, 0.0);
    EXPECT_LE(hi, 1.0);
  }
}

TEST(Appearance, ColourTellsRedFromBlueAndBrightFromDark) {
  cv::Mat bgr(10, 20, CV_8UC3, cv::Scalar(0, 0, 200));           // red left half
  bgr(cv::Rect(10, 0, 10, 10)).setTo(cv::Scalar(200, 0, 0));    // blue right half
  const auto r = rasters_of(bgr);
  EXPECT_GT(at(r, "fA", 5, 2), 0.6);   // a*: red is well above neutral (128 / 255)
  EXPECT_LT(at(r, "fB", 5, 17), 0.4);  // b*: blue is well below neutral
  EXPECT_GT(at(r, "fB", 5, 2), at(r, "fB", 5, 17));
  cv::Mat grey(4, 4, CV_8UC3, cv::Scalar(128, 128, 128)), white(4, 4, CV_8UC3, cv::Scalar::all(255));
  EXPECT_NEAR(at(rasters_of(grey), "fA", 1, 1), 128.0 / 255.0, 1e-9);  // no colour: a* and b* neutral
  EXPECT_NEAR(at(rasters_of(grey), "fB", 1, 1), 128.0 / 255.0, 1e-9);
  EXPECT_NEAR(at(rasters_of(white), "fL", 1, 1), 1.0, 1e-9);
  EXPECT_LT(at(rasters_of(grey), "fL", 1, 1), 0.6);
}

TEST(Appearance, LabMatchesTheCieReferenceValues) {
  // sRGB primaries in CIE L*a*b* (D65): red (53.24, 80.09, 67.20), blue (32.30, 79.19, -107.86).
  cv::Mat bgr(2, 2, CV_8UC3, cv::Scalar(0, 0, 255));
  bgr.row(1).setTo(cv::Scalar(255, 0, 0));
  const auto r = rasters_of(bgr);
  EXPECT_NEAR(at(r, "fL", 0, 0) * 100.0, 53.24, 0.05);
  EXPECT_NEAR(at(r, "fA", 0, 0) * 255.0 - 128.0, 80.09, 0.1);
  EXPECT_NEAR(at(r, "fB", 0, 0) * 255.0 - 128.0, 67.20, 0.1);
  EXPECT_NEAR(at(r, "fL", 1, 0) * 100.0, 32.30, 0.05);
  EXPECT_NEAR(at(r, "fA", 1, 0) * 255.0 - 128.0, 79.19, 0.1);
  EXPECT_NEAR(at(r, "fB", 1, 0) * 255.0 - 128.0, -107.86, 0.1);
}

TEST(Appearance, GradientsFallInTheBinOfTheirOrientation) {
  cv::Mat vertical_edge(16, 16, CV_8UC3, cv::Scalar::all(0));  // intensity changes along x: 0 degrees
  vertical_edge(cv::Rect(8, 0, 8, 16)).setTo(cv::Scalar::all(255));
  auto r = rasters_of(vertical_edge);
  EXPECT_GT(at(r, "fG0", 8, 8), 0.3);
  EXPECT_NEAR(at(r, "fG2", 8, 8), 0.0, 1e-9);
  EXPECT_NEAR(at(r, "fG0", 8, 2), 0.0, 1e-9);  // flat: no gradient anywhere
  cv::Mat horizontal_edge;
  cv::transpose(vertical_edge, horizontal_edge);  // changes along y: 90 degrees
  r = rasters_of(horizontal_edge);
  EXPECT_GT(at(r, "fG2", 8, 8), 0.3);
  EXPECT_NEAR(at(r, "fG0", 8, 8), 0.0, 1e-9);
  cv::Mat diagonal(16, 16, CV_8UC3, cv::Scalar::all(0));  // bright below the x = y diagonal: 135 degrees
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < y; ++x) diagonal.at<cv::Vec3b>(y, x) = cv::Vec3b(255, 255, 255);
  r = rasters_of(diagonal);
  EXPECT_GT(at(r, "fG3", 8, 8), 0.8 * (at(r, "fG0", 8, 8) + at(r, "fG1", 8, 8) + at(r, "fG2", 8, 8) + at(r, "fG3", 8, 8)));
}

TEST(Appearance, PositionIsTheRowAndColumnFraction) {
  const auto r = rasters_of(cv::Mat(20, 50, CV_8UC3, cv::Scalar::all(90)));
  EXPECT_DOUBLE_EQ(at(r, "fRow", 0, 7), 0.5 / 20);
  EXPECT_DOUBLE_EQ(at(r, "fRow", 19, 7), 19.5 / 20);
  EXPECT_DOUBLE_EQ(at(r, "fCol", 3, 0), 0.5 / 50);
  EXPECT_DOUBLE_EQ(at(r, "fCol", 3, 49), 49.5 / 50);
}

TEST(Appearance, AGreyOrEmptyImageIsRefused) {
  std::vector<cv::Mat> out;
  EXPECT_THROW(append_appearance_rasters(cv::Mat(4, 4, CV_8UC1, cv::Scalar(0)), out), Error);
  EXPECT_THROW(append_appearance_rasters(cv::Mat(), out), Error);
  EXPECT_TRUE(out.empty());
}

TEST(Appearance, ExtractWritesThemAfterTheSixAndRecordsTheOption) {
  const fs::path dir = test::temp_dir("appearance_extract");
  const Sequence seq = test::small_corridor(dir / "seq", 8, 4);
  ExtractOptions eo = test::quiet_extract_options();
  extract_features(seq, dir / "plain", eo);
  const StackManifest plain = load_stack_manifest(dir / "plain");
  EXPECT_EQ(plain.features, structure_feature_names());
  EXPECT_FALSE(plain.options["features"].contains("appearance"));  // older work folders keep their options

  eo.features.appearance = true;
  EXPECT_THROW(extract_features(seq, dir / "plain", eo), Error);  // made with other options: --force
  extract_features(seq, dir / "app", eo);
  const StackManifest m = load_stack_manifest(dir / "app");
  ASSERT_EQ(m.features.size(), 15u);
  EXPECT_TRUE(std::equal(structure_feature_names().begin(), structure_feature_names().end(), m.features.begin()));
  EXPECT_TRUE(std::equal(appearance_feature_names().begin(), appearance_feature_names().end(), m.features.begin() + 6));
  EXPECT_EQ(m.options["features"]["appearance"], true);

  // The stored tables are the summed-area tables of the frame's rasters.
  const int f = m.frames.at(1);
  const FrameStack stack = FrameStack::open(m, f, false);
  const auto want = rasters_of(seq.load_left(f));
  const int W = seq.size.width, H = seq.size.height;
  for (int k = 0; k < 9; ++k) {
    const double* sat = stack.sat(6 + k);
    const double total = sat[std::size_t(H) * std::size_t(W + 1) + std::size_t(W)];
    EXPECT_NEAR(total, cv::sum(want[std::size_t(k)])[0], 1e-6 * (1 + std::abs(total))) << appearance_feature_names()[std::size_t(k)];
  }
  fs::remove_all(dir);
}
