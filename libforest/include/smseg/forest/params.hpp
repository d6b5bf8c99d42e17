#pragma once
// Training parameters: one value struct with documented defaults, validated once, passed whole.

#include <cstddef>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "smseg/forest/window.hpp"
#include "smseg/common/io.hpp"

namespace smseg::options {
template <class S>
class Table;
}

namespace smseg::forest {

/// How training keeps the dominant class from swamping the others.
enum class Balance {
  None,     ///< tests drawn as the thesis does: a random labelled frame, then a random non-void pixel
  Classes,  ///< tests drawn per class: a class uniformly among those present, then a pixel of that
            ///< class uniformly among all training frames; splits and leaves then see a balanced
            ///< sample (leaf distributions are class-balanced, i.e. a flat prior over classes)
  Sqrt      ///< halfway: a class with probability proportional to the square root of its pixel count,
            ///< then a pixel of it as with Classes (a rare class gains, the frequent ones keep most)
};
std::string to_string(Balance b);
Balance balance_from_string(const std::string& s, const std::string& field);

/// How a candidate split of a node is scored (the highest score wins).
enum class Score {
  WehenkelPavella,  ///< 2 I(C;S) / (H(C) + H(S)), Wehenkel & Pavella's normalisation (the thesis)
  InformationGain   ///< I(C;S) = H(C) - H(C|S), plain information gain (scikit-learn's 'entropy')
};
std::string to_string(Score s);  ///< "wehenkel-pavella" | "information-gain"
Score score_from_string(const std::string& s, const std::string& field);

struct TrainParams {
  int K = 400;        ///< sets Ks and Kt when they are 0 (thesis: K = Ks = Kt)
  int Ks = 0;         ///< sampling windows per tree (0: K)
  int Kt = 0;         ///< tests (training pixels) per tree (0: K)
  int M = 7;          ///< trees
  int n_min = 5;      ///< a node with fewer tests becomes a leaf
  std::uint64_t seed = 1;
  WindowParams windows;              ///< how the Ks windows are drawn (default uniform)
  Balance balance = Balance::None;   ///< default off
  bool textons = false;              ///< add the four texton tests at Ks random offsets
  /// The split score (default: the thesis's). Forest files without it read as the default.
  Score score = Score::WehenkelPavella;
  /// Lightness normalisation (stacks/exposure.hpp): every frame, in training and wherever the forest
  /// classifies, brought to this mean fL (L* / 100) by the exposure map of its appearance channels; 0:
  /// off. Files without it read as off, and it is left out of them when off.
  double lightness = 0.0;
  /// After a tree has grown on its Kt tests, its leaves count this many more, drawn as those are (the
  /// same balance) from a stream of the tree's own: the splits stay the Kt tests', the leaf
  /// distributions rest on Kt + leaf_tests. 0: the Kt tests alone (the thesis). Files without it read
  /// as 0, and it is left out of them when 0.
  int leaf_tests = 0;
  /// Memory budget of training as a whole, in MiB: trees are built in batches of as many as fit
  /// next to the fixed part (process, test sampler, frames being read); a budget that cannot hold
  /// one tree is refused (Error naming memory_mb and what is needed). Frames are read one at a time
  /// and released (FrameData::release). Does not change the forest, so it is not serialised.
  std::size_t memory_mb = 2048;
  bool progress = false;             ///< progress on stderr (not serialised)

  int ks() const { return Ks > 0 ? Ks : K; }
  int kt() const { return Kt > 0 ? Kt : K; }
  /// Error(source, "<parameter>", reason) for the first bad parameter.
  void validate(const std::string& source = "training parameters") const;
};

/// TrainParams' fields, declared once (options.hpp): train-forest's options, forest.json's "params",
/// run-experiment's training keys, the Python estimator's parameters.
const options::Table<TrainParams>& train_params_table();

/// forest.json's "params": the table's fields on files, and the whole window sampling.
nlohmann::json params_to_json(const TrainParams& p);
TrainParams params_from_json(const JsonView& j);

nlohmann::json histograms_to_json(const WindowHistograms& h);
WindowHistograms histograms_from_json(const JsonView& j);

}  // namespace smseg::forest
