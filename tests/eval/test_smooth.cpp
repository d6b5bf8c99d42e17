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
// that favour the right class at 0.45 vs 0.275 each, except at 35% (flip_rate) of the pixels where a
// random wrong class gets 0.6.
struct Scene {
  cv::Mat image, truth;
  std::vector<float> dists;
  static constexpr int C = 3;
};

Scene make_scene(std::uint64_t seed, double flip_rate = 0.35) {
  const int W = 96, H = 72;
  Scene s;
  s.image.create(H, W, CV_8UC1);
  s.truth.create(H, W, CV_8UC1);
  std::mt19937_64 g(seed);
  std::uniform_int_distribution<int> noise(-6, 6), wrong(1, 2);
  std::bernoulli_distribution flip(flip_rate);
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

eval::SmoothOptions graph_cut(double lambda) {
  eval::SmoothOptions opt;
  opt.method = eval::SmoothMethod::GraphCut;
  opt.lambda = lambda;
  return opt;
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
  eval::SmoothOptions opt = graph_cut(0);
  const cv::Mat out = eval::smooth_labels(s.dists, Scene::C, s.image, opt);
  EXPECT_EQ(cv::countNonZero(out != map_labels(s)), 0);
}

TEST(Smooth, CleansNoisyPosteriorsAlongTheImageEdgesAndLowersTheEnergy) {
  const Scene s = make_scene(2);
  const double before = accuracy(map_labels(s), s.truth);
  EXPECT_LT(before, 0.75);  // the noise is real
  for (int connectivity : {4, 8}) {
    eval::SmoothOptions opt = graph_cut(2);
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
  eval::SmoothOptions opt = graph_cut(6);
  const cv::Mat with = eval::smooth_labels(s.dists, Scene::C, s.image, opt);
  const cv::Mat flat(s.image.size(), CV_8UC1, cv::Scalar(128));
  const cv::Mat without = eval::smooth_labels(s.dists, Scene::C, flat, opt);
  EXPECT_GT(accuracy(with, s.truth), accuracy(without, s.truth));
}

TEST(Smooth, ContrastOffReadsNothingOfTheImage) {
  // Plain Potts (contrast = false, eval-forest --smooth-contrast off): the scene's image, a flat one and
  // random noise give the same labels, and the report's beta is 0; with contrast they differ.
  const Scene s = make_scene(3);
  eval::SmoothOptions opt = graph_cut(6);
  opt.contrast = false;
  eval::SmoothReport rep;
  const cv::Mat on_scene = eval::smooth_labels(s.dists, Scene::C, s.image, opt, &rep);
  EXPECT_EQ(rep.beta, 0.0);
  const cv::Mat flat(s.image.size(), CV_8UC1, cv::Scalar(128));
  cv::Mat noise(s.image.size(), CV_8UC1);
  cv::randu(noise, 0, 256);
  EXPECT_EQ(cv::countNonZero(on_scene != eval::smooth_labels(s.dists, Scene::C, flat, opt)), 0);
  EXPECT_EQ(cv::countNonZero(on_scene != eval::smooth_labels(s.dists, Scene::C, noise, opt)), 0);
  opt.contrast = true;
  EXPECT_GT(cv::countNonZero(on_scene != eval::smooth_labels(s.dists, Scene::C, s.image, opt)), 0);
  EXPECT_EQ(opt.to_json()["contrast"], true);
}

namespace {

// The energy of a labelling, written out from the definition in smooth.hpp (8-connected): what the
// report's energies must be, whatever the solver left out of its graph.
double frame_energy(const Scene& s, const cv::Mat& labels, double lambda) {
  const double beta = eval::contrast_beta(s.image, 8), cap = -std::log(1e-3);
  double e = 0;
  for (std::size_t i = 0; i < labels.total(); ++i) {
    const float* d = s.dists.data() + i * Scene::C;
    const double p = double(d[labels.data[i]]) / (double(d[0]) + double(d[1]) + double(d[2]));
    e += p <= 1e-3 ? cap : std::min(cap, -std::log(p));
  }
  const int dy[4] = {0, 1, 1, 1}, dx[4] = {1, 0, 1, -1};
  for (int y = 0; y < s.image.rows; ++y)
    for (int x = 0; x < s.image.cols; ++x)
      for (int k = 0; k < 4; ++k) {
        const int y1 = y + dy[k], x1 = x + dx[k];
        if (y1 >= s.image.rows || x1 < 0 || x1 >= s.image.cols) continue;
        if (labels.at<std::uint8_t>(y, x) == labels.at<std::uint8_t>(y1, x1)) continue;
        const double d = double(s.image.at<std::uint8_t>(y, x)) - double(s.image.at<std::uint8_t>(y1, x1));
        e += lambda * std::exp(-beta * d * d) / (k < 2 ? 1.0 : std::sqrt(2.0));
      }
  return e;
}

}  // namespace

TEST(Smooth, ALabelWindowWiderThanTheFrameIsPlainAlphaExpansion) {
  const Scene s = make_scene(5);
  eval::SmoothOptions opt = graph_cut(2);
  opt.label_window = 0;
  opt.bands = 1;  // one energy over the whole frame, as plain alpha-expansion has
  eval::SmoothReport plain, wide;
  const cv::Mat a = eval::smooth_labels(s.dists, Scene::C, s.image, opt, &plain);
  opt.label_window = 200;
  const cv::Mat b = eval::smooth_labels(s.dists, Scene::C, s.image, opt, &wide);
  EXPECT_EQ(cv::countNonZero(a != b), 0);
  EXPECT_EQ(wide.allowed_labels, std::int64_t(a.total()) * Scene::C);
  EXPECT_NEAR(wide.energy_after, plain.energy_after, 1e-6 * plain.energy_after);
  EXPECT_EQ(wide.moves, plain.moves);
}

TEST(Smooth, ANarrowLabelWindowGivesOnlyLabelsMappedNearbyAndReportsTheFrameEnergy) {
  const Scene s = make_scene(6, 0.03);  // few wrong pixels: most see one MAP label around them
  const cv::Mat map = map_labels(s);
  for (int radius : {1, 3}) {
    eval::SmoothOptions opt = graph_cut(2);
    opt.label_window = radius;
    eval::SmoothReport rep;
    const cv::Mat out = eval::smooth_labels(s.dists, Scene::C, s.image, opt, &rep);
    int far_labels = 0;
    for (int y = 0; y < out.rows; ++y)
      for (int x = 0; x < out.cols; ++x) {
        bool mapped_nearby = false;
        for (int v = std::max(0, y - radius); v <= std::min(out.rows - 1, y + radius); ++v)
          for (int u = std::max(0, x - radius); u <= std::min(out.cols - 1, x + radius); ++u)
            mapped_nearby |= map.at<std::uint8_t>(v, u) == out.at<std::uint8_t>(y, x);
        far_labels += mapped_nearby ? 0 : 1;
      }
    EXPECT_EQ(far_labels, 0) << "radius " << radius;
    EXPECT_LT(rep.allowed_labels, std::int64_t(out.total()) * Scene::C);
    // The pixels held at their MAP label are out of the solver's graph but not out of the energy.
    EXPECT_NEAR(rep.energy_before, frame_energy(s, map, 2), 1e-6 * rep.energy_before) << "radius " << radius;
    EXPECT_NEAR(rep.energy_after, frame_energy(s, out, 2), 1e-6 * rep.energy_after) << "radius " << radius;
    EXPECT_LT(rep.energy_after, rep.energy_before);
    EXPECT_GT(accuracy(out, s.truth), accuracy(map, s.truth)) << "radius " << radius;
  }
}

TEST(Smooth, BandsSolvedApartThenTheirSeamsGiveTheSameLabelsOnAnyThreadCount) {
  const Scene s = make_scene(8);
  const cv::Mat map = map_labels(s);
  eval::SmoothOptions opt = graph_cut(2);
  opt.label_window = 3;
  opt.bands = 1;
  eval::SmoothReport whole;
  eval::smooth_labels(s.dists, Scene::C, s.image, opt, &whole);
  for (const int bands : {2, 3, 7}) {
    opt.bands = bands;
    cv::Mat out[2];
    eval::SmoothReport rep[2];
    for (const int threads : {1, 2}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      out[threads - 1] = eval::smooth_labels(s.dists, Scene::C, s.image, opt, &rep[threads - 1]);
    }
    EXPECT_EQ(cv::countNonZero(out[0] != out[1]), 0) << bands << " bands";
    EXPECT_EQ(rep[0].energy_after, rep[1].energy_after) << bands << " bands";
    EXPECT_EQ(rep[0].graph_nodes, rep[1].graph_nodes) << bands << " bands";
    // The report is the whole frame's energy, and the bands find about the one energy's minimum.
    EXPECT_NEAR(rep[0].energy_before, frame_energy(s, map, 2), 1e-6 * rep[0].energy_before) << bands << " bands";
    EXPECT_NEAR(rep[0].energy_after, frame_energy(s, out[0], 2), 1e-6 * rep[0].energy_after) << bands << " bands";
    EXPECT_NEAR(rep[0].energy_after, whole.energy_after, 0.01 * whole.energy_after) << bands << " bands";
    EXPECT_LT(rep[0].energy_after, rep[0].energy_before);
    EXPECT_GT(accuracy(out[0], s.truth), accuracy(map, s.truth)) << bands << " bands";
    // The bands were used: the seams' moves cut their rows again.
    EXPECT_GT(rep[0].graph_nodes, whole.graph_nodes) << bands << " bands";
  }
}

TEST(Smooth, TheLabelWindowAllowsEachPixelExactlyTheMapLabelsWithinItsRadius) {
  // 70 classes (two 64-label planes) with random MAP labels on a 23x17 frame, whose sides are not
  // multiples of the dilation's blocks: the pixel-label pairs allowed equal a brute-force count of the
  // distinct MAP labels in each pixel's (2R + 1)-square, clipped to the frame, for radii from one pixel
  // to more than the frame.
  const int W = 23, H = 17, C = 70;
  std::mt19937_64 g(12);
  std::uniform_int_distribution<int> label(0, C - 1);
  cv::Mat map(H, W, CV_8UC1), image(H, W, CV_8UC1, cv::Scalar(90));
  std::vector<float> dists(std::size_t(W) * H * C, 0.1f);
  for (int i = 0; i < W * H; ++i) {
    map.data[i] = static_cast<std::uint8_t>(label(g) % (i % 3 == 0 ? C : 5 + 64 * (i % 2)));  // some runs share labels
    dists[std::size_t(i) * C + map.data[i]] = 1.0f;
  }
  for (int radius : {1, 2, 3, 5, 8, 40}) {
    std::int64_t expected = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        std::vector<bool> seen(C, false);
        for (int v = std::max(0, y - radius); v <= std::min(H - 1, y + radius); ++v)
          for (int u = std::max(0, x - radius); u <= std::min(W - 1, x + radius); ++u)
            seen[map.at<std::uint8_t>(v, u)] = true;
        expected += std::count(seen.begin(), seen.end(), true);
      }
    eval::SmoothOptions opt = graph_cut(1);
    opt.label_window = radius;
    eval::SmoothReport rep;
    eval::smooth_labels(dists, C, image, opt, &rep);
    EXPECT_EQ(rep.allowed_labels, expected) << "radius " << radius;
  }
}

TEST(Smooth, ALabelThatIsNoNearbyPixelsMapLabelIsNeverGiven) {
  // A checkerboard of MAP labels 0 and 1 (0.5 / 0.05) over a flat image, with label 2 second everywhere
  // (0.45): plain alpha-expansion gives the whole board label 2, the label window keeps it out.
  const int W = 40, H = 30;
  const cv::Mat flat(H, W, CV_8UC1, cv::Scalar(100));
  std::vector<float> dists;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const bool even = (x + y) % 2 == 0;
      dists.insert(dists.end(), {even ? 0.5f : 0.05f, even ? 0.05f : 0.5f, 0.45f});
    }
  eval::SmoothOptions opt = graph_cut(2);
  opt.label_window = 0;
  EXPECT_GT(cv::countNonZero(eval::smooth_labels(dists, 3, flat, opt) == 2), W * H / 2);
  opt.label_window = 3;
  eval::SmoothReport rep;
  EXPECT_EQ(cv::countNonZero(eval::smooth_labels(dists, 3, flat, opt, &rep) == 2), 0);
  EXPECT_EQ(rep.allowed_labels, std::int64_t(W) * H * 2);
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
  opt.connectivity = 8;
  opt.label_window = -1;
  EXPECT_THROW(opt.validate(), Error);
  opt.label_window = 0;
  EXPECT_THROW(eval::smooth_method_from_string("crf", "--smooth"), Error);
  std::vector<float> bad = s.dists;
  bad[5] = -1;
  opt.connectivity = 4;
  EXPECT_THROW(eval::smooth_labels(bad, Scene::C, s.image, opt), Error);
  // Under the label window the rows are read at once; the error still names the frame's first bad pixel.
  opt.label_window = 3;
  for (const int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<float> two_bad = s.dists;
    two_bad[std::size_t(70 * 96 + 3) * Scene::C] = std::nanf("");
    two_bad[std::size_t(40 * 96 + 5) * Scene::C + 1] = -2;
    try {
      eval::smooth_labels(two_bad, Scene::C, s.image, opt);
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("pixel " + std::to_string(40 * 96 + 5) + " "), std::string::npos) << e.what();
    }
  }
  opt.bands = 0;
  EXPECT_THROW(opt.validate(), Error);
  opt.bands = 65;
  EXPECT_THROW(opt.validate(), Error);
}

TEST(Smooth, EvaluateReportsSmoothingApart) {
  const fs::path work = eval_test::make_work("smooth", 7);
  const forest::Forest forest = eval_test::train(work, 5, 2);
  eval::EvalOptions opt;
  opt.frames = stacks::FrameRange{5, 7};
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
  opt.frames = stacks::FrameRange{5, 8};
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
