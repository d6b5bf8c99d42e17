// Training and evaluation over stacks written to disk: a learnable scene is learned, grid voting with
// every pixel voting agrees with the per-pixel summed distributions, and mismatched inputs are refused.
#include <gtest/gtest.h>

#include "smseg/eval/evaluate.hpp"
#include "eval_fixture.hpp"

namespace fs = std::filesystem;
using namespace smseg;

using eval_test::make_work;
using eval_test::train;

TEST(Evaluate, LearnsASeparableSceneAndScoresIt) {
  const fs::path work = make_work("learn", 12);
  const forest::Forest f = train(work, 8);
  eval::EvalOptions opt;
  opt.frames = stacks::FrameRange{8, 12};
  const eval::EvalResult r = eval::evaluate(f, {work}, opt);
  ASSERT_EQ(r.frames.size(), 4u);
  EXPECT_GT(r.confusion.global_accuracy(), 0.9);
  EXPECT_GT(r.confusion.class_average_accuracy(), 0.85);
  EXPECT_EQ(r.confusion.total(), 4 * 47 * 64);  // row 0 is void and never counts
  const auto j = r.to_json(f, opt, {work.string()});
  for (const char* key : {"global_accuracy", "class_average_accuracy", "mean_iou", "confusion", "per_frame",
                          "seconds_per_frame", "params", "forest"})
    EXPECT_TRUE(j.contains(key)) << key;
  fs::remove_all(work);
}

TEST(Evaluate, GridVotingWithEveryPixelEqualsSummedPerPixelDistributions) {
  const fs::path work = make_work("grid", 6);
  const forest::Forest f = train(work, 6);
  const auto set = stacks::open_stacks({work}, stacks::FrameRange{5, 6}, true, true, {});
  const forest::Classifier c(f);
  const forest::FrameData& frame = set.dataset.frames[0];
  eval::EvalOptions opt;
  opt.grid = 8;
  opt.votes = 64;  // V = B*B: every pixel of the cell votes
  const cv::Mat grid = eval::label_frame(c, frame, opt, 5);
  // Reference: each cell takes the class of maximum summed distribution over all its pixels.
  std::vector<float> dist(f.classes.size());
  for (int cy = 0; cy < 6; ++cy)
    for (int cx = 0; cx < 8; ++cx) {
      std::vector<double> sum(f.classes.size(), 0.0);
      for (int y = cy * 8; y < cy * 8 + 8; ++y)
        for (int x = cx * 8; x < cx * 8 + 8; ++x) {
          c.posterior(frame, x, y, dist.data());
          for (std::size_t k = 0; k < sum.size(); ++k) sum[k] += dist[k];
        }
      const int best = static_cast<int>(std::max_element(sum.begin(), sum.end()) - sum.begin());
      // A cell is one class throughout.
      const cv::Mat cell = grid(cv::Rect(cx * 8, cy * 8, 8, 8));
      double lo, hi;
      cv::minMaxLoc(cell, &lo, &hi);
      EXPECT_EQ(lo, hi);
      EXPECT_EQ(static_cast<int>(hi), best) << "cell " << cx << "," << cy;
    }
  // Fewer votes: still one class per cell, and the same labels for the same seed.
  opt.votes = 6;
  const cv::Mat a = eval::label_frame(c, frame, opt, 5), b = eval::label_frame(c, frame, opt, 5);
  EXPECT_EQ(cv::countNonZero(a != b), 0);
  fs::remove_all(work);
}

TEST(Evaluate, MismatchedForestIsRefused) {
  const fs::path work = make_work("mismatch", 3);
  const forest::Forest f = train(work, 3);
  const fs::path other = make_work("mismatch_other", 2, {"road", "sky"});
  eval::EvalOptions opt;
  try {
    eval::evaluate(f, {other}, opt);
    FAIL() << "a forest of other classes was accepted";
  } catch (const smseg::Error& e) {
    EXPECT_NE(std::string(e.what()).find("stacks.json"), std::string::npos) << e.what();
  }
  forest::Forest wrong_features = f;
  wrong_features.features = {"fH", "fC"};
  EXPECT_THROW(eval::evaluate(wrong_features, {work}, opt), smseg::Error);
  opt.frames = stacks::FrameRange{50, 60};
  EXPECT_THROW(eval::evaluate(f, {work}, opt), smseg::Error);  // no such frames
  fs::remove_all(work);
  fs::remove_all(other);
}

TEST(Evaluate, BadInputsGiveOneClearErrorEach) {
  const fs::path work = make_work("bad", 4);
  const forest::Forest f = train(work, 3);
  eval::EvalOptions opt;
  opt.frames = stacks::FrameRange{3, 4};
  const auto expect_error = [](const auto& run, const std::string& part) {
    try {
      run();
      ADD_FAILURE() << "accepted, expected an error mentioning " << part;
    } catch (const smseg::Error& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  // Stacks of another size than the forest was trained on.
  const fs::path big = make_work("bad_size", 4, {"floor", "wall"}, cv::Size(80, 60));
  expect_error([&] { eval::evaluate(f, {big}, opt); }, "80x60");
  // A forest trained on other features than the stack has.
  forest::Forest other_features = f;
  other_features.features = {"fH", "fOx"};
  expect_error([&] { eval::evaluate(other_features, {work}, opt); }, "fOx");
  // A forest trained on other classes.
  forest::Forest other_classes = f;
  other_classes.classes = {"floor", "sky"};
  expect_error([&] { eval::evaluate(other_classes, {work}, opt); }, "classes");
  // Missing frames: none in the range, or a stack file gone.
  eval::EvalOptions none = opt;
  none.frames = stacks::FrameRange{40, 50};
  expect_error([&] { eval::evaluate(f, {work}, none); }, "frames");
  fs::remove(stacks::values_path(work, 3));
  expect_error([&] { eval::evaluate(f, {work}, opt); }, "000003");
  // A cost matrix made for other classes.
  eval::EvalOptions costs = opt;
  costs.frames = stacks::FrameRange{0, 3};
  costs.costs = eval::CostMatrix{{"road", "sky"}, {0, 1, 1, 0}};
  costs.costs_file = "costs.json";
  expect_error([&] { eval::evaluate(f, {work}, costs); }, "costs.json");
  fs::remove_all(work);
  fs::remove_all(big);
}

TEST(Evaluate, ResultsCarryTheNewScoresAndParameters) {
  const fs::path work = make_work("results", 6);
  const forest::Forest f = train(work, 5);
  eval::EvalOptions opt;
  opt.frames = stacks::FrameRange{5, 6};
  opt.superpixels = 10;
  opt.votes = 5;
  opt.vote = eval::VoteRule::Majority;
  opt.tolerance = 2;
  opt.costs = eval::CostMatrix{f.classes, {0, 2, 1, 0}};
  opt.costs_file = "c.json";
  const eval::EvalResult r = eval::evaluate(f, {work}, opt);
  EXPECT_GE(r.tolerant_accuracy(), r.confusion.global_accuracy());
  const auto j = r.to_json(f, opt, {work.string()});
  EXPECT_EQ(j["params"]["mode"], "superpixels");
  EXPECT_EQ(j["params"]["vote"], "majority");
  EXPECT_EQ(j["params"]["tolerance"], 2);
  EXPECT_EQ(j["params"]["trees"], 5);
  EXPECT_EQ(j["forest"]["image"]["width"], 64);
  EXPECT_DOUBLE_EQ(j["mean_cost"].get<double>(),
                   (2.0 * double(r.confusion.at(0, 1)) + double(r.confusion.at(1, 0))) / double(r.confusion.total()));
  EXPECT_GT(j["superpixel_seconds_per_frame"].get<double>(), 0.0);
  EXPECT_TRUE(j["per_frame"][0].contains("boundary_tolerant_accuracy"));
  fs::remove_all(work);
}
