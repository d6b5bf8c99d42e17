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

#include "smseg/forest/forest.hpp"
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

/// Trees grown on a table as a Forest, so that they are saved, loaded, pickled and checked as every
/// forest file is ("smseg-forest", versioned): a 1x1 "image" (every window is the pixel itself), one
/// feature per column named "x0", "x1", ... and classes named by their positions "0", "1", ... (the
/// caller keeps its own labels); params records M, n_min, seed and score (the rest are unused).
Forest tabular_forest(std::vector<Tree> trees, std::size_t columns, int num_classes, int n_min, std::uint64_t seed,
                      Score score);

/// Mean decrease in impurity per attribute, as scikit-learn defines feature_importances_: in each
/// tree, every split adds n_t H(t) - n_l H(l) - n_r H(r) (n: the tests reaching a node, summed from the
/// leaves' counts; H: the Shannon entropy of its class counts, the impurity both split scores are
/// built on) to its attribute, divided by the root's count and normalised to sum 1 (a tree that is one
/// leaf adds nothing); the forest's are the trees' mean, normalised to sum 1 (all zeros when no tree
/// splits). num_attributes values.
std::vector<double> impurity_importances(const std::vector<Tree>& trees, int num_attributes);

}  // namespace smseg::forest
