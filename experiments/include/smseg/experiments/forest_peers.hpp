#pragma once
// forest-peers' work: our extremely randomized trees on an exported corpus (train-forest
// --export-corpus) the way scikit-learn's ExtraTreesClassifier and ranger see it (experiments/peers/):
// the corpus CSVs read line by line, trees grown with grow_tabular_forest on the same rows and
// columns (timed, wall clock and process CPU), the held-out rows classified, and the results.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "smseg/common/io.hpp"
#include "smseg/forest/train.hpp"

namespace smseg::experiments {

/// A corpus CSV: header "label,<names>", then per row a class index and one float per column.
struct CorpusTable {
  std::string header;
  std::size_t columns = 0;
  std::vector<std::uint8_t> labels;
  std::vector<float> values;  ///< row-major: values[r * columns + c]
  std::size_t rows() const { return labels.size(); }
};

/// Reads a corpus CSV line by line (memory holds the values, not the text). Error naming the file and
/// the row for a bad header, label or value, a wrong number of values, an overlong line or no rows.
CorpusTable read_corpus_table(const std::filesystem::path& path);

/// Comma-separated non-negative integers; Error naming --seeds otherwise or when there are none.
std::vector<std::uint64_t> parse_seeds(const std::string& s);

/// The median (the mean of the two middle values for an even count); v must not be empty.
double median(std::vector<double> v);

/// What forest-peers runs: the corpora, the forest's parameters, timed fits per seed and threads.
struct PeerSettings {
  std::string train_csv, heldout_csv;
  int trees = 7, n_min = 5, repeat = 3, threads = 1;
  int classes = 0;  ///< 0: 1 + the largest label in either table (see peer_classes)
  forest::Score score = forest::Score::WehenkelPavella;
};

/// The class count: `classes`, or 1 + the largest label of either table when it is 0. Error naming
/// --classes when a label is not below it.
int peer_classes(const CorpusTable& train, const CorpusTable& held, int classes);

/// One seed's fits and scores.
struct PeerRun {
  std::uint64_t seed = 0;
  double accuracy = 0, class_average = 0;
  double seconds = 0, cpu_seconds = 0;            ///< medians of the fits
  std::vector<double> seconds_all, cpu_seconds_all;  ///< every fit
  std::size_t nodes = 0;                          ///< in all trees of the last fit
};

/// s.repeat timed fits of s.trees trees seeded by seed on the training table (s.classes resolved),
/// then the held-out rows classified: accuracy and class-average accuracy.
PeerRun fit_and_score(const CorpusTable& train, const CorpusTable& held, const PeerSettings& s, std::uint64_t seed);

/// The line printed per seed (with its newline).
std::string peer_run_line(const PeerRun& run, int repeat);
/// The closing line: mean accuracy over the seeds, median fit times (with its newline).
std::string peers_summary_line(const std::vector<PeerRun>& runs);
/// The result file: the settings, the tables' sizes, every run, the mean accuracy and median times.
Json peers_json(const PeerSettings& s, const CorpusTable& train, const CorpusTable& held,
                const std::vector<PeerRun>& runs);

}  // namespace smseg::experiments
