// Training tests are drawn as the thesis-style sampler always drew them: from per-frame pixel lists
// grouped by class (each class in raster order). The trainer keeps only per-row class counts; this
// holds its draws to a reference built from such lists, with void pixels and an empty frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "forest_test_util.hpp"

using namespace forest_test;

namespace {

/// The tests of tree `tree` drawn from explicit pixel lists (the reference), sorted as corpora are.
std::vector<TestPoint> reference_tests(const Dataset& d, const TrainParams& p, int tree) {
  const std::size_t C = d.classes.size(), N = static_cast<std::size_t>(d.width) * d.height;
  std::vector<std::vector<std::vector<std::uint32_t>>> lists(d.frames.size(), std::vector<std::vector<std::uint32_t>>(C));
  for (std::size_t fi = 0; fi < d.frames.size(); ++fi)
    for (std::size_t i = 0; i < N; ++i)
      if (d.frames[fi].labels[i] != kVoidLabel) lists[fi][d.frames[fi].labels[i]].push_back(static_cast<std::uint32_t>(i));
  Rng rng(tree_seed(p.seed, tree));
  const WindowSampler windows(p.windows, WindowBounds::for_image(d.width, d.height));
  for (int k = 0; k < p.ks(); ++k) windows.draw(rng);  // the windows come first
  std::vector<int> nonempty, present;
  for (std::size_t fi = 0; fi < d.frames.size(); ++fi) {
    std::size_t n = 0;
    for (const auto& l : lists[fi]) n += l.size();
    if (n) nonempty.push_back(static_cast<int>(fi));
  }
  std::vector<std::vector<std::uint64_t>> cum(C, std::vector<std::uint64_t>(d.frames.size()));
  for (std::size_t c = 0; c < C; ++c) {
    for (std::size_t fi = 0; fi < d.frames.size(); ++fi) cum[c][fi] = (fi ? cum[c][fi - 1] : 0) + lists[fi][c].size();
    if (cum[c].back()) present.push_back(static_cast<int>(c));
  }
  std::vector<TestPoint> tests;
  for (int k = 0; k < p.kt(); ++k) {
    std::size_t fi = 0;
    std::uint32_t px = 0;
    if (p.balance != Balance::None) {
      std::size_t which = 0;
      if (p.balance == Balance::Classes) {
        which = rng.below(present.size());
      } else {  // Sqrt: a class in proportion to llround(1024 sqrt(its pixels))
        std::vector<std::uint64_t> weight_cum;
        for (const int c : present)
          weight_cum.push_back((weight_cum.empty() ? 0 : weight_cum.back()) +
                               static_cast<std::uint64_t>(std::llround(1024.0 * std::sqrt(double(cum[std::size_t(c)].back())))));
        const std::uint64_t w = rng.below(weight_cum.back());
        while (weight_cum[which] <= w) ++which;
      }
      const auto c = static_cast<std::size_t>(present[which]);
      const std::uint64_t r = rng.below(cum[c].back());
      fi = static_cast<std::size_t>(std::upper_bound(cum[c].begin(), cum[c].end(), r) - cum[c].begin());
      px = lists[fi][c][r - (fi ? cum[c][fi - 1] : 0)];
    } else {
      fi = static_cast<std::size_t>(nonempty[rng.below(nonempty.size())]);
      std::vector<std::uint32_t> grouped;
      for (const auto& l : lists[fi]) grouped.insert(grouped.end(), l.begin(), l.end());
      px = grouped[rng.below(grouped.size())];
    }
    tests.push_back({static_cast<int>(fi), static_cast<int>(px % d.width), static_cast<int>(px / d.width),
                     d.frames[fi].labels[px]});
  }
  std::sort(tests.begin(), tests.end(), [](const TestPoint& a, const TestPoint& b) {
    if (a.label != b.label) return a.label < b.label;
    return a.frame != b.frame ? a.frame < b.frame : a.y != b.y ? a.y < b.y : a.x < b.x;
  });
  return tests;
}

}  // namespace

TEST(Corpus, TestsAreDrawnAsFromPixelListsGroupedByClass) {
  SyntheticOptions o;
  o.width = 64;
  o.height = 48;
  o.frames = 5;
  o.features = 2;
  o.seed = 3;
  SyntheticData s = make_synthetic(o);
  // Void pixels: a band in every frame, and all of frame 2.
  for (std::size_t fi = 0; fi < s.labels.size(); ++fi)
    for (std::size_t i = 0; i < s.labels[fi].size(); ++i)
      if (fi == 2 || (i / 64) % 7 == 3 || i % 11 == 0) s.labels[fi][i] = kVoidLabel;
  for (const Balance balance : {Balance::None, Balance::Classes, Balance::Sqrt}) {
    TrainParams p;
    p.K = 50;
    p.Kt = 3000;
    p.M = 2;
    p.balance = balance;
    for (int tree = 0; tree < 2; ++tree) {
      const Corpus corpus = build_corpus(s.data, p, tree);
      const std::vector<TestPoint> ref = reference_tests(s.data, p, tree);
      ASSERT_EQ(corpus.tests.size(), ref.size());
      std::size_t differ = 0;
      for (std::size_t i = 0; i < ref.size(); ++i) {
        const TestPoint &a = corpus.tests[i], &b = ref[i];
        differ += a.frame != b.frame || a.x != b.x || a.y != b.y || a.label != b.label;
        EXPECT_NE(a.frame, 2);  // the all-void frame gives no test
      }
      EXPECT_EQ(differ, 0u) << "balance " << to_string(balance) << ", tree " << tree;
    }
  }
}
