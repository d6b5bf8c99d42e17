// Darker copies of the training frames (train-forest --exposures, stacks/exposure.hpp): each channel's
// rule, the copy's tables equal those of the mapped rasters (the appearance channels against the
// appearance of the image darkened in linear light itself), and a stack set grows by a copy of each
// frame per exposure, greyscale mapped, labels and the light-blind tables shared, its record saying so;
// channels without a rule, brighter and repeated exposures are refused naming them.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "smseg/common/error.hpp"
#include "smseg/stacks/appearance.hpp"
#include "smseg/stacks/exposure.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/stacks/stack.hpp"
#include "error_text.hpp"

namespace fs = std::filesystem;
using namespace smseg;
using namespace smseg::stacks;

namespace {

cv::Mat exposed(const cv::Mat& table, ChannelExposure e) {
  cv::Mat out(table.size(), CV_64FC1);
  exposed_table(table.ptr<double>(), table.cols - 1, table.rows - 1, e, out.ptr<double>());
  return out;
}

double srgb_to_linear(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }
double linear_to_srgb(double l) { return l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1.0 / 2.4) - 0.055; }

/// The image a camera with k times the light would have taken: linear RGB times k, 8 bits again.
cv::Mat darker_image(const cv::Mat& bgr, double k) {
  cv::Mat out(bgr.size(), bgr.type());
  for (int y = 0; y < bgr.rows; ++y)
    for (int x = 0; x < bgr.cols; ++x)
      for (int c = 0; c < 3; ++c) {
        const double l = srgb_to_linear(bgr.at<cv::Vec3b>(y, x)[c] / 255.0) * k;
        out.at<cv::Vec3b>(y, x)[c] = cv::saturate_cast<std::uint8_t>(std::lround(255.0 * linear_to_srgb(l)));
      }
  return out;
}

/// Means over 6 x 6 blocks of a raster, from its table.
cv::Mat block_means(const cv::Mat& table) {
  const int n = 6;
  cv::Mat m((table.rows - 1) / n, (table.cols - 1) / n, CV_64FC1);
  for (int by = 0; by < m.rows; ++by)
    for (int bx = 0; bx < m.cols; ++bx) {
      const int y0 = by * n, x0 = bx * n, y1 = y0 + n, x1 = x0 + n;
      m.at<double>(by, bx) = (table.at<double>(y1, x1) - table.at<double>(y0, x1) - table.at<double>(y1, x0) +
                              table.at<double>(y0, x0)) / (n * n);
    }
  return m;
}

}  // namespace

TEST(ExposurePlan, EachChannelItsRule) {
  const double k = 0.3, c = std::cbrt(k), g = std::pow(k, 1.0 / 2.4);
  const std::vector<std::string> names{"fH", "fL", "fA", "fB", "fG0", "fG3", "fRow", "fCol", "fZU", "fOx"};
  const auto plan = exposure_plan(names, k, "W/stacks.json");
  ASSERT_EQ(plan.size(), names.size());
  for (std::size_t i : {0u, 6u, 7u, 8u, 9u}) EXPECT_TRUE(plan[i].unchanged()) << names[i];
  EXPECT_DOUBLE_EQ(plan[1].scale, c);
  EXPECT_DOUBLE_EQ(plan[1].offset, 0.16 * (c - 1));  // L* + 16 scales by c
  for (std::size_t i : {2u, 3u}) {
    EXPECT_DOUBLE_EQ(plan[i].scale, c) << names[i];
    EXPECT_DOUBLE_EQ(plan[i].offset, 128.0 / 255.0 * (1 - c)) << names[i];  // grey stays grey
  }
  for (std::size_t i : {4u, 5u}) {
    EXPECT_DOUBLE_EQ(plan[i].scale, g) << names[i];
    EXPECT_EQ(plan[i].offset, 0.0) << names[i];
  }
}

TEST(ExposurePlan, ChannelsWithoutARuleAndBrighterCopiesAreRefusedByName) {
  EXPECT_EQ(smseg::test::error_of([] { exposure_plan({"fH", "fTx3"}, 0.5, "W/stacks.json"); }),
            "W/stacks.json: features: --exposures and --lightness cannot map the channel fTx3 (a texton or another forest's "
            "posterior is no affine function of the light; train without it)");
  EXPECT_NE(smseg::test::error_of([] { exposure_plan({"fCtx:Road"}, 0.5, "W/stacks.json"); }).find("fCtx:Road"),
            std::string::npos);
  EXPECT_EQ(smseg::test::error_of([] { exposure_plan({"fWho"}, 0.5, "W/stacks.json"); }),
            "W/stacks.json: features: --exposures and --lightness do not know how the channel fWho changes with the light");
  for (double k : {1.0, 1.5, 0.0, 0.001, -0.5, std::nan("")})
    EXPECT_NE(smseg::test::error_of([&] { check_exposure(k, "--exposures"); }).find("--exposures: exposure"),
              std::string::npos)
        << k;
}

TEST(LightnessPlan, BringsTheFramesMeanToTheTarget) {
  cv::Mat l(9, 12, CV_64FC1);
  for (double low : {0.05, 0.3, 0.7}) {
    cv::RNG(4).fill(l, cv::RNG::UNIFORM, low, low + 0.2);
    const double mean = cv::mean(l)[0];
    const auto plan = lightness_plan({"fH", "fL", "fG0"}, mean, 0.45, "W/stacks.json");
    EXPECT_TRUE(plan[0].unchanged());
    EXPECT_NEAR(cv::mean(l * plan[1].scale + plan[1].offset)[0], 0.45, 1e-12) << low;
    const double k = lightness_exposure(mean, 0.45);
    EXPECT_NEAR(plan[1].scale, std::cbrt(k), 1e-12);
    EXPECT_NEAR(plan[2].scale, std::pow(k, 1 / 2.4), 1e-12);
    EXPECT_EQ(k > 1, mean < 0.45) << low;  // a darker frame is brightened
  }
  EXPECT_EQ(smseg::test::error_of([] { lightness_plan({"fH", "fA"}, 0.3, 0.45, "W/stacks.json"); }),
            "W/stacks.json: features: lightness normalisation needs the channel fL (extract-features --appearance)");
}

TEST(ExposedTable, IsTheTableOfTheMappedRaster) {
  cv::Mat raster(13, 17, CV_64FC1);
  cv::RNG(3).fill(raster, cv::RNG::UNIFORM, -2.0, 5.0);
  const ChannelExposure e{0.7, 0.125};
  const cv::Mat want = summed_area_table(raster * e.scale + e.offset);
  double gap = 0;
  cv::minMaxLoc(cv::abs(want - exposed(summed_area_table(raster), e)), nullptr, &gap);
  EXPECT_LT(gap, 1e-12);
}

// The rules are those of the appearance code itself: the plan applied to an image's appearance tables
// gives (up to the darker image's 8-bit rounding) the appearance of the image darkened in linear light.
TEST(ExposedTable, AppearanceOfTheDarkerImage) {
  cv::Mat bgr(36, 48, CV_8UC3);
  cv::RNG(11).fill(bgr, cv::RNG::UNIFORM, 90, 256);  // above Lab's and sRGB's linear toes, darkened too
  cv::GaussianBlur(bgr, bgr, cv::Size(5, 5), 1.0);  // edges of several strengths and directions
  for (double k : {0.5, 0.25}) {
    std::vector<cv::Mat> here, there;
    append_appearance_rasters(bgr, here);
    append_appearance_rasters(darker_image(bgr, k), there);
    const auto plan = exposure_plan(appearance_feature_names(), k, "test");
    for (std::size_t c = 0; c < plan.size(); ++c) {
      const cv::Mat mine = block_means(exposed(summed_area_table(here[c]), plan[c]));
      const cv::Mat truth = block_means(summed_area_table(there[c]));
      const cv::Mat before = block_means(summed_area_table(here[c]));
      double gap = 0, moved = 0;
      cv::minMaxLoc(cv::abs(mine - truth), nullptr, &gap);
      cv::minMaxLoc(cv::abs(before - truth), nullptr, &moved);
      const std::string& name = appearance_feature_names()[c];
      EXPECT_LT(gap, 0.004) << name << " at " << k;  // an 8-bit step is 1/255
      if (!plan[c].unchanged() && name != "fA" && name != "fB") {  // (near-grey pixels barely move in a, b)
        EXPECT_GT(moved, 4 * gap) << name << " at " << k;  // so the test sees a wrong rule
      }
    }
  }
}

TEST(ExposedGray, MapsSrgbGreysAsTheLight) {
  std::vector<std::uint8_t> image{0, 10, 100, 255}, out(4);
  exposed_gray(image.data(), 2, 2, 0.5, out.data());
  for (std::size_t i = 0; i < image.size(); ++i) {
    const double want = 255.0 * linear_to_srgb(0.5 * srgb_to_linear(image[i] / 255.0));
    EXPECT_LE(std::abs(out[i] - want), image[i] > 10 ? 0.6 : 2.0) << int(image[i]);  // exact above sRGB's toe
  }
  EXPECT_EQ(out[0], 0);
}

struct ExposedSet : ::testing::Test {
  fs::path work;
  std::vector<cv::Mat> rasters;
  cv::Mat gray, labels;
  const cv::Size size{11, 8};
  const std::vector<std::string> features{"fH", "fL", "fG2"};

  void SetUp() override {
    work = fs::temp_directory_path() / ("smseg_exposure_" + std::to_string(::getpid()) +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    StackManifest m;
    m.work = work;
    m.sequence = "/nowhere/seq";
    m.sequence_name = "seq";
    m.size = size;
    m.features = features;
    m.classes = {"road", "car"};
    m.frames = {0, 1};
    m.labelled_frames = {0, 1};
    cv::RNG rng(5);
    for (std::size_t k = 0; k < features.size(); ++k) {
      cv::Mat r(size, CV_64FC1);
      rng.fill(r, cv::RNG::UNIFORM, 0.0, 1.0);
      rasters.push_back(r);
    }
    gray = cv::Mat(size, CV_8UC1);
    rng.fill(gray, cv::RNG::UNIFORM, 0, 256);
    labels = cv::Mat(size, CV_8UC1, cv::Scalar(0));
    labels(cv::Rect(0, 0, 3, 8)).setTo(1);
    for (int f : m.frames) write_frame_values(work, f, size, rasters, gray, labels, m.features);
    save_stack_manifest(m);
  }
  void TearDown() override { fs::remove_all(work); }

  cv::Mat table(const forest::FrameData& d, std::size_t f) const {
    return cv::Mat(size.height + 1, size.width + 1, CV_64FC1, const_cast<double*>(d.sats[f])).clone();
  }
};

TEST_F(ExposedSet, GrowsByACopyOfEachFramePerExposure) {
  StackSet set = open_stacks({work}, FrameRange{}, true, true, {"fL", "fH"});
  const Json before = training_data_record(set);
  add_exposed_frames(set, {0.5, 0.25});
  ASSERT_EQ(set.origin.size(), 2u);
  ASSERT_EQ(set.dataset.frames.size(), 6u);
  EXPECT_FALSE(set.mirrored());
  for (std::size_t e = 0; e < 2; ++e) {
    const double k = e == 0 ? 0.5 : 0.25;
    const auto plan = exposure_plan({"fL", "fH"}, k, "test");
    for (std::size_t i = 0; i < 2; ++i) {
      const forest::FrameData& frame = set.dataset.frames[i];
      const forest::FrameData& copy = set.dataset.frames[2 + 2 * e + i];
      double gap = 0;
      cv::minMaxLoc(cv::abs(table(copy, 0) - summed_area_table(rasters[1] * plan[0].scale + plan[0].offset)), nullptr,
                    &gap);
      EXPECT_LT(gap, 1e-12) << "fL at " << k;
      EXPECT_EQ(copy.sats[1], frame.sats[1]);  // fH: the frame's own table
      EXPECT_EQ(copy.labels, frame.labels);
      cv::Mat want(size, CV_8UC1);
      exposed_gray(gray.ptr<std::uint8_t>(), size.width, size.height, k, want.ptr<std::uint8_t>());
      EXPECT_EQ(cv::norm(cv::Mat(size, CV_8UC1, const_cast<std::uint8_t*>(copy.gray)), want, cv::NORM_INF), 0.0);
      copy.release();  // drops its pages and its frame's; both read again below
    }
  }
  EXPECT_LT(cv::norm(table(set.dataset.frames[0], 1), summed_area_table(rasters[0]), cv::NORM_INF), 1e-12);
  Json after = training_data_record(set);
  EXPECT_EQ(after.at("exposures"), Json::array({0.5, 0.25}));
  after.erase("exposures");
  EXPECT_EQ(after, before);
}

TEST_F(ExposedSet, LightenedFramesHaveTheTargetMeanAndShareTheRest) {
  StackSet set = open_stacks({work}, FrameRange{}, true, true, {"fL", "fH"});
  const std::vector<forest::FrameData> before = set.dataset.frames;
  lighten_frames(set, 0.0);  // off: nothing
  EXPECT_EQ(set.dataset.frames[0].sats, before[0].sats);
  lighten_frames(set, 0.45);
  ASSERT_EQ(set.dataset.frames.size(), 2u);
  ASSERT_EQ(set.lightened.size(), 2u);
  const double mean = cv::mean(rasters[1])[0];
  for (std::size_t i = 0; i < 2; ++i) {
    const forest::FrameData& frame = set.dataset.frames[i];
    const cv::Mat l = table(frame, 0);
    EXPECT_NEAR(l.at<double>(size.height, size.width) / size.area(), 0.45, 1e-12);
    EXPECT_NE(frame.sats[0], before[i].sats[0]);
    EXPECT_EQ(frame.sats[1], before[i].sats[1]);  // fH: the frame's own table
    EXPECT_EQ(frame.labels, before[i].labels);
    cv::Mat want(size, CV_8UC1);
    exposed_gray(gray.ptr<std::uint8_t>(), size.width, size.height, lightness_exposure(mean, 0.45),
                 want.ptr<std::uint8_t>());
    EXPECT_EQ(cv::norm(cv::Mat(size, CV_8UC1, const_cast<std::uint8_t*>(frame.gray)), want, cv::NORM_INF), 0.0);
    frame.release();
  }
  // A frame already at the target maps onto itself.
  forest::FrameData again = set.dataset.frames[1];
  const FrameStack owner = lighten_frame(again, set.dataset.features, 0.45, 1, "test");
  EXPECT_LT(cv::norm(table(again, 0), table(set.dataset.frames[1], 0), cv::NORM_INF), 1e-12);
  forest::FrameData no_l = set.dataset.frames[1];
  EXPECT_NE(smseg::test::error_of([&] { lighten_frame(no_l, {"fH", "fA"}, 0.45, 1, "W"); }).find("needs the channel fL"),
            std::string::npos);
}

TEST_F(ExposedSet, MirrorsAreDarkenedToo) {
  StackSet set = open_stacks({work}, FrameRange{}, true, true, {"fG2", "fH"});
  add_mirrored_frames(set);
  add_exposed_frames(set, {0.5});
  ASSERT_EQ(set.dataset.frames.size(), 4u * 2);
  EXPECT_TRUE(set.mirrored());
  const auto plan = exposure_plan({"fG2"}, 0.5, "test");
  const cv::Mat mirror = table(set.dataset.frames[2], 0);
  EXPECT_LT(cv::norm(table(set.dataset.frames[6], 0), mirror * plan[0].scale, cv::NORM_INF), 1e-12);
  EXPECT_EQ(training_data_record(set).at("mirrored"), true);
}

TEST_F(ExposedSet, RepeatedExposuresAndChannelsWithoutARuleAreRefused) {
  StackSet set = open_stacks({work}, FrameRange{}, true, true, {"fH"});
  EXPECT_EQ(smseg::test::error_of([&] { add_exposed_frames(set, {0.5, 0.5}); }),
            "--exposures: exposure 0.5 is given twice");
  set.dataset.features = {"fTx0"};  // as a folder extended by add-textons would name it
  const std::string e = smseg::test::error_of([&] { add_exposed_frames(set, {0.5}); });
  EXPECT_NE(e.find((work / "stacks.json").string() + ": features: --exposures and --lightness cannot map the channel fTx0"),
            std::string::npos)
      << e;
  EXPECT_EQ(set.dataset.frames.size(), 2u);
}
