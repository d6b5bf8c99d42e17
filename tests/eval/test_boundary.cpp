// Boundary F1: perfect on the truth itself, tolerant to shifts up to T, lowered by speckle, blind to void.
#include <gtest/gtest.h>

#include <cmath>

#include "smseg/eval/boundary.hpp"

using namespace smseg;

namespace {

// 40x30: class 0 left of column `edge`, class 1 right of it.
cv::Mat split(int edge) {
  cv::Mat m(30, 40, CV_8UC1, cv::Scalar(0));
  m.colRange(edge, 40).setTo(1);
  return m;
}

}  // namespace

TEST(Boundary, TruthAgainstItselfIsPerfect) {
  const cv::Mat t = split(20);
  const eval::BoundaryCounts c = eval::boundary_counts(t, t, 0);
  EXPECT_EQ(c.truth, 30);  // one boundary pixel per row (the left side of the edge)
  EXPECT_EQ(c.output, 30);
  EXPECT_DOUBLE_EQ(c.f1(), 1.0);
}

TEST(Boundary, ShiftsWithinTheToleranceCount) {
  const cv::Mat t = split(20), p = split(22);
  EXPECT_DOUBLE_EQ(eval::boundary_counts(t, p, 3).f1(), 1.0);
  EXPECT_DOUBLE_EQ(eval::boundary_counts(t, p, 2).f1(), 1.0);
  EXPECT_DOUBLE_EQ(eval::boundary_counts(t, p, 1).f1(), 0.0);
}

TEST(Boundary, SpeckleLowersPrecisionNotRecall) {
  const cv::Mat t = split(20);
  cv::Mat p = t.clone();
  for (int y = 3; y < 30; y += 6) p.at<std::uint8_t>(y, 5) = 1;  // isolated wrong pixels far from the edge
  const eval::BoundaryCounts c = eval::boundary_counts(t, p, 3);
  EXPECT_DOUBLE_EQ(c.recall(), 1.0);
  EXPECT_LT(c.precision(), 0.8);
  EXPECT_LT(c.f1(), 0.9);
}

TEST(Boundary, VoidIsNoBoundary) {
  cv::Mat t = split(20);
  t.rowRange(0, 10).setTo(255);  // void band on top
  const cv::Mat p = split(20);
  const eval::BoundaryCounts c = eval::boundary_counts(t, p, 0);
  EXPECT_EQ(c.truth, 20);  // rows 10..29 only: not the void border
  EXPECT_EQ(c.output, 20);
  EXPECT_DOUBLE_EQ(c.f1(), 1.0);
  const cv::Mat flat(30, 40, CV_8UC1, cv::Scalar(0));
  EXPECT_TRUE(std::isnan(eval::boundary_counts(flat, flat, 3).f1()));
}
