// The sparse matcher (sparse_stereo.hpp): block matching at chosen pixels gives OpenCV StereoBM's
// disparities (with the mirrored left-right check) bit for bit where BM's speckle filter is off, on
// hand-made pairs and on a real KITTI pair; with the filter on, it differs only where the filter
// removed a pixel.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "random_texture.hpp"
#include "smseg/frontend/sparse_stereo.hpp"

namespace fs = std::filesystem;
using namespace smseg;
using namespace smseg::frontend;

namespace {

constexpr int W = 320, H = 240;

// left(x) = tex(x); right(x) = tex(x + d) outside `square`, where a nearer square (disparity d + 16)
// covers the background: an occluded band for the left-right check, a flat patch for the texture test.
void scene(cv::Mat& left, cv::Mat& right) {
  cv::Mat bg, fg;
  test::random_texture(W + 96, H, 11, 1.0, 10, 245).convertTo(bg, CV_8U);
  test::random_texture(W + 96, H, 12, 1.0, 10, 245).convertTo(fg, CV_8U);
  const cv::Rect square(170, 60, 80, 110);
  const int d = 9, dfg = 25;
  left.create(H, W, CV_8UC1);
  right.create(H, W, CV_8UC1);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      left.at<std::uint8_t>(y, x) = square.contains({x, y}) ? fg.at<std::uint8_t>(y, x) : bg.at<std::uint8_t>(y, x);
      right.at<std::uint8_t>(y, x) =
          square.contains({x + dfg, y}) ? fg.at<std::uint8_t>(y, x + dfg) : bg.at<std::uint8_t>(y, x + d);
    }
  left(cv::Rect(30, 150, 50, 50)).setTo(128);
  right(cv::Rect(30 - d, 150, 50, 50)).setTo(128);
}

std::string first_difference(const cv::Mat& a, const cv::Mat& b) {
  for (int y = 0; y < a.rows; ++y)
    for (int x = 0; x < a.cols; ++x)
      if (a.at<float>(y, x) != b.at<float>(y, x))
        return "(" + std::to_string(x) + ", " + std::to_string(y) + "): " + std::to_string(a.at<float>(y, x)) + " vs " +
               std::to_string(b.at<float>(y, x));
  return "none";
}

void expect_same_as_block_matching(const cv::Mat& left, const cv::Mat& right, StereoOptions o, const std::string& what) {
  o.speckle_window = 0;
  o.method = StereoMethod::BM;
  const cv::Mat bm = compute_disparity(left, right, o);
  o.method = StereoMethod::Sparse;
  const cv::Mat sparse = compute_disparity(left, right, o);
  EXPECT_EQ(cv::countNonZero(bm != sparse), 0) << what << ": first difference " << first_difference(bm, sparse);
  EXPECT_GT(cv::countNonZero(bm > 0), static_cast<int>(bm.total() / 4)) << what << ": the pair must be matched somewhere";
}

const fs::path kKittiSeq1 = fs::path(SMSEG_SHARED_DIR) / "data" / "kitti-stereo" / "seq1";

}  // namespace

TEST(SparseStereo, SparseMatcherEqualsBlockMatchingWithoutSpeckleFilter) {
  cv::Mat left, right;
  scene(left, right);
  StereoOptions o;
  expect_same_as_block_matching(left, right, o, "defaults");
  o.lr_max_diff = -1;
  expect_same_as_block_matching(left, right, o, "no left-right check");
  o = {};
  o.uniqueness_ratio = 0;
  o.texture_threshold = 0;
  expect_same_as_block_matching(left, right, o, "no uniqueness or texture test");
  o = {};
  o.num_disparities = 32;
  o.min_disparity = 4;
  o.block_size = 9;
  o.prefilter_cap = 20;
  expect_same_as_block_matching(left, right, o, "other search range, block and cap");
  o = {};
  o.block_size = 25;  // BM's 32-bit sums
  o.prefilter_cap = 63;
  expect_same_as_block_matching(left, right, o, "32-bit sums");
  cv::Mat colour;
  cv::cvtColor(left, colour, cv::COLOR_GRAY2BGR);
  o = {};
  o.method = StereoMethod::Sparse;
  EXPECT_EQ(cv::countNonZero(compute_disparity(colour, right, o) != compute_disparity(left, right, o)), 0)
      << "compute_disparity takes colour images to grey first";
}

TEST(SparseStereo, SparseMatcherEqualsBlockMatchingOnAKittiPair) {
  if (!fs::exists(kKittiSeq1 / "calib.txt")) GTEST_SKIP() << "no shared KITTI slice at " << kKittiSeq1;
  const cv::Mat left = cv::imread((kKittiSeq1 / "image_l" / "000010.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat right = cv::imread((kKittiSeq1 / "image_r" / "000010.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(left.empty());
  expect_same_as_block_matching(left, right, StereoOptions{}, "KITTI seq1 frame 10");
}

// With BM's speckle filter (the default), the two differ only at pixels the filter removed: BM's
// valid disparities are the sparse matcher's, and the sparse matcher keeps more.
TEST(SparseStereo, SpeckleFilterIsTheOnlyDifferenceAtTrackedCorners) {
  if (!fs::exists(kKittiSeq1 / "calib.txt")) GTEST_SKIP() << "no shared KITTI slice at " << kKittiSeq1;
  const cv::Mat left = cv::imread((kKittiSeq1 / "image_l" / "000010.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat right = cv::imread((kKittiSeq1 / "image_r" / "000010.png").string(), cv::IMREAD_GRAYSCALE);
  TrackingOptions t;
  t.detector = KeypointMethod::Gftt;
  std::vector<cv::Point2f> corners;
  for (const auto& k : detect_keypoints(left, t).keypoints) corners.push_back(k.pt);
  ASSERT_GT(corners.size(), 500u);
  StereoOptions o;
  const std::vector<float> bm = FrameDisparity(compute_disparity(left, right, o)).sample(corners);
  o.method = StereoMethod::Sparse;
  const std::vector<float> sparse = prepare_disparity(left, right, o).sample(corners);
  int bm_valid = 0, sparse_valid = 0, equal_where_bm_valid = 0;
  for (std::size_t i = 0; i < corners.size(); ++i) {
    bm_valid += bm[i] > 0;
    sparse_valid += sparse[i] > 0;
    equal_where_bm_valid += bm[i] > 0 && bm[i] == sparse[i];
  }
  EXPECT_EQ(equal_where_bm_valid, bm_valid);
  EXPECT_GE(sparse_valid, bm_valid);
  std::cout << "KITTI seq1 frame 10, " << corners.size() << " corners: bm valid " << bm_valid << ", sparse valid "
            << sparse_valid << " (the rest removed by bm's speckle filter)\n";
}

TEST(SparseStereo, SamplesTheNearestPixelAsObservePointsReadsAMap) {
  cv::Mat left, right;
  scene(left, right);
  StereoOptions o;
  o.method = StereoMethod::Sparse;
  const FrameDisparity sparse = prepare_disparity(left, right, o);
  const FrameDisparity map(compute_disparity(left, right, o));
  const std::vector<cv::Point2f> pixels{{200.4f, 100.6f}, {-3.0f, 5.0f}, {400.0f, 300.0f}, {120.5f, 80.5f}, {260.2f, 120.0f}};
  EXPECT_EQ(sparse.sample(pixels), map.sample(pixels));
  sequence::Calibration calib;
  calib.fx = 300;
  calib.baseline = 0.5;
  calib.cx = W / 2.0;
  calib.cy = H / 2.0;
  const FrameObservations a = observe_points(pixels, sparse, cv::Mat(), calib);
  const FrameObservations b = observe_points(pixels, map.map(), cv::Mat(), calib);
  EXPECT_EQ(a.disparities, b.disparities);
  EXPECT_EQ(a.points, b.points);
}

TEST(SparseStereo, OptionsAreChecked) {
  EXPECT_EQ(parse_stereo_method("sparse"), StereoMethod::Sparse);
  EXPECT_STREQ(stereo_method_name(StereoMethod::Sparse), "sparse");
  StereoOptions o;
  o.method = StereoMethod::Sparse;
  o.lr_check = LeftRightCheck::Matcher;
  EXPECT_THROW(o.validate(), Error);
  o.lr_check = LeftRightCheck::Mirrored;
  o.block_size = 3;
  EXPECT_THROW(o.validate(), Error);
  const cv::Mat a(20, 30, CV_8UC1, cv::Scalar(0)), b(20, 31, CV_8UC1, cv::Scalar(0)), c(20, 30, CV_8UC3);
  EXPECT_THROW(SparseBlockMatcher(a, b, StereoOptions{}), Error);
  EXPECT_THROW(SparseBlockMatcher(a, c, StereoOptions{}), Error);
}
