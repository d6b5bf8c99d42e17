// Metrics on hand-made confusion matrices (docs/design.md section 5); void never counts.
#include <gtest/gtest.h>

#include <cmath>

#include "smseg/common/error.hpp"
#include "smseg/eval/metrics.hpp"

using smseg::eval::Confusion;

TEST(Metrics, HandMadeConfusionMatrix) {
  // truth\pred  0   1   2
  //   0         8   2   0
  //   1         1   3   0
  //   2         0   0   0   (class 2 absent from truth, predicted nowhere)
  Confusion c(3);
  c.add(0, 0, 8);
  c.add(0, 1, 2);
  c.add(1, 0, 1);
  c.add(1, 1, 3);
  EXPECT_EQ(c.total(), 14);
  EXPECT_DOUBLE_EQ(c.global_accuracy(), 11.0 / 14.0);
  // Recall: 0.8 and 0.75; class 2 has no pixels and does not count.
  EXPECT_DOUBLE_EQ(c.class_average_accuracy(), (0.8 + 0.75) / 2.0);
  // IoU: class 0 = 8 / (8 + 1 + 2) ; class 1 = 3 / (3 + 2 + 1).
  EXPECT_DOUBLE_EQ(c.mean_iou(), (8.0 / 11.0 + 3.0 / 6.0) / 2.0);
  EXPECT_TRUE(std::isnan(c.recall()[2]));
  const auto norm = c.normalised_json();
  EXPECT_DOUBLE_EQ(norm[0][1].get<double>(), 0.2);
  EXPECT_TRUE(norm[2][0].is_null());
  const std::string table = c.table({"floor", "wall", "ceiling"});
  EXPECT_NE(table.find("80.0%"), std::string::npos) << table;
  EXPECT_NE(table.find("75.0%"), std::string::npos) << table;
}

TEST(Metrics, ImagesIgnoreVoidPixels) {
  cv::Mat truth = (cv::Mat_<std::uint8_t>(2, 3) << 0, 1, 255, 1, 1, 255);
  cv::Mat pred = (cv::Mat_<std::uint8_t>(2, 3) << 0, 0, 1, 1, 1, 0);
  Confusion c(2);
  c.add(truth, pred);
  EXPECT_EQ(c.total(), 4);
  EXPECT_DOUBLE_EQ(c.global_accuracy(), 0.75);
  EXPECT_DOUBLE_EQ(c.class_average_accuracy(), (1.0 + 2.0 / 3.0) / 2.0);
  Confusion d(2);
  d.merge(c);
  d.merge(c);
  EXPECT_EQ(d.at(1, 0), 2);
  EXPECT_THROW(c.add(0, 5), smseg::Error);
}

TEST(Metrics, EmptyIsNaNNotZero) {
  Confusion c(2);
  EXPECT_TRUE(std::isnan(c.global_accuracy()));
  EXPECT_TRUE(std::isnan(c.class_average_accuracy()));
}
