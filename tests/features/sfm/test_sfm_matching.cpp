// White-box tests of the monocular SfM's matching (features/frontend/src/sfm_matching.hpp, sfm_map.hpp):
// guided matching along epipolar lines, track merging, and matching a frame against the local map.
#include <gtest/gtest.h>

#include <random>

#include <opencv2/features2d.hpp>

#include "sfm_map.hpp"
#include "sfm_matching.hpp"

using namespace smseg::sfm;

namespace {

cv::Mat random_descriptors(int n, std::mt19937& rng) {
  std::normal_distribution<float> g(0, 1);
  cv::Mat d(n, 32, CV_32F);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < 32; ++c) d.at<float>(r, c) = g(rng);
  return d;
}

cv::Mat jittered(const cv::Mat& d, float sigma, std::mt19937& rng) {
  std::normal_distribution<float> g(0, sigma);
  cv::Mat out = d.clone();
  for (int r = 0; r < out.rows; ++r)
    for (int c = 0; c < out.cols; ++c) out.at<float>(r, c) += g(rng);
  return out;
}

// A rectified pair (pure sideways translation): a point's epipolar line is its own row.
const cv::Matx33d kRowsF(0, 0, 0, 0, 0, -1, 0, 1, 0);

}  // namespace

// Repeated texture: every keypoint of frame a has, in frame b, its true match 6 px to the left and a
// twin with the same descriptor 120 rows lower. A whole-image ratio test cannot tell them apart; the epipolar band can.
TEST(SfmMatching, EpipolarMatchingKeepsRepeatedTextureThatAWholeImageRatioTestRejects) {
  std::mt19937 rng(3);
  const int n = 40;
  const cv::Mat da = random_descriptors(n, rng);
  std::vector<cv::Point2f> pa, pb;
  for (int i = 0; i < n; ++i) pa.emplace_back(20.0f + 10 * i, 30.0f + 2 * i);
  cv::Mat db(2 * n, da.cols, CV_32F);
  jittered(da, 0.05f, rng).copyTo(db.rowRange(0, n));
  db.rowRange(0, n).copyTo(db.rowRange(n, 2 * n));
  for (int i = 0; i < n; ++i) pb.emplace_back(pa[i].x - 6, pa[i].y);
  for (int i = 0; i < n; ++i) pb.emplace_back(pa[i].x - 6, pa[i].y + 120);

  EXPECT_TRUE(sfm_matching::match_ratio(da, db, cv::NORM_L2, 0.8).empty());
  const auto m = sfm_matching::match_epipolar(da, pa, db, pb, kRowsF, cv::NORM_L2, 1.5, 0.8);
  ASSERT_EQ(m.size(), static_cast<std::size_t>(n));
  for (const auto& d : m) EXPECT_EQ(d.trainIdx, d.queryIdx) << "keypoint " << d.queryIdx;
}

// Two candidates on the same epipolar line that look alike: ambiguous, so no match.
TEST(SfmMatching, EpipolarMatchingDropsAmbiguousCandidatesOnTheSameLine) {
  std::mt19937 rng(4);
  const cv::Mat da = random_descriptors(1, rng);
  cv::Mat db;
  cv::vconcat(jittered(da, 0.05f, rng), jittered(da, 0.05f, rng), db);
  const std::vector<cv::Point2f> pa{{100, 50}}, pb{{90, 50}, {40, 50.5f}};
  EXPECT_TRUE(sfm_matching::match_epipolar(da, pa, db, pb, kRowsF, cv::NORM_L2, 1.5, 0.8).empty());
  // Off the line by more than the band, the twin no longer competes.
  const std::vector<cv::Point2f> pb_off{{90, 50}, {40, 53}};
  const auto m = sfm_matching::match_epipolar(da, pa, db, pb_off, kRowsF, cv::NORM_L2, 1.5, 0.8);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].trainIdx, 0);
}

TEST(SfmMap, MergeJoinsTracksWithoutACommonFrameAndRefusesOthers) {
  sfm_map::TrackTable t;
  // Frames 0..3, two keypoints each. Track 0: (0,0) (1,0); track 1: (3,1); track 2: (1,1) (2,0).
  t.tid = {{0, 3}, {0, 2}, {2, 4}, {5, 1}};
  t.tobs = {{{0, 0}, {1, 0}}, {{3, 1}}, {{1, 1}, {2, 0}}, {{0, 1}}, {{2, 1}}, {{3, 0}}};
  ASSERT_TRUE(t.merge(1, 0));
  EXPECT_EQ(t.tobs[0], (std::vector<std::pair<int, int>>{{0, 0}, {1, 0}, {3, 1}}));
  EXPECT_TRUE(t.tobs[1].empty());
  EXPECT_EQ(t.tid[3][1], 0);
  // Track 2 is in frame 1 as track 0 is: refused, nothing changes.
  EXPECT_FALSE(t.merge(2, 0));
  EXPECT_EQ(t.tobs[2].size(), 2u);
  EXPECT_EQ(t.tid[1][1], 2);
  EXPECT_FALSE(t.merge(0, 0));
  // Frames interleave: track 4 (frame 2) into track 3 (frame 0), then track 0's frames are all taken.
  ASSERT_TRUE(t.merge(4, 3));
  EXPECT_EQ(t.tobs[3], (std::vector<std::pair<int, int>>{{0, 1}, {2, 1}}));
}

// Frame 2 sees, under new tracks, a point of frame 0 (track with a 3D point) and one of frame 1 (no
// 3D point), and a keypoint of a track that already has a point: only the first is a candidate.
TEST(SfmMap, LocalMapCandidatesAreKeypointsWithoutAPointMatchedToMapPoints) {
  std::mt19937 rng(5);
  const cv::Mat base = random_descriptors(6, rng);
  sfm_map::TrackTable t;
  // Frame 0: tracks 0, 1, 5 (3D); frame 1: track 2 (no 3D), track 1; frame 2: tracks 3, 4, 1.
  t.tid = {{0, 1, 5}, {2, 1}, {3, 4, 1}};
  t.tobs = {{{0, 0}}, {{0, 1}, {1, 1}, {2, 2}}, {{1, 0}}, {{2, 0}}, {{2, 1}}, {{0, 2}}};
  const std::vector<char> has_point{1, 1, 0, 0, 0, 1};
  std::vector<cv::Mat> desc(3);
  cv::vconcat(base.rowRange(0, 2), base.row(3), desc[0]);                 // tracks 0, 1, 5 = base 0, 1, 3
  cv::vconcat(base.row(2), base.row(1), desc[1]);                         // track 2 = base 2
  cv::vconcat(std::vector<cv::Mat>{jittered(base.row(0), 0.05f, rng),    // keypoint 0 ~ track 0
                                   jittered(base.row(2), 0.05f, rng),    // keypoint 1 ~ track 2 (no point)
                                   base.row(1).clone()},
              desc[2]);
  const auto c = sfm_map::match_local_map(2, {0, 1}, t, has_point, desc, cv::NORM_L2, 0.8);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].keypoint, 0);
  EXPECT_EQ(c[0].track, 0);
}
