// The fast classifier against a plain per-pixel reference, and its API.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <span>
#include <string>

#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include "forest_simd.hpp"
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

void expect_frames_match_reference(const Classifier& clf, const Forest& f, const SyntheticData& s);
void expect_pixel_lists_match_frames(const Classifier& clf, const Forest& f, const SyntheticData& s);

// Whole frames under every SIMD target the processor runs (the scalar loops, and AVX2 and AVX-512 on an
// AVX-512 machine), each against the reference.
void expect_matches_reference(const Forest& f, const SyntheticData& s) {
  for (const std::string& target : Classifier::simd_targets()) {
    SCOPED_TRACE("SIMD target " + target);
    Classifier clf(f);
    clf.set_simd_target(target);
    expect_frames_match_reference(clf, f, s);
  }
}

void expect_frames_match_reference(const Classifier& clf, const Forest& f, const SyntheticData& s) {
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

// The SIMD splits compare double sums with float_bound(t) instead of rounding them to float: the same
// outcome for every value, at the float boundaries above all.
TEST(Classifier, FloatBoundDecidesAsRoundingToFloat) {
  using smseg::forest::detail::float_bound;
  constexpr float finf = std::numeric_limits<float>::infinity(), fmax = std::numeric_limits<float>::max();
  std::vector<float> thresholds{0.0f, -0.0f, 1.0f, -1.0f, 0.1f, -fmax, fmax, finf, std::numeric_limits<float>::denorm_min(),
                                -std::numeric_limits<float>::denorm_min(), std::numeric_limits<float>::min(), 3.0f, 16777216.0f};
  Rng rng(3);
  while (thresholds.size() < 20000) {
    const auto bits = static_cast<std::uint32_t>(rng.below(std::uint64_t(1) << 32));
    float t;
    std::memcpy(&t, &bits, sizeof t);
    if (!std::isnan(t) && t != -finf && std::fabs(t) <= fmax) thresholds.push_back(t);
  }
  constexpr double dinf = std::numeric_limits<double>::infinity();
  const double limit = std::ldexp(1.0, 128) - std::ldexp(1.0, 103);  // still rounds to FLT_MAX below it
  for (const float t : thresholds) {
    const double d = float_bound(t);
    const float below = std::nextafter(t, -finf);
    std::vector<double> values{d, std::nextafter(d, dinf), std::nextafter(d, -dinf), static_cast<double>(t),
                               static_cast<double>(below), std::nan("")};
    for (int k = 0; k < 4; ++k) values.push_back(below + (static_cast<double>(t) - below) * rng.uniform());
    for (const double v : values) {
      if (std::fabs(v) >= limit || std::isinf(v)) continue;  // out of float's range: no defined rounding to compare with
      ASSERT_EQ(static_cast<float>(v) < t, v < d) << "t " << t << " v " << v << " bound " << d;
    }
  }
}

TEST(Classifier, SimdTargetsAreTheProcessorsAndSmsegSimdForcesOne) {
  const SyntheticData s = frames(1, 3, false);
  const Forest f = random_forest(s, 1, false);
  const std::vector<std::string> targets = Classifier::simd_targets();
  ASSERT_FALSE(targets.empty());
  EXPECT_EQ(targets.front(), "scalar");
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  const bool avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
                      __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw");
  EXPECT_EQ(std::count(targets.begin(), targets.end(), "avx512"), avx512 ? 1 : 0);
  if (avx512) {
    EXPECT_EQ(targets, (std::vector<std::string>{"scalar", "avx2", "avx512"}));
  }
#endif
  {
    const RestoreEnv restore("SMSEG_SIMD");
    ::unsetenv("SMSEG_SIMD");
    EXPECT_EQ(Classifier(f).simd_target(), targets.back());  // the widest by default
    for (const std::string& t : targets) {
      ::setenv("SMSEG_SIMD", t.c_str(), 1);
      EXPECT_EQ(Classifier(f).simd_target(), t);
    }
    // An unknown name: one line naming the variable and the names it takes.
    ::setenv("SMSEG_SIMD", "avx9", 1);
    try {
      Classifier clf(f);
      ADD_FAILURE() << "SMSEG_SIMD=avx9 was taken";
    } catch (const smseg::Error& e) {
      EXPECT_NE(std::string(e.what()).find("SMSEG_SIMD"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("expected scalar|"), std::string::npos) << e.what();
    }
  }
  Classifier clf(f);
  EXPECT_THROW(clf.set_simd_target("sse2"), smseg::Error);
  clf.set_simd_target("scalar");
  EXPECT_EQ(clf.simd_target(), "scalar");
}

class PixelLists : public ::testing::TestWithParam<bool> {};  // with texton tests, or windows only

TEST_P(PixelLists, AndSinglePixelsAgreeWithWholeFrames) {
  const SyntheticData s = frames(2, 4, false);
  TrainParams p;
  p.K = 100;
  p.textons = GetParam();
  const Forest f = train_forest(s.data, p);
  for (const std::string& target : Classifier::simd_targets()) {
    SCOPED_TRACE("SIMD target " + target);
    Classifier clf(f);
    clf.set_simd_target(target);
    expect_pixel_lists_match_frames(clf, f, s);
  }
}
INSTANTIATE_TEST_SUITE_P(Classifier, PixelLists, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& i) { return i.param ? "textons" : "windows"; });

namespace {

// Pixel lists (the walks of scattered pixels) against whole frames and single pixels.
void expect_pixel_lists_match_frames(const Classifier& clf, const Forest& f, const SyntheticData& s) {
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

}  // namespace

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

// classify_pixels cuts a list into sets by the arena's thread count and the list's length: the labels
// and distributions must not depend on either (one thread or eight, the whole list or its halves), on
// every SIMD target.
TEST(Classifier, SamePixelListLabelsWhateverTheThreadCountAndTheSets) {
  const SyntheticData s = frames(2, 5, false);
  TrainParams p;
  p.K = 100;
  const Forest f = train_forest(s.data, p);
  const std::size_t C = f.classes.size();
  std::vector<Pixel> pixels;
  Rng rng(11);
  for (int i = 0; i < 1000; ++i) pixels.push_back({rng.uniform_int(0, 71), rng.uniform_int(0, 51)});
  const std::size_t n = pixels.size(), half = 389;  // sets of 250 with one thread, of 67 with eight
  for (const std::string& target : Classifier::simd_targets()) {
    SCOPED_TRACE("SIMD target " + target);
    Classifier clf(f);
    clf.set_simd_target(target);
    auto label = [&](int threads, bool halves, std::vector<std::uint8_t>& labels, std::vector<float>& dists) {
      labels.assign(n, 0);
      dists.assign(n * C, 0.0f);
      tbb::task_arena arena(threads);
      arena.execute([&] {
        if (!halves) return clf.classify_pixels(s.data.frames[1], pixels, labels, dists);
        const std::span<const Pixel> all(pixels);
        clf.classify_pixels(s.data.frames[1], all.first(half), std::span(labels).first(half), std::span(dists).first(half * C));
        clf.classify_pixels(s.data.frames[1], all.subspan(half), std::span(labels).subspan(half), std::span(dists).subspan(half * C));
      });
    };
    std::vector<std::uint8_t> one, eight, split;
    std::vector<float> d_one, d_eight, d_split;
    label(1, false, one, d_one);
    label(8, false, eight, d_eight);
    label(2, true, split, d_split);
    EXPECT_EQ(one, eight);
    EXPECT_EQ(one, split);
    EXPECT_EQ(0, std::memcmp(d_one.data(), d_eight.data(), d_one.size() * sizeof(float)));
    EXPECT_EQ(0, std::memcmp(d_one.data(), d_split.data(), d_one.size() * sizeof(float)));
  }
}

// Short lists, around a vector's lanes (the vector walk takes sets of at least one vector of pixels and
// walks the trees' (pixel, tree) items one after the other, wrapping from one tree into the next within
// a vector), for forests of one and of three trees: each pixel as posterior() gives it, on every target.
TEST(Classifier, ShortPixelListsAgreeWithSinglePixels) {
  const SyntheticData s = frames(2, 7, false);
  for (const int trees : {1, 3}) {
    TrainParams p;
    p.K = 60;
    p.M = trees;
    const Forest f = train_forest(s.data, p);
    const std::size_t C = f.classes.size();
    Classifier clf(f);
    for (const std::string& target : Classifier::simd_targets()) {
      clf.set_simd_target(target);
      for (const std::size_t n : {1, 7, 8, 15, 16, 17, 31, 33, 65, 100}) {
        SCOPED_TRACE("SIMD target " + target + ", " + std::to_string(trees) + " trees, " + std::to_string(n) + " pixels");
        Rng rng(n);
        std::vector<Pixel> pixels;
        for (std::size_t i = 0; i < n; ++i) pixels.push_back({rng.uniform_int(0, 71), rng.uniform_int(0, 51)});
        std::vector<std::uint8_t> labels(n);
        std::vector<float> dists(n * C), one(C);
        clf.classify_pixels(s.data.frames[0], pixels, labels, dists);
        for (std::size_t i = 0; i < n; ++i) {
          ASSERT_EQ(clf.posterior(s.data.frames[0], pixels[i].x, pixels[i].y, one.data()), labels[i]);
          ASSERT_EQ(0, std::memcmp(one.data(), &dists[i * C], C * sizeof(float)));
        }
      }
    }
  }
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

TEST(Classifier, ClassPriorIsTheLeavesShareOfTrainingTests) {
  Forest f;
  f.width = f.height = 4;
  f.classes = {"a", "b", "c"};
  Tree t;
  t.nodes.resize(3);
  t.nodes[0].feature = 0;
  t.nodes[0].left = 1;
  t.nodes[0].right = 2;
  t.nodes[1].counts = {6, 2, 0};
  t.nodes[2].counts = {0, 2, 0};
  f.trees = {t};
  const std::vector<double> prior = class_prior(f);
  EXPECT_EQ(prior, (std::vector<double>{0.6, 0.4, 0.0}));
  EXPECT_EQ(prior_correction(f, 0.0), (std::vector<double>{1.0, 1.0, 1.0}));
  // Power 1: posterior / prior, scaled so that the largest weight is 1; a class never seen keeps 1.
  const std::vector<double> w = prior_correction(f, 1.0);
  EXPECT_DOUBLE_EQ(w[0], 0.4 / 0.6);
  EXPECT_DOUBLE_EQ(w[1], 1.0);
  EXPECT_DOUBLE_EQ(w[2], 1.0);
  EXPECT_THROW(prior_correction(f, -1.0), smseg::Error);
  EXPECT_THROW(prior_correction(f, std::nan("")), smseg::Error);
}

TEST(Classifier, WeightedClassesGiveTheWeightedPosteriorOnEveryPath) {
  const SyntheticData s = frames(2, 5, false);
  const Forest f = random_forest(s, 7, false);
  const std::size_t C = f.classes.size();
  std::vector<double> w(C, 1.0);
  w[0] = 0.25;  // the first class four times less likely: it must lose pixels, and only it
  const Classifier plain(f);
  const std::size_t W = static_cast<std::size_t>(s.data.width), H = static_cast<std::size_t>(s.data.height);
  std::vector<std::uint8_t> plain_labels(W * H);
  std::vector<float> plain_dists(W * H * C);
  plain.classify_frame(s.data.frames[0], plain_labels, plain_dists);
  for (const std::string& target : Classifier::simd_targets()) {
    SCOPED_TRACE("SIMD target " + target);
    Classifier weighted(f, w);
    weighted.set_simd_target(target);
    std::vector<std::uint8_t> labels(W * H);
    std::vector<float> dists(W * H * C);
    weighted.classify_frame(s.data.frames[0], labels, dists);
    std::size_t mismatches = 0, lost = 0, gained = 0;
    std::vector<float> ref(C);
    for (std::size_t y = 0; y < H; ++y)
      for (std::size_t x = 0; x < W; ++x) {
        const std::size_t i = y * W + x;
        mismatches += labels[i] != weighted.posterior(s.data.frames[0], static_cast<int>(x), static_cast<int>(y), ref.data());
        for (std::size_t c = 0; c < C; ++c) {
          mismatches += dists[i * C + c] != ref[c];
          // Class 0's sums are a quarter of the unweighted ones (to float rounding); the others unchanged.
          const float expected = c == 0 ? plain_dists[i * C] * 0.25f : plain_dists[i * C + c];
          mismatches += std::abs(dists[i * C + c] - expected) > 1e-5f * (1 + expected);
        }
        lost += plain_labels[i] == 0 && labels[i] != 0;
        gained += plain_labels[i] != 0 && labels[i] == 0;
      }
    EXPECT_EQ(mismatches, 0u);
    EXPECT_GT(lost, 0u);
    EXPECT_EQ(gained, 0u);
  }
  EXPECT_THROW(Classifier(f, std::vector<double>(C + 1, 1.0)), smseg::Error);
  EXPECT_THROW(Classifier(f, std::vector<double>(C, -1.0)), smseg::Error);
}
