// Mirrored training frames (train-forest --mirror, stacks/mirror.hpp): each channel's rule, the tables
// of the mirror equal those of the mirrored rasters (the appearance channels against the appearance of
// the mirrored image itself), and a stack set grows by the mirrors of its frames, greyscale and labels
// mirrored, its record saying so; channels without a mirror are refused naming them.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

#include "smseg/common/error.hpp"
#include "smseg/stacks/appearance.hpp"
#include "smseg/stacks/mirror.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/stacks/stack.hpp"
#include "error_text.hpp"

namespace fs = std::filesystem;
using namespace smseg;
using namespace smseg::stacks;

namespace {

/// Largest difference between two tables, relative to the larger's largest magnitude.
double relative_gap(const cv::Mat& a, const cv::Mat& b) {
  double scale = 0, gap = 0;
  cv::minMaxLoc(cv::abs(a), nullptr, &scale);
  cv::minMaxLoc(cv::abs(a - b), nullptr, &gap);
  return gap / std::max(scale, 1e-300);
}

cv::Mat mirrored_table(const cv::Mat& table, bool negate) {
  cv::Mat out(table.size(), CV_64FC1);
  mirror_table(table.ptr<double>(), table.cols - 1, table.rows - 1, negate, out.ptr<double>());
  return out;
}

cv::Mat flipped(const cv::Mat& m) {
  cv::Mat out;
  cv::flip(m, out, 1);
  return out;
}

cv::Mat random_colour_image(int rows, int cols) {
  cv::Mat bgr(rows, cols, CV_8UC3);
  cv::RNG rng(11);
  rng.fill(bgr, cv::RNG::UNIFORM, 0, 256);
  return bgr;
}

}  // namespace

TEST(MirrorPlan, EachChannelItsRule) {
  const std::vector<std::string> names{"fH", "fOx", "fOy", "fG1", "fG0", "fG3", "fCol", "fRow", "fZU", "fCtx:Road"};
  const auto plan = mirror_plan(names, "W/stacks.json");
  ASSERT_EQ(plan.size(), names.size());
  for (std::size_t k = 0; k < names.size(); ++k) {
    const std::string& n = names[k];
    EXPECT_EQ(plan[k].source, n == "fG1" ? 5u : n == "fG3" ? 3u : k) << n;
    EXPECT_EQ(plan[k].negate, n == "fOx") << n;
    EXPECT_EQ(plan[k].flip, n != "fCol") << n;
  }
}

TEST(MirrorPlan, ChannelsWithoutAMirrorAreRefusedByName) {
  EXPECT_EQ(smseg::test::error_of([] { mirror_plan({"fH", "fTx3"}, "W/stacks.json"); }),
            "W/stacks.json: features: --mirror cannot mirror the texton channel fTx3 (the filter bank's odd filters "
            "change sign: the mirrored frame's textons are not the mirror of its own)");
  EXPECT_EQ(smseg::test::error_of([] { mirror_plan({"fH", "fWho"}, "W/stacks.json"); }),
            "W/stacks.json: features: --mirror does not know how the channel fWho changes under a mirror");
  EXPECT_EQ(smseg::test::error_of([] { mirror_plan({"fG0", "fG1"}, "W/stacks.json"); }),
            "W/stacks.json: features: --mirror needs fG3 beside fG1 (a mirror turns one orientation bin into the other)");
}

TEST(MirrorTable, IsTheTableOfTheMirroredRaster) {
  cv::Mat raster(13, 17, CV_64FC1);
  cv::RNG(3).fill(raster, cv::RNG::UNIFORM, -2.0, 5.0);
  const cv::Mat table = summed_area_table(raster);
  EXPECT_LT(relative_gap(summed_area_table(flipped(raster)), mirrored_table(table, false)), 1e-14);
  EXPECT_LT(relative_gap(summed_area_table(-flipped(raster)), mirrored_table(table, true)), 1e-14);
  // Twice is the table again.
  EXPECT_LT(relative_gap(table, mirrored_table(mirrored_table(table, false), false)), 1e-14);
}

// The rules are those of the appearance code itself: the plan applied to an image's appearance tables
// gives the tables of the mirrored image's appearance (orientation bins swapped, column position kept).
TEST(MirrorTable, AppearanceOfTheMirroredImage) {
  const cv::Mat bgr = random_colour_image(24, 31);
  std::vector<cv::Mat> here, there;
  append_appearance_rasters(bgr, here);
  append_appearance_rasters(flipped(bgr), there);
  const auto plan = mirror_plan(appearance_feature_names(), "test");
  for (std::size_t k = 0; k < plan.size(); ++k) {
    const cv::Mat source = summed_area_table(here[plan[k].source]);
    const cv::Mat mine = plan[k].flip ? mirrored_table(source, plan[k].negate) : source;
    EXPECT_LT(relative_gap(summed_area_table(there[k]), mine), 1e-12) << appearance_feature_names()[k];
  }
}

TEST(MirrorImage, ReversesEachRow) {
  const std::vector<std::uint8_t> image{1, 2, 3, 4, 5, 6};
  std::vector<std::uint8_t> out(6);
  mirror_image(image.data(), 3, 2, out.data());
  EXPECT_EQ(out, (std::vector<std::uint8_t>{3, 2, 1, 6, 5, 4}));
}

struct MirroredSet : ::testing::Test {
  fs::path work;
  std::vector<cv::Mat> rasters;
  cv::Mat gray, labels;
  const cv::Size size{11, 8};

  void SetUp() override {
    work = fs::temp_directory_path() / ("smseg_mirror_" + std::to_string(::getpid()) +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(work);
    StackManifest m;
    m.work = work;
    m.sequence = "/nowhere/seq";
    m.sequence_name = "seq";
    m.size = size;
    m.features = {"fH", "fOx", "fD"};
    m.classes = {"road", "car"};
    m.frames = {0, 1};
    m.labelled_frames = {0, 1};
    cv::RNG rng(5);
    for (int k = 0; k < 3; ++k) {
      cv::Mat r(size, CV_64FC1);
      rng.fill(r, cv::RNG::UNIFORM, -1.0, 1.0);
      rasters.push_back(r);
    }
    gray = cv::Mat(size, CV_8UC1);
    rng.fill(gray, cv::RNG::UNIFORM, 0, 256);
    labels = cv::Mat(size, CV_8UC1, cv::Scalar(0));
    labels(cv::Rect(0, 0, 3, 8)).setTo(1);  // a car on the left
    for (int f : m.frames) write_frame_values(work, f, size, rasters, gray, labels, m.features);
    save_stack_manifest(m);
  }
  void TearDown() override { fs::remove_all(work); }
};

TEST_F(MirroredSet, GrowsByTheMirrorOfEachFrame) {
  StackSet set = open_stacks({work}, FrameRange{}, true, true, {"fOx", "fH"});
  const Json before = training_data_record(set);
  add_mirrored_frames(set);
  ASSERT_EQ(set.origin.size(), 2u);
  ASSERT_EQ(set.dataset.frames.size(), 4u);
  EXPECT_TRUE(set.mirrored());
  const forest::FrameData& mirror = set.dataset.frames[2];
  const auto table = [&](const forest::FrameData& d, std::size_t f) {
    return cv::Mat(size.height + 1, size.width + 1, CV_64FC1, const_cast<double*>(d.sats[f])).clone();
  };
  EXPECT_LT(relative_gap(summed_area_table(-flipped(rasters[1])), table(mirror, 0)), 1e-14);  // fOx
  EXPECT_LT(relative_gap(summed_area_table(flipped(rasters[0])), table(mirror, 1)), 1e-14);   // fH
  const cv::Mat mirror_labels(size, CV_8UC1, const_cast<std::uint8_t*>(mirror.labels));
  const cv::Mat mirror_gray(size, CV_8UC1, const_cast<std::uint8_t*>(mirror.gray));
  EXPECT_EQ(cv::norm(mirror_labels, flipped(labels), cv::NORM_INF), 0.0);  // the car now on the right
  EXPECT_EQ(cv::norm(mirror_gray, flipped(gray), cv::NORM_INF), 0.0);
  // The frames read are the same; the record says their mirrors were added.
  Json after = training_data_record(set);
  EXPECT_EQ(after.at("mirrored"), true);
  after.erase("mirrored");
  EXPECT_EQ(after, before);
  EXPECT_TRUE(frames_without_points(set).empty());
}

TEST_F(MirroredSet, ATextonChannelIsRefusedNamingTheFolder) {
  StackSet set = open_stacks({work}, FrameRange{}, true, true, {"fH"});
  set.dataset.features = {"fTx0"};  // as a folder extended by add-textons would name it
  const std::string e = smseg::test::error_of([&] { add_mirrored_frames(set); });
  EXPECT_NE(e.find((work / "stacks.json").string() + ": features: --mirror cannot mirror the texton channel fTx0"),
            std::string::npos)
      << e;
  EXPECT_EQ(set.dataset.frames.size(), 2u);
}
