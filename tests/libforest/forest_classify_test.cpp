// The fast classifier against a plain per-pixel reference, and its API.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include "forest_test_util.hpp"
#include "smseg/common/error.hpp"

using namespace forest_test;

namespace {

SyntheticData frames(int n, std::uint64_t seed, bool random_labels, int width = 72, int height = 52) {
  SyntheticOptions o;
  o.width = width;
  o.height = height;
  o.frames = n;
  o.features = 3;
  o.seed = seed;
  o.integer_features = true;  // brute-force sums are then exact
  o.random_labels = random_labels;
  o.signal = 0.3;
  return make_synthetic(o);
}

// A forest of random structure: random windows (often partly outside the image), attributes and
// thresholds near the values actually met, random leaf counts.
// max_size caps window widths and heights (0: the bounds), so that some columns and rows keep every
// window inside the image (the classifier's unclipped path) while others do not.
Forest random_forest(const SyntheticData& s, std::uint64_t seed, bool textons, int max_size = 0) {
  Rng rng(seed);
  Forest f;
  f.width = s.data.width;
  f.height = s.data.height;
  f.classes = s.data.classes;
  f.features = s.data.features;
  f.textons = textons;
  const WindowBounds b = WindowBounds::for_image(f.width, f.height);
  for (int t = 0; t < 5; ++t) {
    Tree tree;
    tree.nodes.emplace_back();
    for (std::size_t i = 0; i < tree.nodes.size(); ++i) {
      if (tree.nodes.size() < 60 && rng.uniform() < 0.8) {
        Node& n = tree.nodes[i];
        n.feature = rng.uniform_int(0, f.num_attributes() - 1);
        const bool texton = n.feature >= static_cast<int>(f.features.size());
        n.win = Window{rng.uniform_int(-b.max_dx, b.max_dx), rng.uniform_int(-b.max_dy, b.max_dy),
                       texton ? 1 : rng.uniform_int(1, max_size ? std::min(max_size, b.max_w) : b.max_w),
                       texton ? 1 : rng.uniform_int(1, max_size ? std::min(max_size, b.max_h) : b.max_h)};
        // Threshold: the value at a random pixel, sometimes nudged, so that ties are exercised.
        const float v = brute_value(s, 0, n.feature, n.win, rng.uniform_int(0, f.width - 1), rng.uniform_int(0, f.height - 1));
        // Just above a value: float(v) < t holds, though t rounds to v in float.
        const int kind = static_cast<int>(rng.below(3));
        n.threshold = kind == 0   ? static_cast<double>(v)
                      : kind == 1 ? std::nextafter(static_cast<double>(v), 1e300)
                                  : static_cast<double>(v) + (rng.uniform() - 0.5) * 3.0;
        n.left = static_cast<int>(tree.nodes.size());
        n.right = n.left + 1;
        tree.nodes.emplace_back();
        tree.nodes.emplace_back();
      } else {
        for (std::size_t c = 0; c < f.classes.size(); ++c) tree.nodes[i].counts.push_back(static_cast<std::uint32_t>(rng.below(4)));
        tree.nodes[i].counts[rng.below(f.classes.size())] += 1;
      }
    }
    f.trees.push_back(std::move(tree));
  }
  f.compute_stats();
  return f;
}

// simd: whether whole frames may split their pixels with AVX-512 (where the processor has it).
void expect_matches_reference(const Forest& f, const SyntheticData& s, bool simd = true) {
  Classifier clf(f);
  clf.set_simd(simd);
  const std::size_t W = static_cast<std::size_t>(s.data.width), H = static_cast<std::size_t>(s.data.height);
  const std::size_t C = f.classes.size();
  std::vector<float> ref_acc;
  for (std::size_t fi = 0; fi < s.data.frames.size(); ++fi) {
    std::vector<std::uint8_t> labels(W * H);
    std::vector<float> dists(W * H * C);
    clf.classify_frame(s.data.frames[fi], labels, dists);
    std::size_t mismatches = 0;
    for (std::size_t y = 0; y < H; ++y)
      for (std::size_t x = 0; x < W; ++x) {
        const int ref = reference_classify(f, s, static_cast<int>(fi), static_cast<int>(x), static_cast<int>(y), ref_acc);
        const std::size_t i = y * W + x;
        mismatches += labels[i] != ref;
        for (std::size_t c = 0; c < C; ++c) mismatches += dists[i * C + c] != ref_acc[c];
      }
    EXPECT_EQ(mismatches, 0u) << "frame " << fi;
  }
}

}  // namespace

TEST(Classifier, WholeFrameEqualsThePerPixelReferenceOnTrainedForests) {
  const SyntheticData train = frames(3, 1, true), test = frames(2, 2, false);
  for (const bool textons : {false, true}) {
    TrainParams p;
    p.K = 150;
    p.M = 4;
    p.textons = textons;
    const Forest f = train_forest(train.data, p);
    // Random labels: deep, noisy trees (with textons the synthetic grey level gives the label away).
    if (!textons) {
      EXPECT_GT(f.stats.trees[0].depth, 5);
    }
    expect_matches_reference(f, test);
  }
}

TEST(Classifier, WholeFrameEqualsThePerPixelReferenceOnRandomForests) {
  const SyntheticData s = frames(2, 3, false);
  for (std::uint64_t seed = 1; seed <= 4; ++seed) expect_matches_reference(random_forest(s, seed, seed % 2 == 0), s);
}

TEST(Classifier, WholeFrameEqualsTheReferenceNearEveryBorder) {
  // Wider and taller frames than the sets the classifier routes together (several row blocks, rows
  // at the top and bottom whose windows leave the image, an inner band of columns), random forests
  // with small windows (wide inner band) and with windows up to the bounds (narrow or none).
  const SyntheticData s = frames(1, 9, false, 150, 91);
  for (std::uint64_t seed = 11; seed <= 14; ++seed)
    expect_matches_reference(random_forest(s, seed, seed % 2 == 0, seed <= 12 ? 3 : 0), s);
}

TEST(Classifier, ScalarSplitsEqualTheReferenceToo) {
  // Where the processor has AVX-512 the tests above check its splits; these check the scalar loop
  // that runs everywhere else (and on any processor with set_simd(false)).
  const SyntheticData train = frames(3, 1, true), test = frames(2, 2, false), border = frames(1, 9, false, 150, 91);
  TrainParams p;
  p.K = 150;
  p.M = 4;
  expect_matches_reference(train_forest(train.data, p), test, false);
  for (std::uint64_t seed = 11; seed <= 14; ++seed)
    expect_matches_reference(random_forest(border, seed, seed % 2 == 0, seed <= 12 ? 3 : 0), border, false);
}

TEST(Classifier, AvxSplitsAreOnlyWhereTheProcessorHasThem) {
  const SyntheticData s = frames(1, 3, false);
  Classifier clf(random_forest(s, 1, false));
  const bool available = clf.simd();  // on by default where available
  clf.set_simd(false);
  EXPECT_FALSE(clf.simd());
  clf.set_simd(true);
  EXPECT_EQ(clf.simd(), available);
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  // On by default exactly where the processor runs the AVX-512 splits.
  EXPECT_EQ(available, __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
                           __builtin_cpu_supports("avx512dq"));
#else
  EXPECT_FALSE(available);
#endif
}

class PixelLists : public ::testing::TestWithParam<bool> {};  // with texton tests, or windows only

TEST_P(PixelLists, AndSinglePixelsAgreeWithWholeFrames) {
  const SyntheticData s = frames(2, 4, false);
  TrainParams p;
  p.K = 100;
  p.textons = GetParam();
  const Forest f = train_forest(s.data, p);
  const Classifier clf(f);
  const std::size_t W = 72, H = 52, C = f.classes.size();
  std::vector<std::uint8_t> labels(W * H);
  std::vector<float> dists(W * H * C);
  clf.classify_frame(s.data.frames[1], labels, dists);
  std::vector<Pixel> pixels;
  Rng rng(8);
  for (int i = 0; i < 5000; ++i) pixels.push_back({rng.uniform_int(0, 71), rng.uniform_int(0, 51)});
  std::vector<std::uint8_t> pl(pixels.size());
  std::vector<float> pd(pixels.size() * C);
  clf.classify_pixels(s.data.frames[1], pixels, pl, pd);
  std::vector<float> one(C);
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const std::size_t at = static_cast<std::size_t>(pixels[i].y) * W + static_cast<std::size_t>(pixels[i].x);
    ASSERT_EQ(pl[i], labels[at]);
    ASSERT_EQ(0, std::memcmp(&pd[i * C], &dists[at * C], C * sizeof(float)));
    ASSERT_EQ(clf.posterior(s.data.frames[1], pixels[i].x, pixels[i].y, one.data()), labels[at]);
    ASSERT_EQ(0, std::memcmp(one.data(), &dists[at * C], C * sizeof(float)));
  }
  // The summed distribution adds up to the number of trees.
  double sum = 0;
  for (std::size_t c = 0; c < C; ++c) sum += dists[c];
  EXPECT_NEAR(sum, static_cast<double>(f.trees.size()), 1e-5);
}
INSTANTIATE_TEST_SUITE_P(Classifier, PixelLists, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& i) { return i.param ? "textons" : "windows"; });

TEST(Classifier, SameLabelsWhateverTheThreadCount) {
  const SyntheticData s = frames(2, 5, false);
  TrainParams p;
  p.K = 100;
  const Classifier clf(train_forest(s.data, p));
  std::vector<std::uint8_t> a(72 * 52), b(72 * 52);
  std::vector<float> da(a.size() * 4), db(a.size() * 4);
  {
    tbb::global_control g(tbb::global_control::max_allowed_parallelism, 1);
    clf.classify_frame(s.data.frames[0], a, da);
  }
  {
    tbb::global_control g(tbb::global_control::max_allowed_parallelism, 2);
    clf.classify_frame(s.data.frames[0], b, db);
  }
  EXPECT_EQ(a, b);
  EXPECT_EQ(da, db);
}

// classify_frame keeps a padded copy of the frame's tables per thread: frames classified from a
// parallel loop (each call's own parallel loop nested in it) must each get their own labels.
TEST(Classifier, FramesClassifiedInParallelEachGetTheirOwnLabels) {
  const SyntheticData s = frames(8, 9, false, 240, 180);
  TrainParams p;
  p.K = 100;
  const Classifier clf(train_forest(s.data, p));
  const std::size_t n = 240 * 180, F = s.data.frames.size();
  std::vector<std::vector<std::uint8_t>> alone(F, std::vector<std::uint8_t>(n)), together = alone;
  for (std::size_t f = 0; f < F; ++f) clf.classify_frame(s.data.frames[f], alone[f]);
  tbb::task_arena eight_threads(8);  // more threads than cores: more ways for the calls to interleave
  for (int round = 0; round < 20; ++round) {
    eight_threads.execute([&] {
      tbb::parallel_for(std::size_t(0), F, [&](std::size_t f) { clf.classify_frame(s.data.frames[f], together[f]); });
    });
    for (std::size_t f = 0; f < F; ++f) ASSERT_EQ(together[f], alone[f]) << "frame " << f << ", round " << round;
  }
}

TEST(Classifier, FramesThatDoNotFitAreRefused) {
  const SyntheticData s = frames(1, 6, false);
  TrainParams p;
  p.K = 50;
  p.M = 1;
  p.textons = true;
  const Classifier clf(train_forest(s.data, p));
  std::vector<std::uint8_t> labels(72 * 52);
  FrameData bad = s.data.frames[0];
  bad.width = 71;
  EXPECT_THROW(clf.classify_frame(bad, labels), smseg::Error);
  bad = s.data.frames[0];
  bad.gray = nullptr;
  EXPECT_THROW(clf.classify_frame(bad, labels), smseg::Error);
  bad = s.data.frames[0];
  bad.sats.pop_back();
  EXPECT_THROW(clf.classify_frame(bad, labels), smseg::Error);
  std::vector<std::uint8_t> short_labels(10);
  EXPECT_THROW(clf.classify_frame(s.data.frames[0], short_labels), smseg::Error);
  std::vector<float> one(4);
  EXPECT_THROW(clf.posterior(s.data.frames[0], 72, 0, one.data()), smseg::Error);
  const std::vector<Pixel> outside{{-1, 3}};
  std::vector<std::uint8_t> l1(1);
  EXPECT_THROW(clf.classify_pixels(s.data.frames[0], outside, l1), smseg::Error);
}
