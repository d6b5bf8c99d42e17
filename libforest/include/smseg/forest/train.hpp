#pragma once
// Training: extremely randomized trees over sampling windows (Geurts, Ernst & Wehenkel 2006; thesis
// sections 2.3.3 and 3.2.4).
//
// Per tree t, with a generator seeded by tree_seed(seed, t):
//  1. draw Ks windows (WindowSampler) and, with textons, Ks texton offsets;
//  2. draw Kt tests: a labelled frame uniformly, then a non-void pixel uniformly in it
//     (Balance::Classes: a class uniformly, then a pixel of that class uniformly over all frames;
//     Balance::Sqrt: a class in proportion to the square root of its pixel count, then likewise);
//  3. evaluate every candidate attribute (window x feature, texton offset x test) at every test:
//     the corpus, a float matrix (Kt x candidates x 4 bytes);
//  4. grow the tree depth first: at each node every non-constant candidate gets one threshold
//     uniform in (min, max] of its values over the node's tests; the best Wehenkel-Pavella score
//     2 I(C;S) / (H(C) + H(S)) splits (ties: lowest candidate index); with Score::InformationGain
//     the best I(C;S) does. A node is a leaf when its tests
//     share one class, when every candidate is constant over them, or when fewer than n_min remain.
// Memory (TrainParams::memory_mb): trees are built in batches that fit the budget; a batch's values
// are filled in one pass over the frames, one frame at a time (released after), straight into the
// grower's test-major layout (Kt x candidates floats per tree, no second copy).
// Trees run in parallel (oneTBB), and candidates of big nodes too; thresholds are counter-based
// draws keyed by (tree seed, node index, candidate), so the forest does not depend on thread count.

#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "smseg/forest/data.hpp"
#include "smseg/forest/forest.hpp"
#include "smseg/forest/params.hpp"
#include "smseg/forest/parts.hpp"

namespace smseg::forest {

/// Trains a forest; validates params and data first (Error on the first problem).
Forest train_forest(const Dataset& data, const TrainParams& params);

/// Only trees range.begin..range.end-1 of train_forest(data, params) (each identical to its
/// counterpart there): a part of the forest, for save_forest_part and merge_forest_parts.
/// Error unless 0 <= begin < end <= params.M.
Forest train_forest_trees(const Dataset& data, const TrainParams& params, TreeRange range);

/// One candidate attribute: a window (or texton offset) and an attribute index.
struct Candidate {
  Window win;
  int feature = 0;
};

/// One test: a labelled pixel.
struct TestPoint {
  int frame = 0, x = 0, y = 0;
  std::uint8_t label = 0;
};

/// The training corpus of one tree (what the tree is grown from).
struct Corpus {
  int num_classes = 0;
  std::vector<Candidate> candidates;
  std::vector<TestPoint> tests;
  std::vector<float> values;  ///< candidate-major: values[c * tests.size() + t]
  const float* column(std::size_t c) const { return values.data() + c * tests.size(); }
};

/// The corpus tree `tree` of train_forest(data, params) is grown from.
Corpus build_corpus(const Dataset& data, const TrainParams& params, int tree);

/// Grows one tree from a corpus (steps 4 above). seed: the tree's seed (thresholds); score: the
/// split score (TrainParams::score).
Tree grow_tree(const Corpus& corpus, int n_min, std::uint64_t seed, Score score = Score::WehenkelPavella);

/// grow_tree for each seed (in parallel), sharing one test-major copy of the corpus's values (the
/// grower's layout) instead of making one per tree: trees[i] == grow_tree(corpus, n_min, seeds[i], score).
std::vector<Tree> grow_trees(const Corpus& corpus, int n_min, std::span<const std::uint64_t> seeds,
                             Score score = Score::WehenkelPavella);

/// grow_trees on values the caller already holds test-major (rows[t * candidates + c], the grower's
/// layout: a table's rows), so that no copy is made; corpus.values is not read (it may be empty).
/// The same trees as grow_trees on the corpus with those values.
std::vector<Tree> grow_trees_from_rows(const Corpus& corpus, const float* rows, int n_min,
                                       std::span<const std::uint64_t> seeds, Score score = Score::WehenkelPavella);

/// Wehenkel-Pavella normalised information gain of a binary split, 2 I(C;S) / (H(C) + H(S)),
/// from the per-class test counts on each side; 0 when either side is empty or H(C) = 0.
double wehenkel_pavella(std::span<const std::uint32_t> left, std::span<const std::uint32_t> right);

/// Information gain of a binary split, I(C;S) = H(C) - H(C|S) in bits, from the per-class test
/// counts on each side; 0 when either side is empty.
double information_gain(std::span<const std::uint32_t> left, std::span<const std::uint32_t> right);

/// Writes the corpus of tree `tree` as CSV: a header "label,<candidate names>", then one row per
/// test: its class index, then every candidate attribute's value (float, round-trip precision).
/// Candidate names look like "fH[dx=-3;dy=5;w=12;h=7]". Atomic write.
void export_corpus_csv(const Dataset& data, const TrainParams& params, int tree,
                       const std::filesystem::path& path);

std::string candidate_name(const Candidate& c, const std::vector<std::string>& features);

}  // namespace smseg::forest
