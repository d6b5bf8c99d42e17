// Leaf distributions counted from more tests than a tree grew on (TrainParams::leaf_tests; see
// forest_corpus.hpp).
#include <algorithm>

#include <oneapi/tbb/parallel_for.h>

#include "forest_corpus.hpp"
#include "smseg/forest/rng.hpp"

namespace smseg::forest::detail {

namespace {
/// The stream tree `tree` draws its leaf tests from: apart from the one it grows from (tree_seed).
std::uint64_t leaf_test_seed(std::uint64_t seed, int tree) noexcept {
  return tree_seed(mix64(seed ^ 0x1EAF7E575EEDULL), tree);
}

/// The leaf (node index) a test at (x, y) reaches: the decisions the trainer and the classifier make
/// (the grower's float value < threshold).
std::int32_t leaf_reached(const Tree& tree, const FrameData& frame, int x, int y) {
  std::int32_t i = 0;
  for (;;) {
    const Node& n = tree.nodes[static_cast<std::size_t>(i)];
    if (n.is_leaf()) return i;
    i = attribute_value(frame, n.feature, n.win, x, y) < n.threshold ? n.left : n.right;
  }
}
}  // namespace

void count_leaf_tests(const Dataset& data, const TrainParams& params, const TestSampler& sampler,
                      std::span<Tree> trees, int first_tree) {
  const auto n = static_cast<std::size_t>(params.leaf_tests);
  if (n == 0 || trees.empty()) return;
  // Each tree's tests, drawn as its growing tests are (the same balance), from its own stream.
  std::vector<std::vector<TestPoint>> tests(trees.size());
  tbb::parallel_for(std::size_t{0}, trees.size(), [&](std::size_t i) {
    Rng rng(leaf_test_seed(params.seed, first_tree + static_cast<int>(i)));
    tests[i].resize(n);
    for (TestPoint& t : tests[i]) t = sampler.draw(rng, params.balance);
  });
  // Frame by frame (each read once, then released): every test's leaf, into its own slot.
  struct Ref {
    std::uint32_t tree, test;
  };
  std::vector<std::vector<Ref>> by_frame(data.frames.size());
  for (std::size_t i = 0; i < tests.size(); ++i)
    for (std::size_t t = 0; t < n; ++t)
      by_frame[static_cast<std::size_t>(tests[i][t].frame)].push_back(
          {static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(t)});
  std::vector<std::vector<std::int32_t>> leaf(trees.size(), std::vector<std::int32_t>(n));
  tbb::parallel_for(std::size_t{0}, data.frames.size(), [&](std::size_t fi) {
    if (by_frame[fi].empty()) return;
    const FrameData& frame = data.frames[fi];
    // In raster order, whichever tree: the next test's windows lie near the last one's. (Each writes
    // its own slot: the order changes nothing.)
    std::vector<Ref>& refs = by_frame[fi];
    const auto at = [&](const Ref& r) { const TestPoint& t = tests[r.tree][r.test]; return std::pair(t.y, t.x); };
    std::sort(refs.begin(), refs.end(), [&](const Ref& a, const Ref& b) { return at(a) < at(b); });
    for (const Ref& r : refs) {
      const TestPoint& t = tests[r.tree][r.test];
      leaf[r.tree][r.test] = leaf_reached(trees[r.tree], frame, t.x, t.y);
    }
    if (frame.release) frame.release();
  });
  // Integer counts added in test order: the same forest whatever the thread count.
  for (std::size_t i = 0; i < trees.size(); ++i)
    for (std::size_t t = 0; t < n; ++t) ++trees[i].nodes[static_cast<std::size_t>(leaf[i][t])].counts[tests[i][t].label];
}

}  // namespace smseg::forest::detail
