// import-kitti: a made-up slice in KITTI odometry's own layout (calibration, times, poses and their
// conversion to our world frame, bad files), and the shared KITTI slices.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include <opencv2/imgcodecs.hpp>

#include "smseg/common/error.hpp"
#include "smseg/sequence/kitti.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace smseg::sequence;
using smseg::test::temp_dir;

namespace {

void write_text(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

/// Three 24x12 stereo frames in KITTI's own layout: fx 100, cx 12, cy 6, baseline 0.5 m; the camera
/// first at the origin, then 1 m forward, then 1 m forward and 2 m to its right.
fs::path make_kitti_slice(const std::string& name) {
  const fs::path d = temp_dir(name);
  fs::create_directories(d / "image_0");
  fs::create_directories(d / "image_1");
  for (int i = 0; i < 3; ++i) {
    char file[16];
    std::snprintf(file, sizeof file, "%06d.png", i);
    cv::imwrite((d / "image_0" / file).string(), cv::Mat(12, 24, CV_8UC1, cv::Scalar(40 * i)));
    cv::imwrite((d / "image_1" / file).string(), cv::Mat(12, 24, CV_8UC1, cv::Scalar(40 * i + 5)));
  }
  write_text(d / "calib.txt",
             "P0: 100 0 12 0 0 100 6 0 0 0 1 0\n"
             "P1: 100 0 12 -50 0 100 6 0 0 0 1 0\n"
             "P2: 100 0 12 4 0 100 6 0 0 0 1 0\n");
  write_text(d / "times.txt", "1.0\n1.1\n1.2\n");
  write_text(d / "poses.txt",
             "1 0 0 0 0 1 0 0 0 0 1 0\n"
             "1 0 0 0 0 1 0 0 0 0 1 1\n"
             "1 0 0 2 0 1 0 0 0 0 1 1\n");
  return d;
}

}  // namespace

TEST(ImportKitti, OwnLayoutGivesCalibrationTimesAndWorldPoses) {
  const fs::path d = make_kitti_slice("kitti_own");
  const smseg::test::RemovedAtEnd cleanup{d};
  const Sequence seq = import_kitti(d, d / "out", KittiImportOptions{});
  EXPECT_EQ(seq.kind, SequenceKind::Stereo);
  ASSERT_EQ(seq.frame_count(), 3);
  EXPECT_EQ(seq.size, cv::Size(24, 12));
  EXPECT_DOUBLE_EQ(*seq.calibration.fx, 100);
  EXPECT_DOUBLE_EQ(seq.calibration.cx, 12);
  EXPECT_DOUBLE_EQ(*seq.calibration.baseline, 0.5);
  EXPECT_NEAR(seq.frames[2].time, 0.2, 1e-12);  // times.txt, from the first frame
  EXPECT_TRUE(seq.labelled_frames.empty());
  EXPECT_EQ(seq.classes.size(), 11u);  // CamVid's road classes by default
  ASSERT_EQ(seq.gt_poses.size(), 3u);
  // First camera: level, 1.65 m above the origin, its down (camera y) is world -Y.
  const Pose& p0 = seq.gt_poses[0];
  EXPECT_DOUBLE_EQ(p0.t[1], 1.65);
  EXPECT_DOUBLE_EQ(p0.R[4], -1);  // camera y (down) -> world -Y
  EXPECT_DOUBLE_EQ(p0.R[8], 1);   // camera z (forward) -> world +Z
  // 1 m forward is world +Z; 2 m to the camera's right is world -X (our right-handed, Y-up frame).
  EXPECT_DOUBLE_EQ(seq.gt_poses[1].t[2], 1);
  EXPECT_DOUBLE_EQ(seq.gt_poses[2].t[0], -2);
  EXPECT_DOUBLE_EQ(seq.gt_poses[2].t[1], 1.65);
  const Sequence again = load_sequence(d / "out");
  EXPECT_EQ(again.frame_count(), 3);
  EXPECT_EQ(again.gt_poses.size(), 3u);
}

// A right camera whose principal point differs from the left one's (P1 cx 13.5 against P0's 12) shifts
// every disparity by 1.5 px: the sequence records the offset (calibration.disparity_offset); an
// explicit --disparity-offset (a slice whose images disagree with its calib.txt) wins; absurd values
// are refused.
TEST(ImportKitti, DisparityOffsetFromTheCalibrationOrTheOption) {
  const fs::path d = make_kitti_slice("kitti_offset");
  const smseg::test::RemovedAtEnd cleanup{d};
  EXPECT_EQ(import_kitti(d, d / "zero", KittiImportOptions{}).calibration.disparity_offset, 0);
  write_text(d / "calib.txt",
             "P0: 100 0 12 0 0 100 6 0 0 0 1 0\n"
             "P1: 100 0 13.5 -50 0 100 6 0 0 0 1 0\n");
  EXPECT_DOUBLE_EQ(import_kitti(d, d / "calib", KittiImportOptions{}).calibration.disparity_offset, 1.5);
  EXPECT_DOUBLE_EQ(load_sequence(d / "calib").calibration.disparity_offset, 1.5);
  KittiImportOptions o;
  o.disparity_offset = 1.25;
  EXPECT_DOUBLE_EQ(import_kitti(d, d / "option", o).calibration.disparity_offset, 1.25);
  EXPECT_DOUBLE_EQ(load_sequence(d / "option").calibration.disparity_offset, 1.25);
  o.disparity_offset = 5000;
  EXPECT_THROW(import_kitti(d, d / "absurd", o), smseg::Error);
}

TEST(ImportKitti, BadFilesNameTheFileAndLine) {
  const fs::path d = make_kitti_slice("kitti_bad");
  const smseg::test::RemovedAtEnd cleanup{d};
  auto message_of = [&] {
    try {
      import_kitti(d, d / "out", KittiImportOptions{});
    } catch (const smseg::Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  write_text(d / "calib.txt", "P0: 100 0 12 0 0 100 6 0 0 0 1\nP1: 100 0 12 -50 0 100 6 0 0 0 1 0\n");
  EXPECT_NE(message_of().find("calib.txt"), std::string::npos);
  EXPECT_NE(message_of().find("line 1"), std::string::npos);
  write_text(d / "calib.txt", "P0: 100 0 12 0 0 100 6 0 0 0 1 0\nP1: 100 0 12 50 0 100 6 0 0 0 1 0\n");
  EXPECT_NE(message_of().find("baseline"), std::string::npos);
  write_text(d / "calib.txt", "P0: 100 0 12 0 0 100 6 0 0 0 1 0\nP1: 100 0 12 -50 0 100 6 0 0 0 1 0\n");
  write_text(d / "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_NE(message_of().find("1 poses for 3 frames"), std::string::npos);
  write_text(d / "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 x\n1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_NE(message_of().find("\"x\" is not a finite number"), std::string::npos);
  fs::remove(d / "poses.txt");
  write_text(d / "times.txt", "1.0\n0.9\n1.2\n");
  EXPECT_NE(message_of().find("times must increase"), std::string::npos);
  fs::remove(d / "times.txt");
  fs::remove(d / "image_1" / "000001.png");
  EXPECT_NE(message_of().find("000001.png"), std::string::npos);
}

TEST(ImportKitti, SharedSlicesImport) {
  const fs::path kitti = fs::path(SMSEG_SHARED_DIR) / "data" / "kitti-stereo";
  if (!fs::exists(kitti / "seq1" / "calib.txt")) GTEST_SKIP() << "no shared KITTI slices at " << kitti;
  const fs::path out = temp_dir("kitti_shared");
  const smseg::test::RemovedAtEnd cleanup{out};
  const Sequence seq = import_kitti(kitti / "seq1", out, KittiImportOptions{});
  EXPECT_EQ(seq.frame_count(), 51);
  EXPECT_EQ(seq.size, cv::Size(1226, 370));
  EXPECT_NEAR(*seq.calibration.fx, 707.09, 0.01);
  EXPECT_NEAR(*seq.calibration.baseline, 0.537, 0.001);
  ASSERT_EQ(seq.gt_poses.size(), 51u);
  double length = 0;
  for (std::size_t i = 1; i < seq.gt_poses.size(); ++i)
    length += std::hypot(seq.gt_poses[i].t[0] - seq.gt_poses[i - 1].t[0], seq.gt_poses[i].t[2] - seq.gt_poses[i - 1].t[2]);
  EXPECT_GT(length, 50);  // ~60 m driven
  EXPECT_LT(length, 70);
  EXPECT_GT(seq.gt_poses.back().t[2], 10);  // mostly forward, world +Z
}

// A pose whose 3x3 part is not a rotation (a scaled or reflected matrix) is refused on import, naming
// the poses file's line, as the tracks reader refuses it; nothing is written.
TEST(ImportKitti, PosesThatAreNotRotationsAreRefusedNamingTheLine) {
  const fs::path d = make_kitti_slice("kitti_not_rotation");
  const smseg::test::RemovedAtEnd cleanup{d};
  const auto message_of = [&] {
    try {
      import_kitti(d, d / "out", KittiImportOptions{});
    } catch (const smseg::Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string first = "1 0 0 0 0 1 0 0 0 0 1 0\n", third = "1 0 0 2 0 1 0 0 0 0 1 1\n";
  for (const std::string& second : {std::string("2 0 0 0 0 1 0 0 0 0 1 1\n"),    // scaled
                                    std::string("-1 0 0 0 0 1 0 0 0 0 1 1\n"),   // a reflection
                                    std::string("0 0 0 0 0 0 0 0 0 0 0 1\n")}) {  // zero
    write_text(d / "poses.txt", first + second + third);
    EXPECT_EQ(message_of(), (d / "poses.txt").string() +
                                ": line 2: its first three columns are not a rotation matrix (R R^T = I, det R = 1)");
    EXPECT_FALSE(fs::exists(d / "out" / "sequence.json"));
  }
  // A rotation about the vertical axis, as KITTI prints it (six digits), passes.
  write_text(d / "poses.txt", first + "0.8660254 0 0.5 0 0 1 0 0 -0.5 0 0.8660254 1\n" + third);
  EXPECT_EQ(message_of(), "no error");
}
