// eval-forest's printed report: percentages, the mode, the summary line and one sweep point's line.
#include <gtest/gtest.h>

#include <cmath>

#include "smseg/eval/report.hpp"

namespace {

using namespace smseg;

TEST(EvalReport, PercentagesAndModes) {
  EXPECT_EQ(eval::percent_text(0.1234), "12.3%");
  EXPECT_EQ(eval::percent_text(NAN), "n/a");
  eval::EvalOptions opt;
  EXPECT_EQ(eval::mode_text(opt), "per pixel");
  opt.grid = 8;
  opt.votes = 5;
  EXPECT_EQ(eval::mode_text(opt).rfind("grid B=8 V=5 ", 0), 0u);
}

TEST(EvalReport, SummaryLineOfAnEmptyResult) {
  const eval::EvalResult r;
  const eval::EvalOptions opt;
  const std::string line = eval::summary_line(r, opt);
  EXPECT_EQ(line.rfind("0 test frames: global accuracy n/a, class-average accuracy n/a, mean IoU n/a", 0), 0u) << line;
  EXPECT_NE(line.find(", 0.00 ms per frame (per pixel)"), std::string::npos) << line;
  EXPECT_EQ(eval::detail_report(r, {}, "OUT", false).find("per-frame"), std::string::npos);
}

TEST(EvalReport, SweepPointLine) {
  const Json rec = {{"sweep", "M"}, {"value", 3}, {"global_accuracy", 0.5}, {"class_average_accuracy", nullptr},
                    {"mean_iou", 0.25}, {"seconds_per_frame", 0.002}};
  EXPECT_EQ(eval::sweep_point_line(rec), "M=3: global 50.0%, class-average n/a, mean IoU 25.0%, 2.00 ms per frame");
}

}  // namespace
