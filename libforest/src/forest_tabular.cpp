#include "smseg/forest/tabular.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "smseg/common/error.hpp"
#include "smseg/forest/rng.hpp"

namespace smseg::forest {

namespace {

// The corpus of a table without its values: the checks, one test per row, candidate c = column c.
Corpus corpus_without_values(std::span<const float> values, std::size_t columns, std::span<const std::uint8_t> labels,
                             int num_classes, const std::string& source) {
  const std::size_t rows = labels.size();
  if (rows == 0) throw Error(source, "rows", "no rows");
  if (columns == 0) throw Error(source, "columns", "no columns");
  if (values.size() != rows * columns)
    throw Error(source, "values", std::to_string(values.size()) + " values for " + std::to_string(rows) + " rows of " +
                                      std::to_string(columns) + " columns");
  if (num_classes < 1 || num_classes >= kVoidLabel) throw Error(source, "classes", "must be 1..254");
  Corpus corpus;
  corpus.num_classes = num_classes;
  corpus.candidates.resize(columns);
  for (std::size_t c = 0; c < columns; ++c) corpus.candidates[c].feature = static_cast<int>(c);
  corpus.tests.resize(rows);
  for (std::size_t r = 0; r < rows; ++r) {
    if (labels[r] >= num_classes)
      throw Error(source, "row " + std::to_string(r), "label " + std::to_string(labels[r]) + " is not below the " +
                                                          std::to_string(num_classes) + " classes");
    corpus.tests[r].label = labels[r];
  }
  return corpus;
}

/// Per node: the class counts of the tests that reach it (a split's are its children's sums; children
/// have larger indices than their parents).
std::vector<std::vector<double>> node_counts(const Tree& tree) {
  std::vector<std::vector<double>> counts(tree.nodes.size());
  for (std::size_t i = tree.nodes.size(); i-- > 0;) {
    const Node& n = tree.nodes[i];
    if (n.is_leaf()) {
      counts[i].assign(n.counts.begin(), n.counts.end());
      continue;
    }
    const auto& l = counts[static_cast<std::size_t>(n.left)];
    const auto& r = counts[static_cast<std::size_t>(n.right)];
    counts[i].resize(l.size());
    for (std::size_t k = 0; k < l.size(); ++k) counts[i][k] = l[k] + r[k];
  }
  return counts;
}

/// n H(counts), n the total: the node's entropy weighted by its tests.
double weighted_entropy(const std::vector<double>& counts) {
  const double n = std::accumulate(counts.begin(), counts.end(), 0.0);
  double h = 0.0;
  for (double c : counts)
    if (c > 0.0) h -= c * std::log(c / n);
  return h;
}

/// Scales v to sum 1 (left as it is when its sum is 0).
void normalise(std::vector<double>& v) {
  const double sum = std::accumulate(v.begin(), v.end(), 0.0);
  if (sum > 0.0)
    for (double& x : v) x /= sum;
}

std::vector<std::uint64_t> tree_seeds(int trees, std::uint64_t seed) {
  std::vector<std::uint64_t> seeds(static_cast<std::size_t>(std::max(trees, 0)));
  for (int t = 0; t < trees; ++t) seeds[static_cast<std::size_t>(t)] = tree_seed(seed, t);
  return seeds;
}

}  // namespace

Corpus tabular_corpus(std::span<const float> values, std::size_t columns, std::span<const std::uint8_t> labels,
                      int num_classes, const std::string& source) {
  Corpus corpus = corpus_without_values(values, columns, labels, num_classes, source);
  const std::size_t rows = labels.size();
  corpus.values.resize(rows * columns);  // candidate-major, the corpus's layout
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < columns; ++c) corpus.values[c * rows + r] = values[r * columns + c];
  return corpus;
}

std::vector<Tree> grow_tabular_forest(const Corpus& corpus, int trees, int n_min, std::uint64_t seed, Score score) {
  return grow_trees(corpus, n_min, tree_seeds(trees, seed), score);
}

std::vector<Tree> grow_tabular_forest(std::span<const float> values, std::size_t columns,
                                      std::span<const std::uint8_t> labels, int num_classes, int trees, int n_min,
                                      std::uint64_t seed, Score score, const std::string& source) {
  const Corpus corpus = corpus_without_values(values, columns, labels, num_classes, source);
  return grow_trees_from_rows(corpus, values.data(), n_min, tree_seeds(trees, seed), score);
}

Forest tabular_forest(std::vector<Tree> trees, std::size_t columns, int num_classes, int n_min, std::uint64_t seed,
                      Score score) {
  Forest f;
  f.width = f.height = 1;
  for (std::size_t c = 0; c < columns; ++c) f.features.push_back("x" + std::to_string(c));
  for (int k = 0; k < num_classes; ++k) f.classes.push_back(std::to_string(k));
  f.params.M = static_cast<int>(trees.size());
  f.params.n_min = n_min;
  f.params.seed = seed;
  f.params.score = score;
  f.trees = std::move(trees);
  f.compute_stats();
  return f;
}

std::vector<double> impurity_importances(const std::vector<Tree>& trees, int num_attributes) {
  std::vector<double> forest(static_cast<std::size_t>(num_attributes), 0.0);
  for (const Tree& tree : trees) {
    if (tree.nodes.size() < 2) continue;
    const auto counts = node_counts(tree);
    std::vector<double> mine(forest.size(), 0.0);
    for (std::size_t i = 0; i < tree.nodes.size(); ++i) {
      const Node& n = tree.nodes[i];
      if (n.is_leaf()) continue;
      mine[static_cast<std::size_t>(n.feature)] += weighted_entropy(counts[i]) -
                                                   weighted_entropy(counts[static_cast<std::size_t>(n.left)]) -
                                                   weighted_entropy(counts[static_cast<std::size_t>(n.right)]);
    }
    // Dividing by the root's count first (as scikit-learn does) changes nothing after normalising, and
    // the mean over trees is their sum normalised.
    normalise(mine);
    for (std::size_t a = 0; a < forest.size(); ++a) forest[a] += mine[a];
  }
  normalise(forest);
  return forest;
}

int tabular_posterior(const std::vector<Tree>& trees, const float* row, int num_classes, std::vector<double>& acc) {
  acc.assign(static_cast<std::size_t>(num_classes), 0.0);
  for (const Tree& tree : trees) {
    const Node* n = &tree.nodes[0];
    while (!n->is_leaf())
      n = &tree.nodes[static_cast<std::size_t>(static_cast<double>(row[n->feature]) < n->threshold ? n->left : n->right)];
    double total = 0.0;
    for (auto v : n->counts) total += v;
    for (int k = 0; k < num_classes; ++k) acc[static_cast<std::size_t>(k)] += n->counts[static_cast<std::size_t>(k)] / total;
  }
  return static_cast<int>(std::max_element(acc.begin(), acc.end()) - acc.begin());
}

}  // namespace smseg::forest
