// Feature stacks of version 1 (tables as .npy files, as older work folders hold them): write,
// memory-map, read back exactly; corrupt or foreign files are refused. Version 2: test_stack_values.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "smseg/stacks/point_features.hpp"
#include "smseg/stacks/stack.hpp"

namespace fs = std::filesystem;
using namespace smseg::sequence;
using namespace smseg::stacks;

namespace {

struct StackFixture : ::testing::Test {
  fs::path work;
  StackManifest m;
  std::vector<cv::Mat> rasters;
  cv::Mat gray, labels;

  void SetUp() override {
    work = fs::temp_directory_path() /
           ("smseg_stack_" + std::to_string(::getpid()) + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(work);
    m.work = work;
    m.sequence = "/nowhere/seq";
    m.sequence_name = "seq";
    m.size = cv::Size(9, 7);
    m.features = {"fH", "fD"};
    m.classes = {"floor", "wall"};
    m.frames = {0, 3};
    m.labelled_frames = {3};
    m.version = 1;
    cv::RNG rng(7);
    for (int k = 0; k < 2; ++k) {
      cv::Mat r(7, 9, CV_64FC1);
      rng.fill(r, cv::RNG::UNIFORM, -1.0, 1.0);
      rasters.push_back(r);
    }
    gray = cv::Mat(7, 9, CV_8UC1);
    rng.fill(gray, cv::RNG::UNIFORM, 0, 256);
    labels = cv::Mat(7, 9, CV_8UC1, cv::Scalar(1));
    labels.at<std::uint8_t>(2, 2) = 255;
    std::vector<cv::Mat> sats;
    for (const auto& r : rasters) sats.push_back(summed_area_table(r));
    write_frame_stack(work, 0, sats, gray, cv::Mat());
    write_frame_stack(work, 3, sats, gray, labels);
    save_stack_manifest(m);
  }
  void TearDown() override { fs::remove_all(work); }

  std::string open_error(int frame, bool with_labels) {
    try {
      FrameStack::open(load_stack_manifest(work), frame, with_labels);
    } catch (const smseg::Error& e) {
      return e.what();
    }
    return "";
  }
};

}  // namespace

TEST_F(StackFixture, RoundTripThroughTheMemoryMap) {
  const StackManifest back = load_stack_manifest(work);
  EXPECT_EQ(back.features, m.features);
  EXPECT_EQ(back.frames, m.frames);
  EXPECT_TRUE(back.is_labelled(3));
  const FrameStack s = FrameStack::open(back, 3, true);
  const auto view = s.view();
  ASSERT_EQ(view.sats.size(), 2u);
  EXPECT_EQ(view.width, 9);
  for (int f = 0; f < 2; ++f) {
    const cv::Mat sat = summed_area_table(rasters[f]);
    for (int y = 0; y <= 7; ++y)
      for (int x = 0; x <= 9; ++x) EXPECT_EQ(view.sats[f][y * 10 + x], sat.at<double>(y, x));
  }
  for (int i = 0; i < 63; ++i) {
    EXPECT_EQ(view.gray[i], gray.data[i]);
    EXPECT_EQ(view.labels[i], labels.data[i]);
  }
  EXPECT_EQ(FrameStack::open(back, 0, false).labels(), nullptr);
}

TEST_F(StackFixture, NumpyReadableHeader) {
  // The header is plain .npy: magic, version 1.0, a dict with descr / fortran_order / shape.
  const std::string bytes = smseg::read_file(sat_path(work, 3));
  const NpyHeader h = parse_npy_header(bytes, sat_path(work, 3));
  EXPECT_EQ(h.descr, "<f8");
  EXPECT_EQ(h.shape, (std::vector<std::size_t>{2, 8, 10}));
  EXPECT_EQ(h.data_offset % 64, 0u);
  EXPECT_EQ(bytes.size(), h.data_offset + 2 * 8 * 10 * 8);
}

TEST_F(StackFixture, CorruptAndForeignFilesAreRefused) {
  // Truncated table file.
  const std::string bytes = smseg::read_file(sat_path(work, 3));
  smseg::write_file_atomic(sat_path(work, 3), bytes.substr(0, bytes.size() - 8));
  std::string e = open_error(3, true);
  EXPECT_NE(e.find("000003.sat.npy"), std::string::npos) << e;
  EXPECT_NE(e.find("truncated"), std::string::npos) << e;
  // Not an npy at all.
  smseg::write_file_atomic(sat_path(work, 3), "hello");
  e = open_error(3, true);
  EXPECT_NE(e.find("not a valid .npy"), std::string::npos) << e;
  // A stack of another size.
  smseg::write_file_atomic(gray_path(work, 0), make_npy_header("|u1", {6, 9}) + std::string(54, '\0'));
  e = open_error(0, false);
  EXPECT_NE(e.find("shape: is 6x9"), std::string::npos) << e;
  // Wrong dtype.
  smseg::write_file_atomic(gray_path(work, 0), make_npy_header("<f4", {7, 9}) + std::string(63 * 4, '\0'));
  e = open_error(0, false);
  EXPECT_NE(e.find("expected '|u1'"), std::string::npos) << e;
  // Frames that do not exist or are not labelled.
  EXPECT_NE(open_error(5, false).find("frame 5 has no feature stack"), std::string::npos);
  EXPECT_NE(open_error(0, true).find("frame 0 is not labelled"), std::string::npos);
}

// issue 19, defect 3: a NaN or an infinity in a SAT file (damaged or foreign) is refused with the file
// and the value's place, not passed on to training and evaluation.
TEST_F(StackFixture, NonFiniteSatValuesAreRefused) {
  const std::string bytes = smseg::read_file(sat_path(work, 3));
  const std::size_t offset = parse_npy_header(bytes, sat_path(work, 3)).data_offset;
  // Shape 2 x 8 x 10: value 93 is feature 1, row 1, column 3.
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                           -std::numeric_limits<double>::infinity()}) {
    std::string damaged = bytes;
    std::memcpy(damaged.data() + offset + 93 * sizeof(double), &bad, sizeof bad);
    smseg::write_file_atomic(sat_path(work, 3), damaged);
    const std::string e = open_error(3, false);
    EXPECT_NE(e.find("000003.sat.npy: SAT value 93 (feature 1, row 1, column 3) is "), std::string::npos) << e;
    EXPECT_NE(e.find(std::isnan(bad) ? "is NaN" : "is infinite"), std::string::npos) << e;
  }
  smseg::write_file_atomic(sat_path(work, 3), bytes);
  EXPECT_NO_THROW(FrameStack::open(load_stack_manifest(work), 3, false));
}

TEST_F(StackFixture, ManifestErrors) {
  smseg::Json j = smseg::read_json(work / "stacks.json");
  j["format"] = "smseg-sequence";
  smseg::write_json_atomic(work / "stacks.json", j);
  EXPECT_THROW(load_stack_manifest(work), smseg::Error);
  j["format"] = "smseg-stacks";
  j["version"] = 99;
  smseg::write_json_atomic(work / "stacks.json", j);
  try {
    load_stack_manifest(work);
    FAIL();
  } catch (const smseg::Error& e) {
    EXPECT_NE(std::string(e.what()).find("unsupported version 99"), std::string::npos);
  }
  fs::remove(work / "stacks.json");
  try {
    load_stack_manifest(work);
    FAIL();
  } catch (const smseg::Error& e) {
    EXPECT_NE(std::string(e.what()).find("run extract-features first"), std::string::npos);
  }
}

TEST_F(StackFixture, AStackThatIsAFolderIsCalledAFolder) {
  fs::remove(gray_path(work, 0));
  fs::create_directories(gray_path(work, 0));
  const std::string e = open_error(0, false);
  EXPECT_NE(e.find("000000.gray.npy: is a folder"), std::string::npos) << e;
}

TEST_F(StackFixture, ALabelOutOfRangeNamesTheLabelsFileNotAPosition) {
  labels.at<std::uint8_t>(4, 6) = 7;  // two classes: 0, 1 (and 255)
  std::vector<cv::Mat> sats;
  for (const auto& r : rasters) sats.push_back(summed_area_table(r));
  write_frame_stack(work, 3, sats, gray, labels);
  try {
    open_stacks({work}, FrameRange{}, true, true, {});
    FAIL() << "label 7 of 2 classes was accepted";
  } catch (const smseg::Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(labels_path(work, 3).string() + ": pixel (6, 4) has label 7"), std::string::npos) << msg;
  }
}

TEST_F(StackFixture, FramesWithoutPointsAreFoundAndNamed) {
  // Frame 0 holds points (random features); frame 3 gets all-zero tables, as a frame with no point has.
  std::vector<cv::Mat> zeros;
  for (const auto& r : rasters) zeros.push_back(summed_area_table(cv::Mat::zeros(r.size(), r.type())));
  write_frame_stack(work, 3, zeros, gray, labels);
  const StackSet set = open_stacks({work}, FrameRange{}, false, false, {});
  const auto empty = frames_without_points(set);
  ASSERT_EQ(empty.size(), 1u);
  EXPECT_EQ(empty[0], std::make_pair(0, 3));
  EXPECT_EQ(frames_without_points_message(set, empty), work.string() + ": 1 of 2 frames hold no tracked point (3)");
}
