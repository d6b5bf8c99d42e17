// Stereo disparity (BM with validity checks, SGBM) and the Middlebury helpers, on hand-made cases.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>

#include <unistd.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "random_texture.hpp"
#include "smseg/frontend/stereo.hpp"

namespace fs = std::filesystem;
using namespace smseg;
using namespace smseg::frontend;

namespace {

// A blurred random texture, wide enough to be sampled at any shift used below.
cv::Mat texture(int w, int h, std::uint64_t seed) { return test::random_texture(w, h, seed, 1.0, 10, 245); }

// Samples tex at (x + shift, y) for every pixel of a W x H image (bilinear for fractional shifts).
cv::Mat shifted(const cv::Mat& tex, int W, int H, double shift) {
  cv::Mat mx(H, W, CV_32FC1), my(H, W, CV_32FC1);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) mx.at<float>(y, x) = static_cast<float>(x + shift), my.at<float>(y, x) = static_cast<float>(y);
  cv::Mat out, out8;
  cv::remap(tex, out, mx, my, cv::INTER_LINEAR, cv::BORDER_REFLECT);
  out.convertTo(out8, CV_8U);
  return out8;
}

struct PlaneStats {
  double valid_share = 0;  // over the columns x >= x0 (the matcher's left band cannot be matched)
  double median_error = 0;
};

PlaneStats plane_stats(const cv::Mat& d, double truth, int x0, const cv::Rect& exclude = {}) {
  std::vector<double> err;
  long total = 0;
  for (int y = 8; y < d.rows - 8; ++y)
    for (int x = x0; x < d.cols - 8; ++x) {
      if (exclude.contains({x, y})) continue;
      ++total;
      const float v = d.at<float>(y, x);
      if (v > 0) err.push_back(std::abs(v - truth));
    }
  PlaneStats s;
  s.valid_share = static_cast<double>(err.size()) / total;
  if (!err.empty()) {
    std::nth_element(err.begin(), err.begin() + err.size() / 2, err.end());
    s.median_error = err[err.size() / 2];
  } else {
    s.median_error = std::numeric_limits<double>::infinity();
  }
  return s;
}

constexpr int W = 320, H = 240;

}  // namespace

TEST(Stereo, BlockMatchingRecoversAFrontoParallelPlane) {
  const cv::Mat tex = texture(W + 64, H, 1);
  const double d = 12.5;
  // left(x) = tex(x), right(x) = tex(x + d): left pixel x shows right pixel x - d, disparity d.
  const cv::Mat left = shifted(tex, W, H, 0), right = shifted(tex, W, H, d);
  StereoOptions o;
  const cv::Mat disp = compute_disparity(left, right, o);
  ASSERT_EQ(disp.type(), CV_32FC1);
  const PlaneStats s = plane_stats(disp, d, o.num_disparities + o.block_size);
  EXPECT_LT(s.median_error, 0.5);
  EXPECT_GT(s.valid_share, 0.8);
}

// A right image offset by 1.5 px against the calibration (its content 1.5 px further right than a
// pair rectified to one principal point): block matching sees d - 1.5, the disparity offset gives d back.
TEST(Stereo, DisparityOffsetUndoesARightImageOffset) {
  const cv::Mat tex = texture(W + 64, H, 3);
  const double d = 12.5, offset = 1.5;
  const cv::Mat left = shifted(tex, W, H, 0), right = shifted(tex, W, H, d - offset);
  StereoOptions o;
  cv::Mat disp = compute_disparity(left, right, o);
  EXPECT_NEAR(plane_stats(disp, d - offset, o.num_disparities + o.block_size).median_error, 0, 0.5);
  const cv::Mat before = disp.clone();
  apply_disparity_offset(disp, offset);
  const PlaneStats s = plane_stats(disp, d, o.num_disparities + o.block_size);
  EXPECT_LT(s.median_error, 0.5);
  EXPECT_GT(s.valid_share, 0.8);
  // Invalid pixels stay invalid; a disparity the offset makes non-positive becomes invalid; 0 is a no-op.
  EXPECT_EQ(cv::countNonZero((before <= 0) != (disp <= 0)), 0);
  cv::Mat small = (cv::Mat_<float>(1, 3) << 0.5f, -1.0f, 3.0f);
  apply_disparity_offset(small, -1.0);
  EXPECT_EQ(small.at<float>(0), kInvalidDisparity);
  EXPECT_EQ(small.at<float>(1), kInvalidDisparity);
  EXPECT_EQ(small.at<float>(2), 2.0f);
  const cv::Mat same = before.clone();
  apply_disparity_offset(const_cast<cv::Mat&>(same), 0.0);
  EXPECT_EQ(cv::countNonZero(same != before), 0);
}

TEST(Stereo, SemiGlobalMatchingRecoversAFrontoParallelPlane) {
  const cv::Mat tex = texture(W + 64, H, 2);
  const double d = 20.25;
  const cv::Mat left = shifted(tex, W, H, 0), right = shifted(tex, W, H, d);
  StereoOptions o;
  o.method = StereoMethod::SGBM;
  o.block_size = 5;
  const cv::Mat disp = compute_disparity(left, right, o);
  const PlaneStats s = plane_stats(disp, d, o.num_disparities + o.block_size);
  EXPECT_LT(s.median_error, 0.5);
  EXPECT_GT(s.valid_share, 0.8);
}

TEST(Stereo, TexturelessAreaIsInvalidWithBlockMatching) {
  const cv::Mat tex = texture(W + 64, H, 3);
  const double d = 10;
  cv::Mat left = shifted(tex, W, H, 0), right = shifted(tex, W, H, d);
  const cv::Rect flat(150, 60, 100, 100);  // constant grey in the left image, and where it shows in the right
  left(flat).setTo(128);
  right(flat - cv::Point(static_cast<int>(d), 0)).setTo(128);
  const cv::Mat disp = compute_disparity(left, right, StereoOptions{});
  const cv::Rect inner(flat.x + 10, flat.y + 10, flat.width - 20, flat.height - 20);
  const int valid_inside = cv::countNonZero(disp(inner) > 0);
  EXPECT_EQ(valid_inside, 0) << "a textureless area must have no disparity";
  // and the textured rest still matches
  const PlaneStats s = plane_stats(disp, d, 80, cv::Rect(flat.x - 12, flat.y - 12, flat.width + 24, flat.height + 24));
  EXPECT_LT(s.median_error, 0.5);
  EXPECT_GT(s.valid_share, 0.8);
}

TEST(Stereo, LeftRightCheckRemovesTheOccludedBand) {
  // Background plane at disparity 8, a foreground square at disparity 24. In the left image the band of
  // background just left of the square (24 - 8 = 16 px wide) is hidden by the square in the right image.
  const int dbg = 8, dfg = 24;
  const cv::Mat bg = texture(W + 64, H, 4), fg = texture(W + 64, H, 5);
  const cv::Rect sq(180, 70, 80, 100);
  cv::Mat left(H, W, CV_8UC1), right(H, W, CV_8UC1);
  const cv::Mat bgl = shifted(bg, W, H, 0), bgr = shifted(bg, W, H, dbg), fgl = shifted(fg, W, H, 0),
                fgr = shifted(fg, W, H, dfg);
  // left(x) = scene point at x; right(x) = scene point that lands at x, i.e. left x + disparity.
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      left.at<std::uint8_t>(y, x) = sq.contains({x, y}) ? fgl.at<std::uint8_t>(y, x) : bgl.at<std::uint8_t>(y, x);
      const bool fg_here = sq.contains({x + dfg, y});
      right.at<std::uint8_t>(y, x) = fg_here ? fgr.at<std::uint8_t>(y, x) : bgr.at<std::uint8_t>(y, x);
    }
  // The band: left pixels x in [sq.x - 16, sq.x), rows inside the square.
  const cv::Rect band(sq.x - (dfg - dbg) + 2, sq.y + 8, dfg - dbg - 4, sq.height - 16);
  // Only the left-right check differs (uniqueness and speckle filtering off, to isolate it).
  StereoOptions with;
  with.uniqueness_ratio = 0;
  with.speckle_window = 0;
  StereoOptions without = with;
  without.lr_max_diff = -1;
  const cv::Mat d_with = compute_disparity(left, right, with), d_without = compute_disparity(left, right, without);
  const double band_px = band.area();
  const double valid_with = cv::countNonZero(d_with(band) > 0) / band_px;
  const double valid_without = cv::countNonZero(d_without(band) > 0) / band_px;
  EXPECT_LT(valid_with, 0.1) << "the left-right check must remove the occluded band";
  EXPECT_GT(valid_without, 0.8) << "without the check the band gets (wrong) disparities";
  // The visible parts stay: background and foreground at their disparities.
  const cv::Rect fg_inner(sq.x + 10, sq.y + 10, sq.width - 20, sq.height - 20);
  EXPECT_LT(plane_stats(d_with(fg_inner), dfg, 0).median_error, 0.5);
}

// The matchers mark unmatched pixels (min_disparity - 1) x 16, a positive number from min_disparity 2
// on: they must come out invalid, not as disparity min_disparity - 1.
TEST(Stereo, UnmatchedPixelsAreInvalidWithAMinimumDisparity) {
  const cv::Mat tex = texture(W + 64, H, 6);
  const double d = 14.5;
  const cv::Mat left = shifted(tex, W, H, 0), right = shifted(tex, W, H, d);
  for (const StereoMethod m : {StereoMethod::BM, StereoMethod::SGBM}) {
    StereoOptions o;
    o.method = m;
    o.block_size = m == StereoMethod::BM ? 11 : 5;
    o.min_disparity = 4;
    const cv::Mat disp = compute_disparity(left, right, o);
    EXPECT_EQ(cv::countNonZero((disp > 0) & (disp < o.min_disparity - 0.5)), 0) << stereo_method_name(m);
    EXPECT_GT(cv::countNonZero(disp <= 0), 0) << stereo_method_name(m) << ": the image border stays unmatched";
    EXPECT_LT(plane_stats(disp, d, o.num_disparities + o.block_size + o.min_disparity).median_error, 0.5);
  }
}

TEST(Stereo, LeftRightCheckOnHandMadeMaps) {
  cv::Mat dl = (cv::Mat_<float>(1, 6) << -1, 1, 2, 2, 3, 5);
  const cv::Mat dr = (cv::Mat_<float>(1, 6) << 1, 2, 2, 9, -1, 1);
  // x=1,d=1 -> xr=0: dr=1 ok; x=2,d=2 -> 0: 1 vs 2 ok (<=1); x=3,d=2 -> 1: 2 ok; x=4,d=3 -> 1: 2 ok;
  // x=5,d=5 -> 0: 1 vs 5 bad.
  EXPECT_EQ(left_right_check(dl, dr, 1.0), 1);
  EXPECT_EQ(dl.at<float>(0, 5), kInvalidDisparity);
  EXPECT_EQ(dl.at<float>(0, 4), 3.0f);
  cv::Mat dl2 = (cv::Mat_<float>(1, 3) << 1, 1, 4);  // x=2,d=4 -> xr=-2: outside, removed
  const cv::Mat dr2 = (cv::Mat_<float>(1, 3) << 1, 1, 1);
  // x=0,d=1 -> xr=-1 and x=2,d=4 -> xr=-2 fall outside the image: removed; x=1,d=1 -> 0 agrees.
  EXPECT_EQ(left_right_check(dl2, dr2, 0.0), 2);
  EXPECT_EQ(dl2.at<float>(0, 0), kInvalidDisparity);
  EXPECT_EQ(dl2.at<float>(0, 1), 1.0f);
  EXPECT_EQ(dl2.at<float>(0, 2), kInvalidDisparity);
}

TEST(Stereo, OptionsAreValidated) {
  StereoOptions o;
  o.num_disparities = 50;
  EXPECT_THROW(o.validate(), Error);
  o = {};
  o.block_size = 4;
  EXPECT_THROW(o.validate(), Error);
  o = {};
  o.method = StereoMethod::SGBM;
  o.block_size = 31;
  EXPECT_THROW(o.validate(), Error);
  o = {};
  o.prefilter_cap = 0;
  EXPECT_THROW(o.validate(), Error);
  EXPECT_THROW(parse_stereo_method("census"), Error);
  EXPECT_EQ(parse_stereo_method("sgbm"), StereoMethod::SGBM);
  const cv::Mat a(20, 30, CV_8UC1, cv::Scalar(0)), b(20, 31, CV_8UC1, cv::Scalar(0));
  try {
    compute_disparity(a, b, StereoOptions{});
    FAIL() << "size mismatch must throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("differs"), std::string::npos) << e.what();
  }
  StereoOptions given;
  given.method = StereoMethod::Given;
  EXPECT_THROW(compute_disparity(a, a, given), Error);
}

TEST(Stereo, AllBlackPairGivesNoDisparityNotACrash) {
  const cv::Mat a(H, W, CV_8UC1, cv::Scalar(0));
  const cv::Mat d = compute_disparity(a, a, StereoOptions{});
  EXPECT_EQ(cv::countNonZero(d > 0), 0);
}

// ---------------------------------------------------------------------------------------------
// Middlebury helpers.

TEST(Middlebury, ScoresAHandMadeCase) {
  const float inf = std::numeric_limits<float>::infinity();
  // 2 x 4. GT: one unknown (inf). Mask: one occluded pixel. Estimate: one invalid.
  const cv::Mat gt = (cv::Mat_<float>(2, 4) << 10, 10, 10, inf,  //
                      20, 20, 20, 20);
  const cv::Mat mask = (cv::Mat_<std::uint8_t>(2, 4) << 255, 255, 255, 255,  //
                        255, 255, 128, 255);
  const cv::Mat est = (cv::Mat_<float>(2, 4) << 10.5, 13, -1, 10,  //
                       22.5, 19, 5, 21.9);
  const DisparityScore s = score_disparity(est, gt, mask, 2.0);
  EXPECT_EQ(s.pixels, 8);
  EXPECT_EQ(s.valid, 7);
  EXPECT_EQ(s.nonocc_known, 6);  // not (0,3) unknown, not (1,2) occluded
  EXPECT_EQ(s.evaluated, 5);     // minus (0,2) invalid
  EXPECT_EQ(s.bad, 2);           // 13 vs 10 and 22.5 vs 20; 21.9 vs 20 is within 2
  EXPECT_DOUBLE_EQ(s.valid_share, 7.0 / 8);
  EXPECT_DOUBLE_EQ(s.bad_rate, 2.0 / 5);
  EXPECT_DOUBLE_EQ(s.nonocc_valid_share, 5.0 / 6);
  EXPECT_NEAR(s.mean_abs_error, (0.5 + 3 + 2.5 + 1 + 1.9) / 5, 1e-6);
}

TEST(Middlebury, PfmRoundTripKeepsRowOrderAndInfinity) {
  const fs::path dir = fs::temp_directory_path() / ("smseg_test_stereo_pfm_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const float inf = std::numeric_limits<float>::infinity();
  const cv::Mat m = (cv::Mat_<float>(2, 3) << 1, 2, 3, 4.5f, inf, -6);
  write_pfm(dir / "a.pfm", m);
  const std::string bytes = read_file(dir / "a.pfm");
  EXPECT_EQ(bytes.substr(0, 10), "Pf\n3 2\n-1\n");
  EXPECT_EQ(bytes.size(), 10u + 6 * 4);
  const cv::Mat r = read_pfm(dir / "a.pfm");
  ASSERT_EQ(r.size(), m.size());
  EXPECT_EQ(r.at<float>(0, 0), 1);  // top row first in memory
  EXPECT_EQ(r.at<float>(1, 0), 4.5f);
  EXPECT_TRUE(std::isinf(r.at<float>(1, 1)));
  // Truncated and wrong-magic files are clear errors.
  write_file_atomic(dir / "short.pfm", std::string("Pf\n3 2\n-1\n") + std::string(8, '\0'));
  EXPECT_THROW(read_pfm(dir / "short.pfm"), Error);
  write_file_atomic(dir / "bad.pfm", "P6\n3 2\n255\n");
  EXPECT_THROW(read_pfm(dir / "bad.pfm"), Error);
  fs::remove_all(dir);
}

TEST(Middlebury, CalibParsingToleratesWhitespace) {
  const fs::path dir = fs::temp_directory_path() / ("smseg_test_stereo_calib_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  write_file_atomic(dir / "calib.txt",
                    "cam0=[ 1038.018 0 322.037 ; 0 1038.018 243.393 ; 0 0 1 ] \n"
                    "cam1=[ 1038.018 0 375.308 ; 0 1038.018 243.393 ; 0 0 1 ]\n doffs= 53.271 \nbaseline= 176.252\n"
                    " width= 718\nheight= 496\n ndisp= 73\n isint=0\n vmin= 8 \nvmax= 65\n");
  const MiddleburyCalib c = read_middlebury_calib(dir / "calib.txt");
  EXPECT_DOUBLE_EQ(c.fx, 1038.018);
  EXPECT_DOUBLE_EQ(c.cx1, 375.308);
  EXPECT_EQ(c.ndisp, 73);
  EXPECT_EQ(c.width, 718);
  EXPECT_EQ(c.vmax, 65);
  write_file_atomic(dir / "calib.txt", "cam0=[1 0 0; 0 1 0; 0 0 1]\ncam1=[1 0 0; 0 1 0; 0 0 1]\ndoffs=0\n");
  try {
    read_middlebury_calib(dir / "calib.txt");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "baseline");
  }
  fs::remove_all(dir);
}

TEST(Middlebury, RealPairBlockMatchingIsMostlyRight) {
  const fs::path root = fs::path(SMSEG_SHARED_DIR) / "data" / "middlebury-q";
  if (!fs::exists(root / "images" / "Teddy")) GTEST_SKIP() << "no Middlebury data";
  const auto calib = read_middlebury_calib(root / "images" / "Teddy" / "calib.txt");
  const cv::Mat l = cv::imread((root / "images" / "Teddy" / "im0.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat r = cv::imread((root / "images" / "Teddy" / "im1.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat gt = read_pfm(root / "groundtruth" / "Teddy" / "disp0GT.pfm");
  const cv::Mat mask = cv::imread((root / "groundtruth" / "Teddy" / "mask0nocc.png").string(), cv::IMREAD_GRAYSCALE);
  StereoOptions o;
  o.num_disparities = (calib.ndisp + 15) / 16 * 16;
  const DisparityScore s = score_disparity(compute_disparity(l, r, o), gt, mask);
  EXPECT_GT(s.valid_share, 0.4);
  EXPECT_LT(s.bad_rate, 0.1);
}
