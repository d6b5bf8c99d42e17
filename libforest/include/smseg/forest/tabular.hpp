#pragma once
// The trainer on tabular data: rows of attribute values and a class per row, as scikit-learn's
// ExtraTreesClassifier sees them (forest-peers, the Python smseg.ExtraTreesClassifier). Every tree is
// grown by grow_trees from the SAME rows and columns (candidate c is column c: no windows, no
// bootstrap), seeded by tree_seed(seed, t); a row is classified by the sum of the trees' normalised
// leaf distributions (argmax, ties to the lowest class), as the pixel classifier does.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "smseg/forest/train.hpp"

namespace smseg::forest {

/// Row-major values (values[r * columns + c]) and labels (< num_classes) as a corpus whose candidate
/// c is column c. Error naming `source` when the sizes disagree or a label is out of range.
Corpus tabular_corpus(std::span<const float> values, std::size_t columns, std::span<const std::uint8_t> labels,
                      int num_classes, const std::string& source = "tabular data");

/// `trees` trees grown from the corpus, tree t seeded by tree_seed(seed, t).
std::vector<Tree> grow_tabular_forest(const Corpus& corpus, int trees, int n_min, std::uint64_t seed, Score score);

/// The same trees grown straight from the row-major table (the grower's layout): no copy of the
/// values is made, so a table as large as memory allows can be trained on. Errors as tabular_corpus.
std::vector<Tree> grow_tabular_forest(std::span<const float> values, std::size_t columns,
                                      std::span<const std::uint8_t> labels, int num_classes, int trees, int n_min,
                                      std::uint64_t seed, Score score, const std::string& source = "tabular data");

/// Summed normalised leaf distributions of one row (acc: num_classes values, overwritten); returns the
/// argmax (lowest class on ties). A node sends the row left when double(row[feature]) < threshold.
int tabular_posterior(const std::vector<Tree>& trees, const float* row, int num_classes, std::vector<double>& acc);

}  // namespace smseg::forest
