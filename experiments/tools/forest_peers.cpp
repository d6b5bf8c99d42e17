// forest-peers: our extremely randomized trees on an exported corpus (train-forest --export-corpus),
// the same way scikit-learn's ExtraTreesClassifier and ranger see it (experiments/peers/): every tree
// is grown with grow_tree on the SAME rows and candidate columns (no bootstrap, no per-tree windows;
// grow_trees, which shares one test-major copy of the values between the trees, is what is timed),
// then the held-out rows are classified (sum of normalised leaf distributions, argmax, ties to the
// lowest class). Reports accuracy and training seconds, wall clock and process CPU (medians of --repeat
// fits; the CSV reading is not timed, as the peers' scripts time the fit only). The CSVs are read line
// by line and the grower reads the training rows in place: one copy of each table in memory.
#include <cstdio>

#include "smseg/common/cli.hpp"
#include "smseg/common/output.hpp"
#include "smseg/common/options.hpp"
#include "smseg/experiments/forest_peers.hpp"

int main(int argc, char** argv) {
  using namespace smseg;
  using namespace smseg::forest;
  CLI::App app{
      "Train our extremely randomized trees on an exported corpus (train-forest --export-corpus) the way\n"
      "scikit-learn's ExtraTreesClassifier and ranger do in experiments/peers/: M trees grown with\n"
      "grow_trees on the same rows and columns (no bootstrap), each seeded by tree_seed(seed, t); then\n"
      "classify the held-out rows (summed normalised leaf distributions, argmax). Both CSVs must have the\n"
      "same header (same candidate columns). Prints and writes accuracy and training seconds (median of\n"
      "--repeat fits, CSV reading not timed) per seed.",
      "forest-peers"};
  experiments::PeerSettings s;
  std::string out, seeds_opt, score_opt = "wehenkel-pavella";
  std::uint64_t seed = 1;
  app.add_option("TRAIN", s.train_csv, "training corpus CSV (label, then one value per candidate)")->required();
  app.add_option("HELDOUT", s.heldout_csv, "held-out corpus CSV with the same header")->required();
  app.add_option("-M,--trees", s.trees, "trees")->capture_default_str()->check(options::in_range(1, 100000));
  app.add_option("--n-min", s.n_min, "nodes with fewer rows become leaves")->capture_default_str()
      ->check(options::in_range(1, 100000000));
  app.add_option("--seed", seed, "forest seed (tree t gets tree_seed(seed, t))")->capture_default_str()
      ->check(options::any_seed())->check(CLI::Validator(kDecimalDigits).description(""));
  app.add_option("--seeds", seeds_opt, "comma-separated forest seeds, one run each (overrides --seed)");
  app.add_option("--repeat", s.repeat, "timed fits per seed; the median is reported")->capture_default_str()
      ->check(options::in_range(1, 1000));
  add_threads_option(app, s.threads, "trees are grown in parallel");
  app.add_option("--classes", s.classes, "number of classes (0: 1 + the largest label in either CSV)")
      ->capture_default_str()->check(options::in_range(0, 65536));
  app.add_option("--score", score_opt, "split score: wehenkel-pavella (the thesis) | information-gain")
      ->capture_default_str();
  app.add_option("-o,--out", out, "result JSON file (default: none)");

  return run_tool(app, argc, argv, s.threads, [&] {
    s.score = as_usage([&] { return score_from_string(score_opt, "--score"); });
    if (!out.empty()) check_output_apart(out, {s.train_csv, s.heldout_csv});
    const std::vector<std::uint64_t> seeds =
        seeds_opt.empty() ? std::vector<std::uint64_t>{seed} : as_usage([&] { return experiments::parse_seeds(seeds_opt); });
    const experiments::CorpusTable train = experiments::read_corpus_table(s.train_csv);
    const experiments::CorpusTable held = experiments::read_corpus_table(s.heldout_csv);
    if (train.header != held.header)
      throw Error(s.heldout_csv, "header",
                  "differs from " + s.train_csv + "'s: the corpora must share their candidate columns");
    s.classes = experiments::peer_classes(train, held, s.classes);
    std::vector<experiments::PeerRun> runs;
    for (const std::uint64_t one : seeds) {
      runs.push_back(experiments::fit_and_score(train, held, s, one));
      std::fputs(experiments::peer_run_line(runs.back(), s.repeat).c_str(), stdout);
    }
    std::fputs(experiments::peers_summary_line(runs).c_str(), stdout);
    if (!out.empty()) write_json_atomic(out, experiments::peers_json(s, train, held, runs));
    return 0;
  });
}
