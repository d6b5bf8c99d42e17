// Training: learning what can be learned, not learning noise, determinism, balance, parameters.
#include <gtest/gtest.h>

#include <cmath>

#include <oneapi/tbb/global_control.h>

#include "forest_test_util.hpp"
#include "smseg/common/error.hpp"

using namespace forest_test;

namespace {

// Frames each wholly of one class (0 or 1), labelled only where every window's centre is inside
// the image; feature 0 is 1 on class-1 frames, 0 on class-0 frames: class 1 gives every window a
// positive sum, class 0 zero, so the classes are separable by any window.
struct Separable {
  int W = 48, H = 32;
  std::vector<std::vector<double>> sats;
  std::vector<std::vector<std::uint8_t>> labels;
  Dataset data;
  explicit Separable(int frames) {
    const WindowBounds b = WindowBounds::for_image(W, H);
    data.width = W;
    data.height = H;
    data.features = {"f"};
    data.classes = {"zero", "one"};
    for (int f = 0; f < frames; ++f) {
      const std::uint8_t c = static_cast<std::uint8_t>(f % 2);
      std::vector<double> img(static_cast<std::size_t>(W) * H, c);
      std::vector<double> sat(static_cast<std::size_t>(W + 1) * (H + 1));
      summed_area_table(img.data(), W, H, sat.data());
      std::vector<std::uint8_t> lab(img.size(), kVoidLabel);
      for (int y = b.max_dy; y < H - b.max_dy; ++y)
        for (int x = b.max_dx; x < W - b.max_dx; ++x) lab[static_cast<std::size_t>(y) * W + x] = c;
      sats.push_back(std::move(sat));
      labels.push_back(std::move(lab));
    }
    for (int f = 0; f < frames; ++f) {
      FrameData fd;
      fd.width = W;
      fd.height = H;
      fd.sats = {sats[static_cast<std::size_t>(f)].data()};
      fd.labels = labels[static_cast<std::size_t>(f)].data();
      data.frames.push_back(fd);
    }
  }
};

double accuracy_on(const Classifier& clf, const Dataset& d, const std::vector<std::vector<std::uint8_t>>& labels) {
  std::size_t right = 0, n = 0;
  std::vector<std::uint8_t> out(static_cast<std::size_t>(d.width) * d.height);
  for (std::size_t f = 0; f < d.frames.size(); ++f) {
    clf.classify_frame(d.frames[f], out);
    for (std::size_t i = 0; i < out.size(); ++i)
      if (labels[f][i] != kVoidLabel) {
        ++n;
        right += out[i] == labels[f][i];
      }
  }
  return static_cast<double>(right) / static_cast<double>(n);
}

// A forest grown to pure leaves on the separable toy: one test per leaf is enough.
TrainParams pure_leaves(int trees) {
  TrainParams p;
  p.K = 150;
  p.M = trees;
  p.n_min = 1;
  return p;
}

SyntheticOptions small_room(std::uint64_t seed) {
  SyntheticOptions o;
  o.width = 80;
  o.height = 60;
  o.frames = 6;
  o.features = 4;
  o.seed = seed;
  return o;
}

}  // namespace

TEST(Train, SeparableToyIsLearnedPerfectly) {
  const Separable toy(6);
  TrainParams p = pure_leaves(1);
  const Forest f = train_forest(toy.data, p);
  const Classifier clf(f);
  // Every training test lands in a pure leaf of its own class...
  const Corpus c = build_corpus(toy.data, p, 0);
  for (const TestPoint& t : c.tests)
    ASSERT_EQ(clf.classify(toy.data.frames[static_cast<std::size_t>(t.frame)], t.x, t.y), t.label);
  // ...and every labelled pixel of unseen frames is classified right.
  p.M = 5;
  p.n_min = 5;
  const Classifier clf5(train_forest(toy.data, p));
  const Separable unseen(4);
  EXPECT_EQ(accuracy_on(clf5, unseen.data, unseen.labels), 1.0);
}

TEST(Train, LearnsTheSyntheticRoomOnHeldOutFrames) {
  const SyntheticData train = make_synthetic(small_room(1));
  const SyntheticData test = make_synthetic(small_room(2));
  TrainParams p;
  p.K = 200;
  const Forest f = train_forest(train.data, p);
  const double acc = accuracy_on(Classifier(f), test.data, test.labels);
  EXPECT_GT(acc, 0.9) << "held-out accuracy " << acc;
}

TEST(Train, RandomLabelsGiveChanceAccuracyOnHeldOutFrames) {
  SyntheticOptions o = small_room(3);
  o.classes = 2;
  o.random_labels = true;
  const SyntheticData train = make_synthetic(o);
  o.seed = 4;
  const SyntheticData test = make_synthetic(o);
  TrainParams p;
  p.K = 200;
  const Forest f = train_forest(train.data, p);
  // The trees fit the noise (many nodes) but cannot predict it.
  EXPECT_GT(f.stats.trees[0].nodes, 40);
  const double acc = accuracy_on(Classifier(f), test.data, test.labels);
  EXPECT_NEAR(acc, 0.5, 0.05) << "held-out accuracy " << acc;
}

// The smallest --memory-mb that training accepts, read from its refusal of 1 MB: it holds one tree
// at a time (the refusal names what one tree at a time needs).
std::size_t one_tree_budget_mb(const Dataset& data, TrainParams p) {
  p.memory_mb = 1;
  try {
    train_forest(data, p);
  } catch (const smseg::Error& e) {
    const std::string msg = e.what();
    const auto at = msg.find("needs at least ");
    if (at != std::string::npos) return std::stoul(msg.substr(at + 15));
    ADD_FAILURE() << "unexpected refusal: " << msg;
    return 0;
  }
  ADD_FAILURE() << "a 1 MB budget was accepted";
  return 0;
}

TEST(Train, MemoryBudgetTooSmallIsRefusedInOneLine) {
  const SyntheticData s = make_synthetic(small_room(2));
  TrainParams p;
  p.K = 100;
  p.M = 2;
  p.memory_mb = 1;
  try {
    train_forest(s.data, p);
    FAIL() << "a 1 MB budget was accepted";
  } catch (const smseg::Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("memory_mb"), std::string::npos) << msg;
    EXPECT_NE(msg.find("needs at least"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
  p.memory_mb = one_tree_budget_mb(s.data, p);
  EXPECT_GT(p.memory_mb, 1u);
  EXPECT_EQ(train_forest(s.data, p).trees.size(), 2u);  // the budget it asked for is enough
}

TEST(Train, SameForestWhateverTheThreadCount) {
  const SyntheticData s = make_synthetic(small_room(5));
  for (const bool textons : {false, true}) {
    TrainParams p;
    p.K = 600;  // big enough for the in-node parallel paths (tests x candidates > 2^20)
    p.M = 3;
    p.textons = textons;
    p.balance = textons ? Balance::Classes : Balance::None;
    std::string one, two, sequential;
    {
      tbb::global_control g(tbb::global_control::max_allowed_parallelism, 1);
      one = model_bytes(train_forest(s.data, p));
    }
    {
      tbb::global_control g(tbb::global_control::max_allowed_parallelism, 2);
      two = model_bytes(train_forest(s.data, p));
      p.memory_mb = one_tree_budget_mb(s.data, p);  // one tree at a time
      sequential = model_bytes(train_forest(s.data, p));
    }
    EXPECT_EQ(one, two) << "textons " << textons;
    EXPECT_EQ(one, sequential) << "textons " << textons;
  }
}

// Leaf tests (TrainParams::leaf_tests) change the leaf counts only: every split as the tree grew it,
// every leaf with at least what it had, each tree Kt + leaf_tests tests in all; the same bytes on one
// thread as on two.
TEST(Train, LeafTestsAddToTheLeavesAndKeepTheSplits) {
  const SyntheticData s = make_synthetic(small_room(8));
  for (const bool textons : {false, true}) {
    TrainParams p;
    p.K = 150;
    p.M = 3;
    p.textons = textons;
    p.balance = Balance::Sqrt;
    const Forest grown = train_forest(s.data, p);
    p.leaf_tests = 4000;
    std::string one;
    {
      tbb::global_control g(tbb::global_control::max_allowed_parallelism, 1);
      one = model_bytes(train_forest(s.data, p));
    }
    const Forest counted = train_forest(s.data, p);
    EXPECT_EQ(model_bytes(counted), one) << "textons " << textons;
    for (std::size_t t = 0; t < grown.trees.size(); ++t) {
      const auto& a = grown.trees[t].nodes;
      const auto& b = counted.trees[t].nodes;
      ASSERT_EQ(a.size(), b.size());
      std::uint64_t total = 0, added = 0;
      for (std::size_t i = 0; i < a.size(); ++i) {
        ASSERT_EQ(a[i].feature, b[i].feature);
        ASSERT_EQ(a[i].win, b[i].win);
        ASSERT_EQ(a[i].threshold, b[i].threshold);
        ASSERT_EQ(a[i].left, b[i].left);
        if (!a[i].is_leaf()) continue;
        for (std::size_t c = 0; c < a[i].counts.size(); ++c) {
          ASSERT_GE(b[i].counts[c], a[i].counts[c]);
          total += b[i].counts[c];
          added += b[i].counts[c] - a[i].counts[c];
        }
      }
      EXPECT_EQ(total, static_cast<std::uint64_t>(p.kt() + p.leaf_tests));
      EXPECT_EQ(added, static_cast<std::uint64_t>(p.leaf_tests));
    }
  }
}

// They reach the leaves the classifier routes them to: on a separable toy, grown to pure leaves, every
// leaf test lands in a leaf of its own class (a test routed by other windows or thresholds would not).
TEST(Train, LeafTestsOfASeparableToyLandInLeavesOfTheirClass) {
  const Separable toy(6);
  TrainParams p = pure_leaves(2);
  p.leaf_tests = 3000;
  const Forest f = train_forest(toy.data, p);
  for (const Tree& tree : f.trees) {
    for (const Node& n : tree.nodes) {
      if (n.is_leaf()) {
        EXPECT_TRUE(n.counts[0] == 0 || n.counts[1] == 0) << n.counts[0] << " " << n.counts[1];
      }
    }
  }
}

TEST(Train, SeedsAndTreesDiffer) {
  const SyntheticData s = make_synthetic(small_room(6));
  TrainParams p;
  p.K = 100;
  p.M = 2;
  const Forest a = train_forest(s.data, p);
  p.seed = 2;
  const Forest b = train_forest(s.data, p);
  EXPECT_NE(model_bytes(a), model_bytes(b));
  EXPECT_NE(forest_to_json(a)["trees"][0], forest_to_json(a)["trees"][1]);
}

TEST(Train, StatisticsDescribeTheTrees) {
  const SyntheticData s = make_synthetic(small_room(7));
  TrainParams p;
  p.K = 150;
  p.M = 3;
  p.textons = true;
  const Forest f = train_forest(s.data, p);
  ASSERT_EQ(f.stats.trees.size(), 3u);
  std::int64_t splits = 0, window_splits = 0;
  for (std::size_t t = 0; t < 3; ++t) {
    const Tree& tree = f.trees[t];
    int leaves = 0;
    for (const Node& n : tree.nodes) {
      leaves += n.is_leaf();
      splits += !n.is_leaf();
      window_splits += !n.is_leaf() && n.feature < 4;
    }
    EXPECT_EQ(f.stats.trees[t].nodes, static_cast<int>(tree.nodes.size()));
    EXPECT_EQ(f.stats.trees[t].leaves, leaves);
    EXPECT_EQ(leaves * 2 - 1, f.stats.trees[t].nodes);  // binary trees
    EXPECT_GE(f.stats.trees[t].depth, 1);
    EXPECT_LT(f.stats.trees[t].depth, leaves);
  }
  std::int64_t per_feature = 0;
  for (auto v : f.stats.nodes_per_feature) per_feature += v;
  EXPECT_EQ(per_feature, splits);
  EXPECT_EQ(f.stats.nodes_per_feature.size(), 8u);  // 4 features + 4 texton tests
  EXPECT_EQ(f.stats.windows.total(), static_cast<double>(window_splits));
  EXPECT_GT(f.stats.seconds, 0.0);
}

TEST(Train, BalanceDrawsTestsPerClass) {
  // The box class covers few pixels: unbalanced, it gets few tests; balanced, a quarter.
  const SyntheticData s = make_synthetic(small_room(8));
  TrainParams p;
  p.K = 400;
  p.M = 1;
  auto share = [&](Balance b) {
    p.balance = b;
    const Corpus c = build_corpus(s.data, p, 0);
    std::vector<double> n(4, 0.0);
    for (const auto& t : c.tests) n[t.label] += 1.0 / static_cast<double>(c.tests.size());
    return n;
  };
  const auto plain = share(Balance::None), balanced = share(Balance::Classes), halfway = share(Balance::Sqrt);
  EXPECT_LT(plain[3], 0.1);
  for (double v : balanced) EXPECT_NEAR(v, 0.25, 0.07);
  // sqrt: each class in proportion to the square root of its share of the pixels (~ plain's share).
  double root_sum = 0;
  for (double v : plain) root_sum += std::sqrt(v);
  for (std::size_t c = 0; c < 4; ++c) EXPECT_NEAR(halfway[c], std::sqrt(plain[c]) / root_sum, 0.03) << "class " << c;
  EXPECT_GT(halfway[3], plain[3] + 0.03);  // the box gains, less than with classes
  EXPECT_LT(halfway[3], balanced[3] - 0.03);
}

TEST(Train, BadParametersAreRefusedByName) {
  const SyntheticData s = make_synthetic(small_room(9));
  auto field_of = [&](TrainParams p) -> std::string {
    try {
      train_forest(s.data, p);
    } catch (const smseg::Error& e) {
      return e.field();
    }
    return "(accepted)";
  };
  TrainParams p;
  p.K = 0;
  EXPECT_EQ(field_of(p), "K");
  p = TrainParams{};
  p.M = 0;
  EXPECT_EQ(field_of(p), "M");
  p = TrainParams{};
  p.n_min = 0;
  EXPECT_EQ(field_of(p), "n_min");
  p = TrainParams{};
  p.Kt = -3;
  EXPECT_EQ(field_of(p), "Kt");
  p = TrainParams{};
  p.windows.thesis_dy_share = 1.5;
  EXPECT_EQ(field_of(p), "windows.thesis_dy_share");
  p = TrainParams{};
  p.windows.mode = WindowSampling::Learned;
  EXPECT_EQ(field_of(p), "windows.learned");
}

TEST(Train, BadDataIsRefusedByName) {
  auto field_of = [](const Dataset& d, bool textons = false) -> std::string {
    TrainParams p;
    p.K = 20;
    p.M = 1;
    p.textons = textons;
    try {
      train_forest(d, p);
    } catch (const smseg::Error& e) {
      return e.field();
    }
    return "(accepted)";
  };
  SyntheticData s = make_synthetic(small_room(10));
  Dataset d = s.data;
  EXPECT_EQ(field_of(d), "(accepted)");
  s.labels[1][17] = 9;  // only 4 classes
  EXPECT_EQ(field_of(d), "frames[1].labels");
  s.labels[1][17] = 0;
  d.frames[2].sats.pop_back();
  EXPECT_EQ(field_of(d), "frames[2].sats");
  d = s.data;
  d.frames[0].width = 10;
  EXPECT_EQ(field_of(d), "frames[0]");
  d = s.data;
  d.frames[0].gray = nullptr;
  EXPECT_EQ(field_of(d), "(accepted)");
  EXPECT_EQ(field_of(d, true), "frames[0].gray");
  d = s.data;
  d.frames[3].labels = nullptr;
  EXPECT_EQ(field_of(d), "frames[3].labels");
  d = s.data;
  d.classes.push_back("ceiling");
  EXPECT_EQ(field_of(d), "classes");
  // All void: nothing to learn from.
  d = s.data;
  for (auto& l : s.labels) std::fill(l.begin(), l.end(), kVoidLabel);
  EXPECT_EQ(field_of(d), "labels");
}
