// train-forest: extremely randomized trees over sampling windows, trained on feature stacks.
#include <iostream>
#include <sstream>

#include <tbb/global_control.h>

#include "smseg/cli.hpp"
#include "smseg/features/stack.hpp"
#include "smseg/forest/train.hpp"

namespace {

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Train a forest of extremely randomized trees (Geurts et al. 2006; thesis 2.3.3, 3.2.4) on the\n"
      "labelled frames of one or more work folders made by extract-features. Each tree draws Ks\n"
      "sampling windows and Kt tests (labelled pixels); the candidate attributes are all (window,\n"
      "feature) pairs, plus the four texton tests at Ks offsets with --textons. Same seed, same forest,\n"
      "whatever the thread count.",
      "train-forest"};
  std::vector<std::string> works;
  std::string frames = "0:", features_opt, windows = "uniform", learned_from, balance = "none", out, corpus;
  forest::TrainParams p;
  int threads = 0, corpus_tree = 0;
  bool quiet = false;
  app.add_option("WORK", works, "work folders (from extract-features); frames of all are pooled")->required();
  app.add_option("--train-frames", frames, "labelled frames used for training, A:B half-open (0:101 = first 101)")
      ->capture_default_str();
  app.add_option("-K", p.K, "sets Ks = Kt (thesis 400)")->capture_default_str();
  app.add_option("--Ks", p.Ks, "sampling windows per tree (default: K)");
  app.add_option("--Kt", p.Kt, "tests (training pixels) per tree (default: K)");
  app.add_option("-M,--trees", p.M, "number of trees")->capture_default_str();
  app.add_option("--n-min", p.n_min, "nodes with fewer tests become leaves")->capture_default_str();
  app.add_option("--seed", p.seed, "random seed (each tree derives its own from it)")->capture_default_str();
  app.add_option("--features", features_opt, "comma-separated features to use (default: all in the stacks)");
  app.add_flag("--textons", p.textons, "add the texton tests fP, fPs, fPd, fPda on the greyscale image");
  app.add_option("--windows", windows, "window sampling: uniform | thesis-biased | learned (thesis 4.5.3)")
      ->capture_default_str();
  app.add_option("--learned-from", learned_from, "comma-separated forest files whose chosen windows --windows learned follows");
  app.add_option("--balance", balance, "none | classes: draw tests per class so no class swamps the rest")
      ->capture_default_str();
  std::string score = "wehenkel-pavella";
  app.add_option("--score", score, "split score: wehenkel-pavella (the thesis) | information-gain")
      ->capture_default_str();
  app.add_option("--memory-mb", p.memory_mb, "memory budget of training in MiB: trees are built in batches that fit; refused if one tree does not")
      ->capture_default_str();
  app.add_option("--threads", threads, "worker threads (0: all cores); the forest does not depend on it")
      ->capture_default_str();
  app.add_option("--export-corpus", corpus, "also write the training corpus of one tree as CSV (label, then every candidate's value)");
  app.add_option("--corpus-tree", corpus_tree, "which tree's corpus --export-corpus writes")->capture_default_str();
  app.add_flag("-q,--quiet", quiet, "no progress on stderr");
  app.add_option("-o,--out", out, "forest file to write (JSON)")->required();

  return run_tool(app, argc, argv, [&] {
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
    p.windows.mode = forest::window_sampling_from_string(windows, "--windows");
    p.balance = forest::balance_from_string(balance, "--balance");
    p.score = forest::score_from_string(score, "--score");
    if (p.windows.mode == forest::WindowSampling::Learned) {
      const auto files = split_list(learned_from);
      if (files.empty()) throw Error("", "--learned-from", "--windows learned needs the forests to learn from");
      std::vector<forest::Forest> earlier;
      for (const auto& f : files) earlier.push_back(forest::load_forest(f));
      p.windows.learned = forest::learned_windows(earlier);
    } else if (!learned_from.empty()) {
      throw Error("", "--learned-from", "only with --windows learned");
    }
    p.progress = !quiet;
    p.validate("train-forest");
    const auto range = features::FrameRange::parse(frames, "--train-frames");
    const features::StackSet set = features::open_stacks(
        std::vector<fs::path>(works.begin(), works.end()), range, true, true, split_list(features_opt));
    if (!quiet)
      std::cerr << "train-forest: " << set.dataset.frames.size() << " labelled frames, "
                << set.dataset.features.size() << " features, K=" << p.K << " M=" << p.M << "\n";
    if (!corpus.empty()) forest::export_corpus_csv(set.dataset, p, corpus_tree, corpus);
    forest::Forest f = forest::train_forest(set.dataset, p);
    forest::save_forest(f, out);
    int nodes = 0;
    for (const auto& t : f.stats.trees) nodes += t.nodes;
    std::cout << "trained " << f.trees.size() << " trees (" << nodes << " nodes, "
              << nodes / std::max<std::size_t>(1, f.trees.size()) << " per tree) in " << f.stats.seconds
              << " s on " << set.dataset.frames.size() << " frames -> " << out << "\n";
    return 0;
  });
}
