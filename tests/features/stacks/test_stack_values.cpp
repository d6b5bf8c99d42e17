// Feature stacks of version 2 (values files, docs/formats.md): every kind of raster, and appearance
// channels made again from the colour image, come back as the very table extraction computes
// (cv::integral over the same doubles); damaged files are refused in one line naming the file.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "error_text.hpp"
#include "smseg/stacks/appearance.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/stacks/stack.hpp"

namespace fs = std::filesystem;
using namespace smseg::stacks;

namespace {

/// Rasters of every kind the writer tells apart: doubles, float32 values, bytes, 16-bit integers,
/// zeros, and sparse values with a negative zero (which must stay negative).
std::vector<cv::Mat> rasters_of_every_kind(cv::Size size) {
  cv::RNG rng(11);
  std::vector<cv::Mat> out;
  cv::Mat d(size, CV_64FC1), f(size, CV_64FC1), u8(size, CV_64FC1), u16(size, CV_64FC1), sparse(size, CV_64FC1, 0.0);
  rng.fill(d, cv::RNG::UNIFORM, -3.0, 3.0);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      f.at<double>(y, x) = static_cast<float>(rng.uniform(-1.0, 1.0));
      u8.at<double>(y, x) = rng.uniform(0, 256);
      u16.at<double>(y, x) = rng.uniform(0, 65536);
      if (rng.uniform(0, 9) == 0) sparse.at<double>(y, x) = rng.uniform(-2.0, 2.0);
    }
  sparse.at<double>(1, 1) = -0.0;
  out = {d, f, u8, u16, cv::Mat::zeros(size, CV_64FC1), sparse};
  return out;
}

struct ValuesFixture : ::testing::Test {
  fs::path work;
  StackManifest m;
  std::vector<cv::Mat> rasters;
  cv::Mat gray, labels, colour;

  void SetUp() override {
    work = fs::temp_directory_path() / ("smseg_values_" + std::to_string(::getpid()) +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(work);
    m.work = work;
    m.sequence = "/nowhere/seq";
    m.size = cv::Size(23, 17);
    // Six channels of every kind, then the appearance channels of a colour image.
    m.features = {"v0", "v1", "v2", "v3", "v4", "v5"};
    m.features.insert(m.features.end(), appearance_feature_names().begin(), appearance_feature_names().end());
    m.classes = {"floor", "wall"};
    m.frames = {0, 3};
    m.labelled_frames = {3};
    rasters = rasters_of_every_kind(m.size);
    colour = cv::Mat(m.size, CV_8UC3);
    cv::RNG(5).fill(colour, cv::RNG::UNIFORM, 0, 256);
    append_appearance_rasters(colour, rasters);
    gray = cv::Mat(m.size, CV_8UC1);
    cv::RNG(6).fill(gray, cv::RNG::UNIFORM, 0, 256);
    labels = cv::Mat(m.size, CV_8UC1, cv::Scalar(1));
    labels.at<std::uint8_t>(2, 2) = 255;
    write_frame_values(work, 0, m.size, rasters, gray, cv::Mat());  // every channel stored
    write_frame_values(work, 3, m.size, rasters, gray, labels, m.features, colour);
    save_stack_manifest(m);
  }
  void TearDown() override { fs::remove_all(work); }

  /// The error opening the frame, or "" when it opens.
  std::string open_error(int frame) {
    const std::string e = smseg::test::error_of([&] { FrameStack::open(load_stack_manifest(work), frame, true); });
    return e == "(no error)" ? "" : e;
  }
};

}  // namespace

TEST_F(ValuesFixture, TablesAreExtractionsBitForBit) {
  const StackManifest back = load_stack_manifest(work);
  EXPECT_EQ(back.version, 2);
  for (int frame : {0, 3}) {
    const FrameStack s = FrameStack::open(back, frame, frame == 3);
    for (std::size_t k = 0; k < rasters.size(); ++k) {
      const cv::Mat want = summed_area_table(rasters[k]);
      EXPECT_EQ(0, std::memcmp(s.sat(static_cast<int>(k)), want.ptr<double>(), want.total() * sizeof(double))) << k;
    }
    EXPECT_EQ(0, std::memcmp(s.gray(), gray.data, gray.total()));
    if (frame == 3) EXPECT_EQ(0, std::memcmp(s.labels(), labels.data, labels.total()));
    else EXPECT_EQ(s.labels(), nullptr);
    // A released frame reads the same again.
    const smseg::forest::FrameData d = s.view();
    d.release();
    const cv::Mat want = summed_area_table(rasters[0]);
    EXPECT_EQ(0, std::memcmp(d.sats[0], want.ptr<double>(), want.total() * sizeof(double)));
  }
}

// A reader that asks for some channels gets their very tables and no others (their blocks are passed
// over; their headers still checked): with and without the colour image's channels among them.
TEST_F(ValuesFixture, ChannelsAskedForComeBackBitForBitTheOthersAreNotBuilt) {
  const StackManifest back = load_stack_manifest(work);
  const std::size_t appearance = 6;  // the first appearance channel
  for (const std::vector<std::size_t>& asked : {std::vector<std::size_t>{1, 4}, std::vector<std::size_t>{0, appearance + 2},
                                                std::vector<std::size_t>{}}) {
    std::vector<bool> wanted(back.features.size(), false);
    for (std::size_t k : asked) wanted[k] = true;
    for (int frame : {0, 3}) {
      const FrameStack s = FrameStack::open(back, frame, frame == 3, wanted);
      for (std::size_t k = 0; k < rasters.size(); ++k) {
        if (!wanted[k]) {
          EXPECT_EQ(s.sat(static_cast<int>(k)), nullptr) << k;
          continue;
        }
        const cv::Mat want = summed_area_table(rasters[k]);
        EXPECT_EQ(0, std::memcmp(s.sat(static_cast<int>(k)), want.ptr<double>(), want.total() * sizeof(double))) << k;
      }
      EXPECT_EQ(0, std::memcmp(s.gray(), gray.data, gray.total()));
    }
  }
  // A block header damaged in a channel not asked for is still refused.
  const fs::path file = values_path(work, 0);
  std::string bad = smseg::read_file(file);
  bad[24] = static_cast<char>(0x7f);  // the first block's encoding
  smseg::write_file_atomic(file, bad);
  std::vector<bool> only_last(back.features.size(), false);
  only_last.back() = true;
  const std::string e = smseg::test::error_of([&] { FrameStack::open(back, 0, false, only_last); });
  EXPECT_EQ(e.rfind(file.string() + ": ", 0), 0u) << e;
  EXPECT_NE(e.find("unknown encoding"), std::string::npos) << e;
}

// open_stacks opens the frames in parallel: of two damaged frames, the error names the first, always.
TEST_F(ValuesFixture, OfTwoDamagedFramesTheFirstIsNamed) {
  for (int frame : {0, 3}) smseg::write_file_atomic(values_path(work, frame), "not a values file");
  for (int run = 0; run < 20; ++run) {
    const std::string e = smseg::test::error_of([&] { open_stacks({work}, FrameRange{}, false, false, {}); });
    ASSERT_EQ(e.rfind(values_path(work, 0).string() + ": ", 0), 0u) << e;
  }
}

// A changed byte is refused in one line naming the file, unless it leaves what the file says unchanged
// (zstd's frame header has bits that do not change the content its checksum covers): then the tables
// are the same. A file cut short, or with a byte more, is always refused.
TEST_F(ValuesFixture, DamagedFilesAreRefusedInOneLineNamingTheFile) {
  const fs::path file = values_path(work, 3);
  const std::string good = smseg::read_file(file);
  const auto same_tables = [&] {
    const FrameStack s = FrameStack::open(load_stack_manifest(work), 3, true);
    for (std::size_t k = 0; k < rasters.size(); ++k) {
      const cv::Mat want = summed_area_table(rasters[k]);
      if (std::memcmp(s.sat(static_cast<int>(k)), want.ptr<double>(), want.total() * sizeof(double)) != 0) return false;
    }
    return std::memcmp(s.gray(), gray.data, gray.total()) == 0 && std::memcmp(s.labels(), labels.data, labels.total()) == 0;
  };
  const auto check = [&](const std::string& bytes, const std::string& what, bool may_read_the_same) {
    smseg::write_file_atomic(file, bytes);
    const std::string e = open_error(3);
    if (e.empty() && may_read_the_same) {
      EXPECT_TRUE(same_tables()) << what << " was read, with other values";
      return;
    }
    EXPECT_EQ(e.rfind(file.string() + ": ", 0), 0u) << what << ": " << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << what << ": " << e;
  };
  for (std::size_t at = 0; at < good.size(); at += at < 64 ? 1 : 5) {
    std::string bad = good;
    bad[at] = static_cast<char>(bad[at] ^ 0x5a);
    check(bad, "byte " + std::to_string(at) + " changed", true);
  }
  for (std::size_t n = 0; n < good.size(); n += 11) check(good.substr(0, n), "cut at " + std::to_string(n), false);
  check(good + "x", "a byte after the end", false);
  smseg::write_file_atomic(file, good);
  EXPECT_EQ(open_error(3), "");
}

TEST_F(ValuesFixture, NonFiniteValuesAndWrongCountsAreRefused) {
  std::vector<cv::Mat> bad = rasters;
  bad[0].at<double>(4, 6) = std::numeric_limits<double>::quiet_NaN();
  write_frame_values(work, 3, m.size, bad, gray, labels);
  EXPECT_NE(open_error(3).find("channel 0 pixel (6, 4) is NaN"), std::string::npos) << open_error(3);
  bad.pop_back();
  write_frame_values(work, 3, m.size, bad, gray, labels);
  EXPECT_NE(open_error(3).find("holds 14 channels, the work folder's stacks.json says 15"), std::string::npos);
  write_frame_values(work, 3, m.size, rasters, gray, cv::Mat());  // a labelled frame without its labels
  EXPECT_NE(open_error(3).find("images field is 1, expected 3 (gray stored, labels stored)"), std::string::npos)
      << open_error(3);
  fs::remove(values_path(work, 3));
  EXPECT_NE(open_error(3).find("000003.values.bin"), std::string::npos) << open_error(3);
}

TEST_F(ValuesFixture, ALabelOutOfRangeNamesTheValuesFile) {
  labels.at<std::uint8_t>(4, 6) = 7;
  write_frame_values(work, 3, m.size, rasters, gray, labels);
  try {
    open_stacks({work}, FrameRange{}, true, true, {});
    FAIL() << "label 7 of 2 classes was accepted";
  } catch (const smseg::Error& e) {
    EXPECT_NE(std::string(e.what()).find(values_path(work, 3).string() + ": pixel (6, 4) has label 7"),
              std::string::npos) << e.what();
  }
}

TEST_F(ValuesFixture, AppearanceChannelsComeFromTheColourImageOnlyWhenExact) {
  // Frame 3 holds the colour image instead of the nine appearance channels: a smaller file.
  EXPECT_LT(fs::file_size(values_path(work, 3)), fs::file_size(values_path(work, 0)) / 2);
  // A raster that is not what the colour image makes (one value changed) is stored as it is.
  std::vector<cv::Mat> changed = rasters;
  changed[6] = rasters[6].clone();
  changed[6].at<double>(3, 3) += 1e-9;
  write_frame_values(work, 3, m.size, changed, gray, labels, m.features, colour);
  const FrameStack s = FrameStack::open(load_stack_manifest(work), 3, true);
  for (std::size_t k = 0; k < changed.size(); ++k) {
    const cv::Mat want = summed_area_table(changed[k]);
    EXPECT_EQ(0, std::memcmp(s.sat(static_cast<int>(k)), want.ptr<double>(), want.total() * sizeof(double))) << k;
  }
}

TEST_F(ValuesFixture, SparseAndSmallValuesPackSmall) {
  // The sparse channel (one value in nine) and the integers take a fraction of their doubles.
  std::vector<cv::Mat> sparse_only = {rasters[5], rasters[2], rasters[4]};
  write_frame_values(work, 7, m.size, sparse_only, cv::Mat(), cv::Mat());
  EXPECT_LT(fs::file_size(values_path(work, 7)), 3 * m.size.area() * 8 / 3);
}
