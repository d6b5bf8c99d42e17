// Beyond the thesis (its 5.2.2): the mean cost per pixel from a class-to-class cost matrix, and the
// boundary-tolerant accuracy, on hand-made cases; malformed cost files give one clear error each.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "smseg/common/error.hpp"
#include "smseg/eval/metrics.hpp"

namespace fs = std::filesystem;
using smseg::eval::Confusion;
using smseg::eval::CostMatrix;

namespace {
const std::vector<std::string> kClasses{"floor", "wall", "ceiling"};

CostMatrix costs_from(const std::string& text) {
  return CostMatrix::from_json(nlohmann::json::parse(text), "costs.json", kClasses);
}

void expect_field(const std::string& text, const std::string& field_part) {
  try {
    costs_from(text);
    FAIL() << "accepted: " << text;
  } catch (const smseg::Error& e) {
    EXPECT_EQ(e.file(), "costs.json");
    EXPECT_NE(std::string(e.what()).find(field_part), std::string::npos) << e.what();
  }
}
}  // namespace

TEST(Costs, MeanCostPerPixelWithReorderedClasses) {
  // The file lists the classes in another order than the forest: rows and columns follow the names.
  const CostMatrix m = costs_from(R"({"format": "smseg-costs", "version": 1,
      "classes": ["wall", "floor", "ceiling"],
      "costs": [[0, 4, 1], [3, 0, 2], [1, 5, 0]]})");
  // In forest order: cost(truth floor, out wall) = 3, (wall, floor) = 4, (wall, ceiling) = 1,
  // (floor, ceiling) = 2, (ceiling, wall) = 1, (ceiling, floor) = 5.
  EXPECT_EQ(m.at(0, 1), 3);
  EXPECT_EQ(m.at(1, 0), 4);
  EXPECT_EQ(m.at(1, 2), 1);
  EXPECT_EQ(m.at(0, 2), 2);
  EXPECT_EQ(m.at(2, 1), 1);
  EXPECT_EQ(m.at(2, 0), 5);
  Confusion c(3);
  c.add(0, 0, 10);
  c.add(1, 0, 2);  // wall taken for floor: 2 x 4
  c.add(1, 2, 3);  // wall taken for ceiling: 3 x 1
  c.add(2, 2, 5);
  EXPECT_DOUBLE_EQ(smseg::eval::mean_cost(c, m), (2 * 4.0 + 3 * 1.0) / 20.0);
  EXPECT_TRUE(std::isnan(smseg::eval::mean_cost(Confusion(3), m)));
}

TEST(Costs, MalformedFilesGiveOneClearErrorEach) {
  const std::string head = R"("format": "smseg-costs", "version": 1, )";
  expect_field(R"({"format": "smseg-other", "version": 1, "classes": [], "costs": []})", "format");
  expect_field("{" + head + R"("classes": ["floor", "wall", "sky"], "costs": [[0,1,1],[1,0,1],[1,1,0]]})", "sky");
  expect_field("{" + head + R"("classes": ["floor", "wall"], "costs": [[0,1],[1,0]]})", "ceiling");
  expect_field("{" + head + R"("classes": ["floor", "wall", "wall"], "costs": [[0,1,1],[1,0,1],[1,1,0]]})", "twice");
  expect_field("{" + head + R"("classes": ["floor", "wall", "ceiling"], "costs": [[0,1,1],[1,0,1]]})", "rows");
  expect_field("{" + head + R"("classes": ["floor", "wall", "ceiling"], "costs": [[0,1,1],[1,0],[1,1,0]]})",
               "costs[1]");
  expect_field("{" + head + R"("classes": ["floor", "wall", "ceiling"], "costs": [[0,-1,1],[1,0,1],[1,1,0]]})",
               ">= 0");
  expect_field("{" + head + R"("classes": ["floor", "wall", "ceiling"], "costs": [[0,1,1],[1,2,1],[1,1,0]]})",
               "diagonal");
  expect_field("{" + head + R"("classes": ["floor", "wall", "ceiling"], "costs": [[0,"a",1],[1,0,1],[1,1,0]]})",
               "costs[0][1]");
  expect_field("{" + head + R"("classes": ["floor", "wall", "ceiling"]})", "costs");
  // A file that is not JSON at all.
  const fs::path p = fs::temp_directory_path() / ("smseg_costs_" + std::to_string(::getpid()) + ".json");
  std::ofstream(p) << "{ \"format\": \"smseg-costs\", ";
  EXPECT_THROW(CostMatrix::load(p, kClasses), smseg::Error);
  fs::remove(p);
  EXPECT_THROW(CostMatrix::load(p, kClasses), smseg::Error);  // missing file
}

TEST(Tolerance, NearMissesCountByDistanceToTheOutputClass) {
  // Truth: class 0 left of x = 5, class 1 from x = 5; the output moves the boundary to x = 7, so
  // columns 5 and 6 are wrong (taken for 0) at distances 1 and 2 from the nearest true 0.
  cv::Mat truth(4, 12, CV_8UC1), pred(4, 12, CV_8UC1);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 12; ++x) {
      truth.at<std::uint8_t>(y, x) = x < 5 ? 0 : 1;
      pred.at<std::uint8_t>(y, x) = x < 7 ? 0 : 1;
    }
  EXPECT_EQ(smseg::eval::near_misses(truth, pred, 0), 0);
  EXPECT_EQ(smseg::eval::near_misses(truth, pred, 1), 4);
  EXPECT_EQ(smseg::eval::near_misses(truth, pred, 2), 8);
  EXPECT_EQ(smseg::eval::near_misses(truth, pred, 3), 8);
  // A wrong pixel of a class absent from the truth is never near; a void pixel never counts.
  pred.at<std::uint8_t>(1, 10) = 2;
  truth.at<std::uint8_t>(2, 6) = 255;
  EXPECT_EQ(smseg::eval::near_misses(truth, pred, 3), 7);
  // Euclidean, not square: a lone true 0 at (0, 0), the output says 0 at (2, 2) (distance 2.83).
  cv::Mat t2(5, 5, CV_8UC1, cv::Scalar(1)), p2(5, 5, CV_8UC1, cv::Scalar(1));
  t2.at<std::uint8_t>(0, 0) = 0;
  p2.at<std::uint8_t>(0, 0) = 0;
  p2.at<std::uint8_t>(2, 2) = 0;
  EXPECT_EQ(smseg::eval::near_misses(t2, p2, 2), 0);
  EXPECT_EQ(smseg::eval::near_misses(t2, p2, 3), 1);
  EXPECT_THROW(smseg::eval::near_misses(t2, p2, -1), smseg::Error);
}
