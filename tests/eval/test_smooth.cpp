// Graph-cut smoothing of the per-pixel output: the contrast beta, lambda = 0 is the MAP labelling, the
// energy never rises, noisy posteriors over a piecewise-constant image are cleaned along the image's
// edges, and evaluate() reports smoothing apart.
#include <gtest/gtest.h>

#include <random>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "eval_fixture.hpp"
#include "smseg/common/error.hpp"
#include "smseg/eval/evaluate.hpp"
#include "smseg/eval/smooth.hpp"

namespace fs = std::filesystem;
using namespace smseg;

namespace {

// A 96x72 image of three regions (a left band, an upper right and a lower right block, the latter
// with a diagonal edge) at distinct grey levels with a little noise, their class ids, and posteriors
// that favour the right class at 0.45 vs 0.275 each, except at 35% of the pixels where a random
// wrong class gets 0.6.
struct Scene {
  cv::Mat image, truth;
  std::vector<float> dists;
  static constexpr int C = 3;
};

Scene make_scene(std::uint64_t seed) {
  const int W = 96, H = 72;
  Scene s;
  s.image.create(H, W, CV_8UC1);
  s.truth.create(H, W, CV_8UC1);
  std::mt19937_64 g(seed);
  std::uniform_int_distribution<int> noise(-6, 6), wrong(1, 2);
  std::bernoulli_distribution flip(0.35);
  const int grey[3] = {50, 130, 210};
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int t = x < 30 ? 0 : (y < 20 + x / 3 ? 1 : 2);
      s.truth.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(t);
      s.image.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(grey[t] + noise(g));
      std::vector<float> p(Scene::C, 0.275f);
      p[std::size_t(t)] = 0.45f;
      if (flip(g)) {
        std::fill(p.begin(), p.end(), 0.2f);
        p[std::size_t((t + wrong(g)) % Scene::C)] = 0.6f;
      }
      s.dists.insert(s.dists.end(), p.begin(), p.end());
    }
  return s;
}

double accuracy(const cv::Mat& a, const cv::Mat& b) {
  return double(cv::countNonZero(a == b)) / double(a.total());
}

cv::Mat map_labels(const Scene& s) {
  cv::Mat m(s.truth.size(), CV_8UC1);
  for (std::size_t i = 0; i < m.total(); ++i) {
    const float* d = s.dists.data() + i * Scene::C;
    m.data[i] = static_cast<std::uint8_t>(std::max_element(d, d + Scene::C) - d);
  }
  return m;
}

}  // namespace

TEST(Smooth, BetaIsHalfTheInverseMeanSquaredNeighbourDifference) {
  // Columns alternate 0 and 10: horizontal pairs differ by 10, vertical ones by 0.
  cv::Mat img(6, 8, CV_8UC1);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x) img.at<std::uint8_t>(y, x) = x % 2 ? 10 : 0;
  // 4-connected: 6*7 horizontal pairs of 100, 5*8 vertical pairs of 0.
  EXPECT_NEAR(eval::contrast_beta(img, 4), 1.0 / (2.0 * (42.0 * 100.0 / 82.0)), 1e-12);
  // 8-connected adds 2 * 5*7 diagonal pairs of 100.
  EXPECT_NEAR(eval::contrast_beta(img, 8), 1.0 / (2.0 * (112.0 * 100.0 / 152.0)), 1e-12);
  EXPECT_EQ(eval::contrast_beta(cv::Mat(5, 5, CV_8UC1, cv::Scalar(7)), 8), 0.0);
}

TEST(Smooth, LambdaZeroIsTheMapLabelling) {
  const Scene s = make_scene(1);
  eval::SmoothOptions opt;
  opt.method = eval::SmoothMethod::GraphCut;
  opt.lambda = 0;
  const cv::Mat out = eval::smooth_labels(s.dists, Scene::C, s.image, opt);
  EXPECT_EQ(cv::countNonZero(out != map_labels(s)), 0);
}

TEST(Smooth, CleansNoisyPosteriorsAlongTheImageEdgesAndLowersTheEnergy) {
  const Scene s = make_scene(2);
  const double before = accuracy(map_labels(s), s.truth);
  EXPECT_LT(before, 0.75);  // the noise is real
  for (int connectivity : {4, 8}) {
    eval::SmoothOptions opt;
    opt.method = eval::SmoothMethod::GraphCut;
    opt.lambda = 2;
    opt.connectivity = connectivity;
    eval::SmoothReport rep;
    const cv::Mat out = eval::smooth_labels(s.dists, Scene::C, s.image, opt, &rep);
    EXPECT_GT(accuracy(out, s.truth), 0.99) << connectivity << "-connected";
    EXPECT_LT(rep.energy_after, rep.energy_before);
    EXPECT_GT(rep.moves, 0);
  }
}

TEST(Smooth, WithoutContrastTheSameSmoothingCutsCorners) {
  // On a flat image (no edges to follow) a strong Potts term rounds off the 3-way junction and the
  // diagonal edge; with the image's contrast it follows them: contrast must help.
  const Scene s = make_scene(3);
  eval::SmoothOptions opt;
  opt.method = eval::SmoothMethod::GraphCut;
  opt.lambda = 6;
  const cv::Mat with = eval::smooth_labels(s.dists, Scene::C, s.image, opt);
  const cv::Mat flat(s.image.size(), CV_8UC1, cv::Scalar(128));
  const cv::Mat without = eval::smooth_labels(s.dists, Scene::C, flat, opt);
  EXPECT_GT(accuracy(with, s.truth), accuracy(without, s.truth));
}

TEST(Smooth, BadInputIsAnError) {
  const Scene s = make_scene(4);
  eval::SmoothOptions opt;
  opt.method = eval::SmoothMethod::GraphCut;
  EXPECT_THROW(eval::smooth_labels(std::span<const float>(s.dists).first(10), Scene::C, s.image, opt), Error);
  EXPECT_THROW(eval::smooth_labels(s.dists, Scene::C, cv::Mat(), opt), Error);
  opt.lambda = -1;
  EXPECT_THROW(eval::smooth_labels(s.dists, Scene::C, s.image, opt), Error);
  opt.lambda = 1;
  opt.connectivity = 6;
  EXPECT_THROW(opt.validate(), Error);
  EXPECT_THROW(eval::smooth_method_from_string("crf", "--smooth"), Error);
  std::vector<float> bad = s.dists;
  bad[5] = -1;
  opt.connectivity = 4;
  EXPECT_THROW(eval::smooth_labels(bad, Scene::C, s.image, opt), Error);
}

TEST(Smooth, EvaluateReportsSmoothingApart) {
  const fs::path work = eval_test::make_work("smooth", 7);
  const forest::Forest forest = eval_test::train(work, 5, 2);
  eval::EvalOptions opt;
  opt.frames = features::FrameRange{5, 7};
  const eval::EvalResult plain = eval::evaluate(forest, {work}, opt);
  opt.smooth.method = eval::SmoothMethod::GraphCut;
  opt.smooth.lambda = 1;
  const eval::EvalResult smoothed = eval::evaluate(forest, {work}, opt);
  EXPECT_GT(smoothed.smooth_seconds_per_frame, 0);
  EXPECT_EQ(plain.smooth_seconds_per_frame, 0);
  // A two-region scene with a clean image edge: smoothing must not make it worse.
  EXPECT_GE(smoothed.confusion.global_accuracy(), plain.confusion.global_accuracy() - 0.005);
  const auto j = smoothed.to_json(forest, opt, {work.string()});
  EXPECT_EQ(j["params"]["smooth"]["method"], "graphcut");
  EXPECT_EQ(j["params"]["smooth"]["lambda"], 1.0);
  EXPECT_GT(j["smooth_seconds_per_frame"].get<double>(), 0);
  opt.grid = 10;
  EXPECT_THROW(eval::evaluate(forest, {work}, opt), Error);
  fs::remove_all(work);
}

TEST(Smooth, FramesSmoothedTogetherGetTheLabelsTheyGetOneByOne) {
  // With --smooth, evaluate() labels one frame per thread at once; three frames on two threads make a
  // batch of two and one of one. Each frame must get the labels (so the confusion) it gets alone.
  const fs::path work = eval_test::make_work("smooth-batch", 8);
  const forest::Forest forest = eval_test::train(work, 5, 2);
  eval::EvalOptions opt;
  opt.frames = features::FrameRange{5, 8};
  opt.smooth.method = eval::SmoothMethod::GraphCut;
  opt.smooth.lambda = 1;
  auto run = [&](std::size_t threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    return eval::evaluate(forest, {work}, opt);
  };
  const eval::EvalResult one = run(1), two = run(2);
  EXPECT_EQ(one.frames_in_flight, 1);
  EXPECT_EQ(two.frames_in_flight, std::min(2, tbb::this_task_arena::max_concurrency()));
  ASSERT_EQ(one.frames.size(), 3u);
  ASSERT_EQ(two.frames.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(one.frames[i].frame, two.frames[i].frame);
    EXPECT_EQ(one.frames[i].confusion.counts_json(), two.frames[i].confusion.counts_json()) << "frame " << i;
  }
  EXPECT_GT(two.wall_seconds_per_frame, 0);
  fs::remove_all(work);
}
