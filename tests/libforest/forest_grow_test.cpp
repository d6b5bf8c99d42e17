// The split score, the stopping rules, and tree growth against a plain reference grower.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <numeric>
#include <string>

#include "forest_test_util.hpp"
#include "smseg/common/error.hpp"
#include "smseg/forest/rng.hpp"
#include "smseg/forest/tabular.hpp"

using namespace forest_test;

namespace {

// Wehenkel-Pavella from joint probabilities, I(C;S) = sum p(c,s) log(p(c,s) / (p(c) p(s))).
double wp_by_definition(const std::vector<double>& left, const std::vector<double>& right) {
  double n = 0;
  for (double v : left) n += v;
  for (double v : right) n += v;
  const double ps[2] = {std::accumulate(left.begin(), left.end(), 0.0) / n,
                        std::accumulate(right.begin(), right.end(), 0.0) / n};
  double I = 0, HC = 0, HS = 0;
  for (std::size_t c = 0; c < left.size(); ++c) {
    const double pc = (left[c] + right[c]) / n;
    if (pc > 0) HC -= pc * std::log2(pc);
    for (int s = 0; s < 2; ++s) {
      const double pcs = (s == 0 ? left[c] : right[c]) / n;
      if (pcs > 0) I += pcs * std::log2(pcs / (pc * ps[s]));
    }
  }
  for (double p : ps)
    if (p > 0) HS -= p * std::log2(p);
  return 2 * I / (HC + HS);
}

Corpus make_corpus(int num_classes, const std::vector<int>& labels, const std::vector<std::vector<float>>& columns) {
  Corpus c;
  c.num_classes = num_classes;
  for (int l : labels) c.tests.push_back({0, 0, 0, static_cast<std::uint8_t>(l)});
  for (std::size_t k = 0; k < columns.size(); ++k) {
    c.candidates.push_back({Window{static_cast<int>(k), 0, 1, 1}, 0});
    c.values.insert(c.values.end(), columns[k].begin(), columns[k].end());
  }
  return c;
}

// ---- A reference grower written straight from the specification (slow, obvious). ----
struct RefGrower {
  const Corpus& c;
  int n_min;
  std::uint64_t seed;
  Score kind;
  std::vector<double> xlogx;

  RefGrower(const Corpus& corpus, int nmin, std::uint64_t s, Score k = Score::WehenkelPavella)
      : c(corpus), n_min(nmin), seed(s), kind(k) {
    xlogx.resize(c.tests.size() + 1);
    for (std::size_t i = 1; i < xlogx.size(); ++i) xlogx[i] = static_cast<double>(i) * std::log(static_cast<double>(i));
  }
  // The normalised gain in the trainer's n log n form (so that scores agree to the last bit).
  double score(const std::vector<std::uint32_t>& l, const std::vector<std::uint32_t>& tot, std::size_t n) const {
    std::size_t nl = 0;
    double sl = 0, sr = 0, sc = 0;
    for (std::size_t k = 0; k < l.size(); ++k) {
      nl += l[k];
      sl += xlogx[l[k]];
      sr += xlogx[tot[k] - l[k]];
      sc += xlogx[tot[k]];
    }
    const std::size_t nr = n - nl;
    if (nl == 0 || nr == 0) return 0.0;
    const double hc = xlogx[n] - sc, hs = xlogx[n] - xlogx[nl] - xlogx[nr];
    const double hcs = (xlogx[nl] - sl) + (xlogx[nr] - sr);
    if (kind == Score::InformationGain) return (hc - hcs) / static_cast<double>(n);  // I(C;S) in nats
    return hc + hs > 0 ? 2.0 * (hc - hcs) / (hc + hs) : 0.0;
  }
  Tree grow() {
    Tree tree;
    tree.nodes.emplace_back();
    std::vector<std::uint32_t> all(c.tests.size());
    std::iota(all.begin(), all.end(), 0u);
    struct Item {
      int node;
      std::vector<std::uint32_t> tests;
    };
    std::vector<Item> stack{{0, all}};
    const std::size_t n = c.tests.size(), C = static_cast<std::size_t>(c.num_classes);
    while (!stack.empty()) {
      Item it = stack.back();
      stack.pop_back();
      std::vector<std::uint32_t> counts(C, 0);
      for (auto t : it.tests) ++counts[c.tests[t].label];
      const int present = static_cast<int>(std::count_if(counts.begin(), counts.end(), [](auto v) { return v > 0; }));
      double best = -1;
      std::size_t best_c = 0;
      double best_t = 0;
      if (present > 1 && it.tests.size() >= static_cast<std::size_t>(n_min) && it.tests.size() >= 2) {
        for (std::size_t k = 0; k < c.candidates.size(); ++k) {
          float lo = c.values[k * n + it.tests[0]], hi = lo;
          for (auto t : it.tests) {
            lo = std::min(lo, c.values[k * n + t]);
            hi = std::max(hi, c.values[k * n + t]);
          }
          if (lo == hi) continue;
          double thr = static_cast<double>(hi) - hash_uniform(seed, static_cast<std::uint64_t>(it.node), k) * (static_cast<double>(hi) - lo);
          if (!(thr > lo)) thr = hi;
          std::vector<std::uint32_t> l(C, 0);
          for (auto t : it.tests)
            if (static_cast<double>(c.values[k * n + t]) < thr) ++l[c.tests[t].label];
          const double s = score(l, counts, it.tests.size());
          if (s > best) {
            best = s;
            best_c = k;
            best_t = thr;
          }
        }
      }
      if (best < 0) {
        tree.nodes[static_cast<std::size_t>(it.node)].counts = counts;
        continue;
      }
      std::vector<std::uint32_t> L, R;
      for (auto t : it.tests) (static_cast<double>(c.values[best_c * n + t]) < best_t ? L : R).push_back(t);
      Node& nd = tree.nodes[static_cast<std::size_t>(it.node)];
      nd.feature = c.candidates[best_c].feature;
      nd.win = c.candidates[best_c].win;
      nd.threshold = best_t;
      const int left = static_cast<int>(tree.nodes.size());
      nd.left = left;
      nd.right = left + 1;
      tree.nodes.emplace_back();
      tree.nodes.emplace_back();
      stack.push_back({left + 1, R});
      stack.push_back({left, L});
    }
    return tree;
  }
};

void expect_same_tree(const Tree& a, const Tree& b) {
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  for (std::size_t i = 0; i < a.nodes.size(); ++i) {
    SCOPED_TRACE("node " + std::to_string(i));
    EXPECT_EQ(a.nodes[i].feature, b.nodes[i].feature);
    EXPECT_EQ(a.nodes[i].win, b.nodes[i].win);
    EXPECT_EQ(a.nodes[i].threshold, b.nodes[i].threshold);
    EXPECT_EQ(a.nodes[i].left, b.nodes[i].left);
    EXPECT_EQ(a.nodes[i].right, b.nodes[i].right);
    EXPECT_EQ(a.nodes[i].counts, b.nodes[i].counts);
  }
}

}  // namespace

TEST(WehenkelPavella, HandComputedValues) {
  using V = std::vector<std::uint32_t>;
  // A perfect split of two equal classes: I = H(C) = H(S) = 1 bit -> 1.
  EXPECT_NEAR(wehenkel_pavella(V{2, 0}, V{0, 2}), 1.0, 1e-12);
  // An uninformative split: I = 0.
  EXPECT_NEAR(wehenkel_pavella(V{1, 1}, V{1, 1}), 0.0, 1e-12);
  EXPECT_NEAR(wehenkel_pavella(V{3, 6}, V{1, 2}), 0.0, 1e-12);
  // Left {3,1}, right {0,4}: H(C) = H(3/8) = 0.954434 bits, H(S) = 1, H(C|S) = 0.5 H(1/4) = 0.405639,
  // I = 0.548795, score = 2 I / (H(C) + H(S)) = 1.097590 / 1.954434 = 0.561590.
  EXPECT_NEAR(wehenkel_pavella(V{3, 1}, V{0, 4}), 0.5615896, 1e-6);
  EXPECT_NEAR(wehenkel_pavella(V{3, 1}, V{0, 4}), wp_by_definition({3, 1}, {0, 4}), 1e-12);
  // Three classes, uneven sides.
  EXPECT_NEAR(wehenkel_pavella(V{5, 2, 0}, V{1, 3, 7}), wp_by_definition({5, 2, 0}, {1, 3, 7}), 1e-12);
  // An empty side carries no information.
  EXPECT_EQ(wehenkel_pavella(V{3, 4}, V{0, 0}), 0.0);
  EXPECT_THROW(wehenkel_pavella(V{1, 2}, V{1}), smseg::Error);
}

TEST(GrowTree, PureNodeIsALeaf) {
  const Corpus c = make_corpus(2, {1, 1, 1, 1, 1, 1, 1, 1}, {{0, 1, 2, 3, 4, 5, 6, 7}});
  const Tree t = grow_tree(c, 1, 42);
  ASSERT_EQ(t.nodes.size(), 1u);
  EXPECT_TRUE(t.nodes[0].is_leaf());
  EXPECT_EQ(t.nodes[0].counts, (std::vector<std::uint32_t>{0, 8}));
}

TEST(GrowTree, ConstantCandidatesGiveALeaf) {
  const Corpus c = make_corpus(2, {0, 1, 0, 1, 0, 1}, {{3, 3, 3, 3, 3, 3}, {-1, -1, -1, -1, -1, -1}});
  const Tree t = grow_tree(c, 1, 42);
  ASSERT_EQ(t.nodes.size(), 1u);
  EXPECT_EQ(t.nodes[0].counts, (std::vector<std::uint32_t>{3, 3}));
}

TEST(GrowTree, FewerThanNMinTestsGiveALeaf) {
  const Corpus c = make_corpus(2, {0, 0, 1, 1}, {{0, 0, 1, 1}});
  const Tree leaf = grow_tree(c, 5, 42);  // 4 < n_min = 5
  ASSERT_EQ(leaf.nodes.size(), 1u);
  EXPECT_EQ(leaf.nodes[0].counts, (std::vector<std::uint32_t>{2, 2}));
  const Tree split = grow_tree(c, 4, 42);  // 4 >= n_min = 4: splits, threshold in (0, 1]
  ASSERT_EQ(split.nodes.size(), 3u);
  EXPECT_GT(split.nodes[0].threshold, 0.0);
  EXPECT_LE(split.nodes[0].threshold, 1.0);
  EXPECT_EQ(split.nodes[1].counts, (std::vector<std::uint32_t>{2, 0}));
  EXPECT_EQ(split.nodes[2].counts, (std::vector<std::uint32_t>{0, 2}));
}

TEST(GrowTree, PicksTheMostInformativeCandidate) {
  // Candidate 1 separates the classes whatever its threshold; candidate 0 is noise.
  const Corpus c = make_corpus(2, {0, 0, 0, 1, 1, 1}, {{5, 1, 4, 2, 6, 3}, {0, 0, 0, 10, 10, 10}});
  const Tree t = grow_tree(c, 1, 7);
  ASSERT_EQ(t.nodes.size(), 3u);
  EXPECT_EQ(t.nodes[0].win.dx, 1);  // candidate index 1 (make_corpus stores it in dx)
}

TEST(GrowTree, EqualsTheReferenceGrowerOnRandomCorpora) {
  for (int trial = 0; trial < 12; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    Rng rng(1000 + static_cast<std::uint64_t>(trial));
    const int C = 2 + trial % 4, n = 50 + 40 * trial, K = 5 + 3 * trial;
    std::vector<int> labels(static_cast<std::size_t>(n));
    for (auto& l : labels) l = static_cast<int>(rng.below(static_cast<std::uint64_t>(C)));
    std::vector<std::vector<float>> cols(static_cast<std::size_t>(K));
    for (int k = 0; k < K; ++k)
      for (int i = 0; i < n; ++i) {
        // Some columns are coarse (many ties), some constant, some weakly informative.
        float v = static_cast<float>(rng.uniform());
        if (k % 3 == 1) v = static_cast<float>(rng.below(4));
        if (k % 7 == 6) v = 2.5f;
        if (k % 5 == 0) v += 0.3f * static_cast<float>(labels[static_cast<std::size_t>(i)]);
        cols[static_cast<std::size_t>(k)].push_back(v);
      }
    const Corpus c = make_corpus(C, labels, cols);
    for (int n_min : {1, 5}) {
      const Tree fast = grow_tree(c, n_min, 99 + static_cast<std::uint64_t>(trial));
      const Tree ref = RefGrower(c, n_min, 99 + static_cast<std::uint64_t>(trial)).grow();
      expect_same_tree(fast, ref);
      // Every leaf's counts add up to the tests.
      std::uint64_t total = 0;
      for (const auto& nd : fast.nodes)
        for (auto v : nd.counts) total += v;
      EXPECT_EQ(total, static_cast<std::uint64_t>(n));
    }
  }
}

// The node scan's vector kernels (forest_simd.hpp) against the grower's own loops (SMSEG_SIMD=scalar):
// the same trees on every target the processor runs. Corpora wide enough for several candidate blocks
// and vector tails (up to 700 candidates, blocks of 256), large enough for the parallel scan of a
// node (tests x candidates >= 2^19), with ties, constants, NaN and infinities, whose folding order a
// Min or Max instruction would change.
TEST(GrowTree, EverySimdTargetGrowsTheScalarLoopsTree) {
  const std::vector<std::string> targets = Classifier::simd_targets();
  const RestoreEnv restore("SMSEG_SIMD");
  for (int trial = 0; trial < 4; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    Rng rng(77 + static_cast<std::uint64_t>(trial));
    const int C = 3 + trial, n = trial == 3 ? 1100 : 300 + 150 * trial, K = trial == 3 ? 500 : 37 + 221 * trial;
    std::vector<int> labels(static_cast<std::size_t>(n));
    for (auto& l : labels) l = static_cast<int>(rng.below(static_cast<std::uint64_t>(C)));
    std::vector<std::vector<float>> cols(static_cast<std::size_t>(K));
    for (int k = 0; k < K; ++k)
      for (int i = 0; i < n; ++i) {
        float v = static_cast<float>(rng.uniform()) + 0.4f * static_cast<float>(labels[static_cast<std::size_t>(i)] % 2);
        if (k % 3 == 1) v = static_cast<float>(rng.below(4));
        if (k % 11 == 6) v = 2.5f;
        if (k % 5 == 2 && rng.below(9) == 0) v = std::numeric_limits<float>::quiet_NaN();
        if (k % 7 == 3 && rng.below(13) == 0) v = rng.below(2) ? std::numeric_limits<float>::infinity()
                                                                : -std::numeric_limits<float>::infinity();
        cols[static_cast<std::size_t>(k)].push_back(v);
      }
    const Corpus c = make_corpus(C, labels, cols);
    ASSERT_EQ(::setenv("SMSEG_SIMD", "scalar", 1), 0);
    const Tree scalar = grow_tree(c, 1, 5 + static_cast<std::uint64_t>(trial));
    EXPECT_GT(scalar.nodes.size(), 9u);
    for (const std::string& t : targets) {
      SCOPED_TRACE("SMSEG_SIMD=" + t);
      ASSERT_EQ(::setenv("SMSEG_SIMD", t.c_str(), 1), 0);
      expect_same_tree(grow_tree(c, 1, 5 + static_cast<std::uint64_t>(trial)), scalar);
    }
  }
}

TEST(GrowTree, EqualsTheReferenceOnARealCorpusWithTextons) {
  SyntheticOptions o;
  o.width = 64;
  o.height = 48;
  o.frames = 3;
  o.features = 3;
  o.signal = 0.3;
  const SyntheticData s = make_synthetic(o);
  TrainParams p;
  p.K = 120;
  p.M = 2;
  p.textons = true;
  const Corpus c = build_corpus(s.data, p, 1);
  const Tree fast = grow_tree(c, p.n_min, tree_seed(p.seed, 1));
  expect_same_tree(fast, RefGrower(c, p.n_min, tree_seed(p.seed, 1)).grow());
  // And the forest's tree 1 is this tree.
  const Forest f = train_forest(s.data, p);
  expect_same_tree(f.trees[1], fast);
}

TEST(GrowTree, RejectsMalformedCorpora) {
  Corpus c = make_corpus(2, {0, 1}, {{0, 1}});
  c.values.pop_back();
  EXPECT_THROW(grow_tree(c, 1, 1), smseg::Error);
  Corpus d = make_corpus(2, {0, 3}, {{0, 1}});
  EXPECT_THROW(grow_tree(d, 1, 1), smseg::Error);
}

TEST(InformationGain, HandComputedValues) {
  using V = std::vector<std::uint32_t>;
  // A perfect split of two equal classes: I = H(C) = 1 bit.
  EXPECT_NEAR(information_gain(V{2, 0}, V{0, 2}), 1.0, 1e-12);
  // Uninformative splits: I = 0.
  EXPECT_NEAR(information_gain(V{1, 1}, V{1, 1}), 0.0, 1e-12);
  EXPECT_NEAR(information_gain(V{3, 6}, V{1, 2}), 0.0, 1e-12);
  // Left {3,1}, right {0,4}: H(C) = H(3/8) = 0.954434 bits, H(C|S) = 0.5 H(1/4) = 0.405639 bits,
  // I = 0.548795 bits (Wehenkel-Pavella divides 2 I by H(C) + H(S) = 1.954434: 0.561590).
  EXPECT_NEAR(information_gain(V{3, 1}, V{0, 4}), 0.5487949, 1e-6);
  // Three classes {4,4,8} split {4,0,0} / {0,4,8}: H(C) = 1.5 bits, H(C|S) = 0.75 H(1/3) = 0.688722,
  // I = 0.811278 bits.
  EXPECT_NEAR(information_gain(V{4, 0, 0}, V{0, 4, 8}), 0.8112781, 1e-6);
  // Same node, a lopsided and a balanced split: Wehenkel-Pavella divides the balanced split's gain
  // by the larger H(C) + H(S) (H(S) = 1 bit against 0.47), so relative to the balanced split it rates
  // the lopsided one higher than information gain does.
  const double ig_small = information_gain(V{10, 0}, V{10, 80}), ig_half = information_gain(V{18, 32}, V{2, 48});
  const double wp_small = wehenkel_pavella(V{10, 0}, V{10, 80}), wp_half = wehenkel_pavella(V{18, 32}, V{2, 48});
  EXPECT_LT(ig_small / ig_half, wp_small / wp_half);
  EXPECT_EQ(information_gain(V{3, 4}, V{0, 0}), 0.0);
  EXPECT_THROW(information_gain(V{1, 2}, V{1}), smseg::Error);
}

TEST(GrowTree, InformationGainEqualsTheReferenceAndIsDeterministic) {
  int differ = 0;
  for (int trial = 0; trial < 8; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    Rng rng(2000 + static_cast<std::uint64_t>(trial));
    const int C = 2 + trial % 4, n = 60 + 50 * trial, K = 6 + 3 * trial;
    std::vector<int> labels(static_cast<std::size_t>(n));
    for (auto& l : labels) l = static_cast<int>(rng.below(static_cast<std::uint64_t>(C)));
    std::vector<std::vector<float>> cols(static_cast<std::size_t>(K));
    for (int k = 0; k < K; ++k)
      for (int i = 0; i < n; ++i) {
        float v = static_cast<float>(rng.uniform());
        if (k % 3 == 1) v = static_cast<float>(rng.below(4));
        if (k % 4 == 0) v += 0.3f * static_cast<float>(labels[static_cast<std::size_t>(i)]);
        cols[static_cast<std::size_t>(k)].push_back(v);
      }
    const Corpus c = make_corpus(C, labels, cols);
    const std::uint64_t seed = 7 + static_cast<std::uint64_t>(trial);
    const Tree ig = grow_tree(c, 5, seed, Score::InformationGain);
    expect_same_tree(ig, RefGrower(c, 5, seed, Score::InformationGain).grow());
    expect_same_tree(ig, grow_tree(c, 5, seed, Score::InformationGain));  // same seed, same tree
    const Tree wp = grow_tree(c, 5, seed);
    differ += wp.nodes.size() != ig.nodes.size() || wp.nodes[0].win != ig.nodes[0].win ||
              wp.nodes[0].threshold != ig.nodes[0].threshold;
    // grow_trees (one shared layout) grows the same trees as grow_tree.
    const std::vector<std::uint64_t> seeds{seed, seed + 1, seed + 2};
    const std::vector<Tree> many = grow_trees(c, 5, seeds, Score::InformationGain);
    ASSERT_EQ(many.size(), 3u);
    for (std::size_t i = 0; i < seeds.size(); ++i) expect_same_tree(many[i], grow_tree(c, 5, seeds[i], Score::InformationGain));
  }
  EXPECT_GT(differ, 0);  // the option does change trees
}

// A table's rows grown in place (forest-peers, the Python ExtraTreesClassifier) give the trees of its
// corpus copy.
TEST(GrowTree, TabularRowsInPlaceGrowTheCorpusTrees) {
  Rng rng(77);
  const std::size_t rows = 300, columns = 17;
  const int classes = 4;
  std::vector<float> values(rows * columns);
  std::vector<std::uint8_t> labels(rows);
  for (std::size_t r = 0; r < rows; ++r) {
    labels[r] = static_cast<std::uint8_t>(rng.below(classes));
    for (std::size_t c = 0; c < columns; ++c)
      values[r * columns + c] = static_cast<float>(rng.uniform()) + (c % 3 == 0 ? 0.4f * labels[r] : 0.0f);
  }
  for (const Score score : {Score::WehenkelPavella, Score::InformationGain}) {
    const std::vector<Tree> copied = grow_tabular_forest(tabular_corpus(values, columns, labels, classes), 3, 5, 9, score);
    const std::vector<Tree> in_place = grow_tabular_forest(values, columns, labels, classes, 3, 5, 9, score);
    ASSERT_EQ(copied.size(), in_place.size());
    for (std::size_t t = 0; t < copied.size(); ++t) expect_same_tree(in_place[t], copied[t]);
  }
  labels[5] = classes;  // a label outside the classes is refused the same way
  EXPECT_THROW(grow_tabular_forest(values, columns, labels, classes, 3, 5, 9, Score::WehenkelPavella), smseg::Error);
}

// scikit-learn's mean decrease in impurity, worked by hand on two small trees: tree A splits the root
// (counts 4/5) on attribute 1 into a leaf 3/0 and a node 1/5, which attribute 0 splits into 1/0 and
// 0/5; tree B is one leaf and adds nothing.
TEST(TabularForest, ImportancesAreTheMeanDecreaseInImpurity) {
  auto leaf = [](std::uint32_t a, std::uint32_t b) {
    Node n;
    n.counts = {a, b};
    return n;
  };
  auto split = [](int feature, int left, int right) {
    Node n;
    n.feature = feature;
    n.left = left;
    n.right = right;
    return n;
  };
  Tree a;
  a.nodes = {split(1, 1, 2), leaf(3, 0), split(0, 3, 4), leaf(1, 0), leaf(0, 5)};
  Tree b;
  b.nodes = {leaf(2, 2)};
  auto nH = [](double x, double y) {  // n H for counts x, y
    double h = 0;
    for (double c : {x, y})
      if (c > 0) h -= c * std::log(c / (x + y));
    return h;
  };
  const double root = nH(4, 5) - nH(3, 0) - nH(1, 5), lower = nH(1, 5) - nH(1, 0) - nH(0, 5);
  const std::vector<double> imp = impurity_importances({a, b}, 3);
  ASSERT_EQ(imp.size(), 3u);
  EXPECT_NEAR(imp[0], lower / (root + lower), 1e-12);
  EXPECT_NEAR(imp[1], root / (root + lower), 1e-12);
  EXPECT_EQ(imp[2], 0.0);
  EXPECT_EQ(impurity_importances({b}, 3), std::vector<double>(3, 0.0));  // no split anywhere
}

// A table's trees are a forest file like any other: saved and read back, they classify every row alike.
TEST(TabularForest, RoundTripsThroughTheForestFormat) {
  Rng rng(5);
  const std::size_t rows = 200, columns = 3;
  std::vector<float> values(rows * columns);
  std::vector<std::uint8_t> labels(rows);
  for (std::size_t r = 0; r < rows; ++r) {
    labels[r] = static_cast<std::uint8_t>(rng.below(3));
    for (std::size_t c = 0; c < columns; ++c) values[r * columns + c] = static_cast<float>(rng.uniform()) + labels[r];
  }
  const Forest f = tabular_forest(grow_tabular_forest(values, columns, labels, 3, 4, 2, 8, Score::InformationGain),
                                  columns, 3, 2, 8, Score::InformationGain);
  EXPECT_EQ(f.features, (std::vector<std::string>{"x0", "x1", "x2"}));
  EXPECT_EQ(f.classes, (std::vector<std::string>{"0", "1", "2"}));
  const Forest back = forest_from_json(nlohmann::json::parse(forest_to_json(f).dump()), "mem");
  EXPECT_EQ(back.params.M, 4);
  EXPECT_EQ(back.params.n_min, 2);
  EXPECT_EQ(back.params.score, Score::InformationGain);
  std::vector<double> acc, acc_back;
  for (std::size_t r = 0; r < rows; ++r) {
    tabular_posterior(f.trees, &values[r * columns], 3, acc);
    tabular_posterior(back.trees, &values[r * columns], 3, acc_back);
    ASSERT_EQ(acc, acc_back) << "row " << r;
  }
}

TEST(GrowTree, TrainForestUsesTheScoreOption) {
  SyntheticOptions o;
  o.width = 64;
  o.height = 48;
  o.frames = 3;
  o.features = 3;
  o.signal = 0.3;
  const SyntheticData s = make_synthetic(o);
  TrainParams p;
  p.K = 120;
  p.M = 2;
  p.score = Score::InformationGain;
  const Corpus c = build_corpus(s.data, p, 1);
  const Tree t = grow_tree(c, p.n_min, tree_seed(p.seed, 1), Score::InformationGain);
  expect_same_tree(t, RefGrower(c, p.n_min, tree_seed(p.seed, 1), Score::InformationGain).grow());
  const Forest f = train_forest(s.data, p);
  expect_same_tree(f.trees[1], t);
  EXPECT_EQ(f.params.score, Score::InformationGain);
}
