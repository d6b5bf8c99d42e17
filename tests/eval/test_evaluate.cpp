// Training and evaluation over stacks written to disk: a learnable scene is learned, grid voting with
// every pixel voting agrees with the per-pixel summed distributions, and mismatched inputs are refused.
#include <gtest/gtest.h>

#include "smseg/eval/evaluate.hpp"
#include "smseg/features/point_features.hpp"
#include "smseg/forest/train.hpp"

namespace fs = std::filesystem;
using namespace smseg;

namespace {

// A 64x48 "scene": class 0 (floor) below row 30, class 1 (wall) above; sparse points carry fH = 0 on
// the floor and 1.5 on the wall, fD marks them. Row 0 is void.
fs::path make_work(const std::string& name, int frames, std::vector<std::string> classes = {"floor", "wall"}) {
  const fs::path work = fs::temp_directory_path() / ("smseg_eval_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(work);
  features::StackManifest m;
  m.work = work;
  m.sequence = work / "no-sequence";
  m.size = cv::Size(64, 48);
  m.features = {"fH", "fD"};
  m.classes = classes;
  cv::RNG rng(3);
  for (int f = 0; f < frames; ++f) {
    cv::Mat fh = cv::Mat::zeros(48, 64, CV_64FC1), fd = cv::Mat::zeros(48, 64, CV_64FC1);
    cv::Mat labels(48, 64, CV_8UC1);
    const int boundary = 26 + f % 8;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 64; ++x) {
        labels.at<std::uint8_t>(y, x) = y == 0 ? 255 : (y >= boundary ? 0 : 1);
        if (rng.uniform(0, 6) == 0) {
          fd.at<double>(y, x) = 1;
          fh.at<double>(y, x) = y >= boundary ? 0.0 : 1.5;
        }
      }
    features::write_frame_stack(work, f, {features::summed_area_table(fh), features::summed_area_table(fd)},
                                cv::Mat(48, 64, CV_8UC1, cv::Scalar(100)), labels);
    m.frames.push_back(f);
    m.labelled_frames.push_back(f);
  }
  features::save_stack_manifest(m);
  return work;
}

forest::Forest train(const fs::path& work, int frames_end) {
  const auto set = features::open_stacks({work}, features::FrameRange{0, frames_end}, true, true, {});
  forest::TrainParams p;
  p.K = 200;
  p.M = 5;
  return forest::train_forest(set.dataset, p);
}

}  // namespace

TEST(Evaluate, LearnsASeparableSceneAndScoresIt) {
  const fs::path work = make_work("learn", 12);
  const forest::Forest f = train(work, 8);
  eval::EvalOptions opt;
  opt.frames = features::FrameRange{8, 12};
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
  const auto set = features::open_stacks({work}, features::FrameRange{5, 6}, true, true, {});
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
  opt.frames = features::FrameRange{50, 60};
  EXPECT_THROW(eval::evaluate(f, {work}, opt), smseg::Error);  // no such frames
  fs::remove_all(work);
  fs::remove_all(other);
}
