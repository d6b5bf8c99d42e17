// The monocular SfM's descriptor tracker on real 1 Hz video: the first 24 frames of CamVid's train run
// 0016E5_00390-02400 (../shared/data/camvid), where consecutive whole-image matching alone leaves a
// third of the frames without a pose.
#include <gtest/gtest.h>

#include <cstdio>

#include <tbb/global_control.h>

#include "smseg/sfm/sfm.hpp"
#include "smseg/sequence/camvid.hpp"
#include "temp_dir.hpp"
#include "front_end_equal.hpp"

namespace fs = std::filesystem;
using namespace smseg;
using namespace smseg::sequence;
using namespace smseg::frontend;
using namespace smseg::sfm;

namespace {

class SfmCamVid1Hz : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const fs::path camvid = fs::path(SMSEG_SHARED_DIR) / "data" / "camvid";
    if (!fs::exists(camvid / "frames.csv")) return;
    dir_ = new fs::path(smseg::test::temp_dir("sfm_camvid_1hz"));
    CamvidImportOptions io;
    io.splits = {"train"};
    import_camvid(camvid, *dir_, io);
    seq_ = new Sequence(load_sequence(*dir_ / "0016E5_00390-02400"));
  }
  static void TearDownTestSuite() {
    delete seq_;
    seq_ = nullptr;
    if (dir_) fs::remove_all(*dir_);
    delete dir_;
    dir_ = nullptr;
  }
  void SetUp() override {
    if (!seq_) GTEST_SKIP() << "no shared CamVid";
  }
  static SfmOptions options() {
    SfmOptions o;
    o.focal = 650;  // about what self-calibration finds on CamVid's 1 Hz runs
    o.last_frame = 24;
    o.progress = false;
    return o;
  }
  static Sequence* seq_;
  static fs::path* dir_;
};
Sequence* SfmCamVid1Hz::seq_ = nullptr;
fs::path* SfmCamVid1Hz::dir_ = nullptr;

long points_in_tracks(const FrontEndResult& r) {
  long n = 0;
  for (const auto& t : r.tracks) n += static_cast<long>(t.frames.size());
  return n;
}

}  // namespace

TEST_F(SfmCamVid1Hz, EpipolarMatchingAndTheLocalMapPoseMoreFramesWithMorePoints) {
  SfmOptions plain = options();
  plain.epipolar_ratio = 0;
  plain.map_window = 0;
  SfmReport before, after;
  const FrontEndResult a = run_mono_front_end(*seq_, plain, &before);
  const FrontEndResult b = run_mono_front_end(*seq_, options(), &after);
  ASSERT_EQ(before.tracker, SfmTracker::Descriptors);
  EXPECT_EQ(before.map_joins, 0);
  EXPECT_GT(after.map_joins, 0);
  const int posed_before = before.pnp_frames + 2, posed_after = after.pnp_frames + 2;
  EXPECT_GE(posed_after, posed_before + 3) << "before " << posed_before << ", after " << posed_after;
  EXPECT_GT(static_cast<double>(after.observations), 1.3 * static_cast<double>(before.observations));
  EXPECT_GT(static_cast<double>(points_in_tracks(b)), 1.3 * static_cast<double>(points_in_tracks(a)));
  EXPECT_LT(after.reprojection_rms_px, 1.0);
  std::printf("[   INFO   ] posed %d -> %d of 24, observations %ld -> %ld, joins %ld\n", posed_before, posed_after,
              before.observations, after.observations, after.map_joins);
}

TEST_F(SfmCamVid1Hz, OutputDoesNotDependOnTheThreadCount) {
  const FrontEndResult many = run_mono_front_end(*seq_, options());
  FrontEndResult one;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = run_mono_front_end(*seq_, options());
  }
  expect_same_front_end(one, many);
}
