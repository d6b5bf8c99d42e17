// forest-peers: our extremely randomized trees on an exported corpus (train-forest --export-corpus),
// the same way scikit-learn's ExtraTreesClassifier and ranger see it (experiments/peers/): every tree
// is grown with grow_tree on the SAME rows and candidate columns (no bootstrap, no per-tree windows;
// grow_trees, which shares one test-major copy of the values between the trees, is what is timed),
// then the held-out rows are classified (sum of normalised leaf distributions, argmax, ties to the
// lowest class). Reports accuracy and training seconds, wall clock and process CPU (medians of --repeat
// fits; the CSV reading is not timed, as the peers' scripts time the fit only). The CSVs are read line
// by line and the grower reads the training rows in place: one copy of each table in memory.
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string_view>

#include <tbb/parallel_for.h>

#include "smseg/common/cli.hpp"
#include "smseg/forest/tabular.hpp"
#include "smseg/common/io.hpp"

namespace {

using namespace smseg;
using namespace smseg::forest;

/// A corpus CSV: header "label,<names>", then per row a class index and one float per column.
struct Table {
  std::string header;
  std::size_t columns = 0;
  std::vector<std::uint8_t> labels;
  std::vector<float> values;  // row-major: values[r * columns + c]
  std::size_t rows() const { return labels.size(); }
};

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
void parse_row(std::string_view s, Table& t, const fs::path& path, const std::string& where) {
  const char* p = s.data();
  const char* end = s.data() + s.size();
  int label = 0;
  auto r = std::from_chars(p, end, label);
  if (r.ec != std::errc() || label < 0 || label >= kVoidLabel)
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

// Read line by line (a CamVid-scale corpus is hundreds of MB): memory holds the values, not the text.
Table read_table(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string(), "", "cannot be opened");
  constexpr std::size_t kMaxHeader = std::size_t(64) << 20;
  std::string line;
  if (!read_line(in, line, kMaxHeader, path, "header")) throw Error(path.string(), "header", "no header line");
  Table t;
  t.header = line;
  if (!t.header.empty() && t.header.back() == '\r') t.header.pop_back();
  if (t.header.rfind("label,", 0) != 0)
    throw Error(path.string(), "header", "expected 'label,<candidate names>' (train-forest --export-corpus)");
  t.columns = static_cast<std::size_t>(std::count(t.header.begin(), t.header.end(), ','));
  const std::size_t max_row = 64 + 64 * t.columns;  // a float is at most ~50 characters
  std::error_code ec;
  const std::uintmax_t bytes = fs::is_regular_file(path, ec) ? fs::file_size(path, ec) : 0;
  std::size_t row = 0;
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Train our extremely randomized trees on an exported corpus (train-forest --export-corpus) the way\n"
      "scikit-learn's ExtraTreesClassifier and ranger do in experiments/peers/: M trees grown with\n"
      "grow_trees on the same rows and columns (no bootstrap), each seeded by tree_seed(seed, t); then\n"
      "classify the held-out rows (summed normalised leaf distributions, argmax). Both CSVs must have the\n"
      "same header (same candidate columns). Prints and writes accuracy and training seconds (median of\n"
      "--repeat fits, CSV reading not timed) per seed.",
      "forest-peers"};
  std::string train_csv, heldout_csv, out, seeds_opt, score_opt = "wehenkel-pavella";
  int M = 7, n_min = 5, repeat = 3, threads = 1, classes = 0;
  std::uint64_t seed = 1;
  app.add_option("TRAIN", train_csv, "training corpus CSV (label, then one value per candidate)")->required();
  app.add_option("HELDOUT", heldout_csv, "held-out corpus CSV with the same header")->required();
  app.add_option("-M,--trees", M, "trees")->capture_default_str();
  app.add_option("--n-min", n_min, "nodes with fewer rows become leaves")->capture_default_str();
  app.add_option("--seed", seed, "forest seed (tree t gets tree_seed(seed, t))")->capture_default_str()
      ->check(smseg::kDecimalDigits);
  app.add_option("--seeds", seeds_opt, "comma-separated forest seeds, one run each (overrides --seed)");
  app.add_option("--repeat", repeat, "timed fits per seed; the median is reported")->capture_default_str();
  add_threads_option(app, threads, "trees are grown in parallel");
  app.add_option("--classes", classes, "number of classes (0: 1 + the largest label in either CSV)")
      ->capture_default_str();
  app.add_option("--score", score_opt, "split score: wehenkel-pavella (the thesis) | information-gain")
      ->capture_default_str();
  app.add_option("-o,--out", out, "result JSON file (default: none)");

  return run_tool(app, argc, argv, threads, [&] {
    if (M < 1) throw Error("", "-M", "must be at least 1");
    if (n_min < 1) throw Error("", "--n-min", "must be at least 1");
    if (repeat < 1) throw Error("", "--repeat", "must be at least 1");
    const Score score = score_from_string(score_opt, "--score");
    const std::vector<std::uint64_t> seeds = seeds_opt.empty() ? std::vector<std::uint64_t>{seed} : parse_seeds(seeds_opt);

    Table train = read_table(train_csv);
    const Table held = read_table(heldout_csv);
    if (train.header != held.header)
      throw Error(heldout_csv, "header", "differs from " + train_csv + "'s: the corpora must share their candidate columns");
    int max_label = 0;
    for (auto l : train.labels) max_label = std::max<int>(max_label, l);
    for (auto l : held.labels) max_label = std::max<int>(max_label, l);
    if (classes == 0) classes = max_label + 1;
    if (classes <= max_label) throw Error("", "--classes", "is " + std::to_string(classes) + " but a label is " + std::to_string(max_label));
    // The grower reads the table's rows as they are (no corpus copy, no transposed copy).

    Json runs = Json::array();
    std::vector<double> accs, secs, cpus;
    std::vector<double> acc(static_cast<std::size_t>(classes));
    for (const std::uint64_t s : seeds) {
      std::vector<Tree> trees;
      std::vector<double> times, cpu_times;
      for (int r = 0; r < repeat; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        const std::clock_t c0 = std::clock();  // process CPU time, all threads
        trees = grow_tabular_forest(train.values, train.columns, train.labels, classes, M, n_min, s, score, train_csv);
        cpu_times.push_back(static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
        times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      }
      std::size_t right = 0, nodes = 0;
      std::vector<std::size_t> per_class(static_cast<std::size_t>(classes)), per_class_right(per_class.size());
      for (std::size_t i = 0; i < held.rows(); ++i) {
        const int k = tabular_posterior(trees, held.values.data() + i * held.columns, classes, acc);
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
      for (const auto& t : trees) nodes += t.nodes.size();
      const double accuracy = static_cast<double>(right) / static_cast<double>(held.rows());
      const double sec = median(times), cpu = median(cpu_times);
      accs.push_back(accuracy);
      secs.push_back(sec);
      cpus.push_back(cpu);
      runs.push_back({{"seed", s}, {"accuracy", accuracy}, {"class_average", class_avg}, {"seconds", sec},
                      {"seconds_all", times}, {"cpu_seconds", cpu}, {"cpu_seconds_all", cpu_times}, {"nodes", nodes}});
      std::printf("seed %llu: accuracy %.4f (class-average %.4f), fit %.4f s wall, %.4f s CPU (medians of %d), %zu nodes\n",
                  static_cast<unsigned long long>(s), accuracy, class_avg, sec, cpu, repeat, nodes);
    }
    double mean_acc = 0.0;
    for (double a : accs) mean_acc += a;
    mean_acc /= static_cast<double>(accs.size());
    Json result{{"tool", "smseg forest-peers (grow_trees, " + to_string(score) + ")"},
                {"train", train_csv},
                {"heldout", heldout_csv},
                {"rows_train", train.rows()},
                {"rows_heldout", held.rows()},
                {"columns", train.columns},
                {"classes", classes},
                {"trees", M},
                {"n_min", n_min},
                {"score", to_string(score)},
                {"threads", threads},
                {"repeat", repeat},
                {"runs", runs},
                {"mean_accuracy", mean_acc},
                {"median_seconds", median(secs)},
                {"median_cpu_seconds", median(cpus)}};
    std::printf("mean accuracy %.4f over %zu seeds, median fit %.4f s wall, %.4f s CPU\n", mean_acc, seeds.size(),
                median(secs), median(cpus));
    if (!out.empty()) write_json_atomic(out, result);
    return 0;
  });
}
