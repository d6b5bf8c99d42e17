// forest-peers' work (see forest_peers.hpp).
#include "smseg/experiments/forest_peers.hpp"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <sstream>
#include <string_view>

#include "smseg/forest/tabular.hpp"

namespace smseg::experiments {

namespace {

// One line of `in` into `line` (without its end of line); false at the end of the file. A line longer
// than max_chars is refused: a file without line ends (a device, a binary file) must not grow the
// process without bound.
bool read_line(std::istream& in, std::string& line, std::size_t max_chars, const fs::path& path,
               const std::string& where) {
  line.clear();
  std::streambuf* sb = in.rdbuf();
  for (int c = sb->sbumpc(); c != std::char_traits<char>::eof(); c = sb->sbumpc()) {
    if (c == '\n') return true;
    line.push_back(static_cast<char>(c));
    if (line.size() > max_chars)
      throw Error(path.string(), where, "is longer than " + std::to_string(max_chars) + " characters: not a corpus CSV");
  }
  return !line.empty();
}

// One data row: its label and `columns` values appended to the table.
void parse_row(std::string_view s, CorpusTable& t, const fs::path& path, const std::string& where) {
  const char* p = s.data();
  const char* end = s.data() + s.size();
  int label = 0;
  auto r = std::from_chars(p, end, label);
  if (r.ec != std::errc() || label < 0 || label >= forest::kVoidLabel)
    throw Error(path.string(), where, "label is not a class index 0..254");
  t.labels.push_back(static_cast<std::uint8_t>(label));
  p = r.ptr;
  for (std::size_t c = 0; c < t.columns; ++c) {
    if (p >= end || *p != ',')
      throw Error(path.string(), where, "has " + std::to_string(c) + " values, expected " + std::to_string(t.columns));
    float v = 0.0f;
    r = std::from_chars(p + 1, end, v);
    if (r.ec != std::errc()) throw Error(path.string(), where, "value " + std::to_string(c + 1) + " is not a number");
    t.values.push_back(v);
    p = r.ptr;
  }
  if (p != end) throw Error(path.string(), where, "has more than " + std::to_string(t.columns) + " values");
}

// The header line "label,<names>" into t (its column count from the commas).
void read_header(std::istream& in, CorpusTable& t, const fs::path& path) {
  constexpr std::size_t kMaxHeader = std::size_t(64) << 20;
  std::string line;
  if (!read_line(in, line, kMaxHeader, path, "header")) throw Error(path.string(), "header", "no header line");
  t.header = line;
  if (!t.header.empty() && t.header.back() == '\r') t.header.pop_back();
  if (t.header.rfind("label,", 0) != 0)
    throw Error(path.string(), "header", "expected 'label,<candidate names>' (train-forest --export-corpus)");
  t.columns = static_cast<std::size_t>(std::count(t.header.begin(), t.header.end(), ','));
}

// Classifies the held-out rows: accuracy, and the mean of the per-class accuracies over the classes
// present.
void score_heldout(const std::vector<forest::Tree>& trees, const CorpusTable& held, int classes, PeerRun& run) {
  std::vector<double> acc(static_cast<std::size_t>(classes));
  std::size_t right = 0;
  std::vector<std::size_t> per_class(static_cast<std::size_t>(classes)), per_class_right(per_class.size());
  for (std::size_t i = 0; i < held.rows(); ++i) {
    const int k = forest::tabular_posterior(trees, held.values.data() + i * held.columns, classes, acc);
    ++per_class[held.labels[i]];
    if (k == held.labels[i]) {
      ++right;
      ++per_class_right[held.labels[i]];
    }
  }
  double class_avg = 0.0;
  int present = 0;
  for (std::size_t k = 0; k < per_class.size(); ++k)
    if (per_class[k]) {
      class_avg += static_cast<double>(per_class_right[k]) / static_cast<double>(per_class[k]);
      ++present;
    }
  class_avg /= std::max(1, present);
  run.accuracy = static_cast<double>(right) / static_cast<double>(held.rows());
  run.class_average = class_avg;
}

}  // namespace

// Read line by line (a CamVid-scale corpus is hundreds of MB): memory holds the values, not the text.
CorpusTable read_corpus_table(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string(), "", "cannot be opened");
  CorpusTable t;
  read_header(in, t, path);
  const std::size_t max_row = 64 + 64 * t.columns;  // a float is at most ~50 characters
  std::error_code ec;
  const std::uintmax_t bytes = fs::is_regular_file(path, ec) ? fs::file_size(path, ec) : 0;
  std::size_t row = 0;
  std::string line;
  while (read_line(in, line, max_row, path, "row " + std::to_string(row + 1))) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;  // blank lines (at the end)
    ++row;
    if (row == 1 && bytes > 0) {  // room for the rows the file holds if they are about this long
      const std::size_t rows = static_cast<std::size_t>(1.1 * static_cast<double>(bytes) / double(line.size() + 1)) + 16;
      t.labels.reserve(rows);
      t.values.reserve(rows * t.columns);
    }
    parse_row(line, t, path, "row " + std::to_string(row));
  }
  if (in.bad()) throw Error(path.string(), "", "read error");
  if (t.labels.empty()) throw Error(path.string(), "", "no rows");
  return t;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::vector<std::uint64_t> parse_seeds(const std::string& s) {
  std::vector<std::uint64_t> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) {
    std::uint64_t v = 0;
    const auto r = std::from_chars(item.data(), item.data() + item.size(), v);
    if (item.empty() || r.ec != std::errc() || r.ptr != item.data() + item.size())
      throw Error("", "--seeds", "'" + item + "' is not a non-negative integer");
    out.push_back(v);
  }
  if (out.empty()) throw Error("", "--seeds", "no seed given");
  return out;
}

int peer_classes(const CorpusTable& train, const CorpusTable& held, int classes) {
  int max_label = 0;
  for (auto l : train.labels) max_label = std::max<int>(max_label, l);
  for (auto l : held.labels) max_label = std::max<int>(max_label, l);
  if (classes == 0) classes = max_label + 1;
  if (classes <= max_label)
    throw Error("", "--classes", "is " + std::to_string(classes) + " but a label is " + std::to_string(max_label));
  return classes;
}

PeerRun fit_and_score(const CorpusTable& train, const CorpusTable& held, const PeerSettings& s, std::uint64_t seed) {
  PeerRun run;
  run.seed = seed;
  // The grower reads the table's rows as they are (no corpus copy, no transposed copy).
  std::vector<forest::Tree> trees;
  for (int r = 0; r < s.repeat; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();  // process CPU time, all threads
    trees = forest::grow_tabular_forest(train.values, train.columns, train.labels, s.classes, s.trees, s.n_min, seed,
                                        s.score, s.train_csv);
    run.cpu_seconds_all.push_back(static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
    run.seconds_all.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  score_heldout(trees, held, s.classes, run);
  for (const auto& t : trees) run.nodes += t.nodes.size();
  run.seconds = median(run.seconds_all);
  run.cpu_seconds = median(run.cpu_seconds_all);
  return run;
}

std::string peer_run_line(const PeerRun& run, int repeat) {
  char line[256];
  std::snprintf(line, sizeof line,
                "seed %llu: accuracy %.4f (class-average %.4f), fit %.4f s wall, %.4f s CPU (medians of %d), %zu nodes\n",
                static_cast<unsigned long long>(run.seed), run.accuracy, run.class_average, run.seconds,
                run.cpu_seconds, repeat, run.nodes);
  return line;
}

namespace {

struct RunTotals {
  double mean_accuracy = 0, median_seconds = 0, median_cpu_seconds = 0;
};

RunTotals run_totals(const std::vector<PeerRun>& runs) {
  std::vector<double> secs, cpus;
  RunTotals t;
  for (const auto& r : runs) {
    t.mean_accuracy += r.accuracy;
    secs.push_back(r.seconds);
    cpus.push_back(r.cpu_seconds);
  }
  t.mean_accuracy /= static_cast<double>(runs.size());
  t.median_seconds = median(secs);
  t.median_cpu_seconds = median(cpus);
  return t;
}

}  // namespace

std::string peers_summary_line(const std::vector<PeerRun>& runs) {
  const RunTotals t = run_totals(runs);
  char line[256];
  std::snprintf(line, sizeof line, "mean accuracy %.4f over %zu seeds, median fit %.4f s wall, %.4f s CPU\n",
                t.mean_accuracy, runs.size(), t.median_seconds, t.median_cpu_seconds);
  return line;
}

Json peers_json(const PeerSettings& s, const CorpusTable& train, const CorpusTable& held,
                const std::vector<PeerRun>& runs) {
  Json runs_j = Json::array();
  for (const auto& r : runs)
    runs_j.push_back({{"seed", r.seed}, {"accuracy", r.accuracy}, {"class_average", r.class_average},
                      {"seconds", r.seconds}, {"seconds_all", r.seconds_all}, {"cpu_seconds", r.cpu_seconds},
                      {"cpu_seconds_all", r.cpu_seconds_all}, {"nodes", r.nodes}});
  const RunTotals t = run_totals(runs);
  return Json{{"tool", "smseg forest-peers (grow_trees, " + to_string(s.score) + ")"},
              {"train", s.train_csv},
              {"heldout", s.heldout_csv},
              {"rows_train", train.rows()},
              {"rows_heldout", held.rows()},
              {"columns", train.columns},
              {"classes", s.classes},
              {"trees", s.trees},
              {"n_min", s.n_min},
              {"score", to_string(s.score)},
              {"threads", s.threads},
              {"repeat", s.repeat},
              {"runs", runs_j},
              {"mean_accuracy", t.mean_accuracy},
              {"median_seconds", t.median_seconds},
              {"median_cpu_seconds", t.median_cpu_seconds}};
}

}  // namespace smseg::experiments
