// train-forest: extremely randomized trees over sampling windows, trained on feature stacks.
#include <iostream>
#include <optional>
#include <sstream>

#include "smseg/common/cli.hpp"
#include "smseg/common/option_names.hpp"
#include "smseg/common/options.hpp"
#include "smseg/common/output.hpp"
#include "smseg/stacks/stack.hpp"
#include "smseg/forest/classify.hpp"
#include "smseg/forest/slurm_train.hpp"
#include "smseg/forest/train.hpp"
#include "smseg/common/slurm.hpp"
#include "smseg/common/slurm_cli.hpp"

namespace {

int report(const smseg::forest::Forest& f, const std::string& what, const std::string& out) {
  int nodes = 0;
  for (const auto& t : f.stats.trees) nodes += t.nodes;
  std::cout << "trained " << f.trees.size() << " trees (" << nodes << " nodes, "
            << nodes / std::max<std::size_t>(1, f.trees.size()) << " per tree) in " << f.stats.seconds << " s "
            << what << " -> " << out << "\n";
  return 0;
}

int save_and_report(const smseg::forest::Forest& f, const std::string& out, const std::string& what) {
  smseg::forest::save_forest(f, out);
  return report(f, what, out);
}

/// train-forest --merge PART... -o OUT
int merge_parts(const std::vector<std::string>& parts, const std::vector<std::string>& works,
                const std::string& tree_range, bool on_slurm, const std::string& out) {
  using smseg::UsageError;
  if (!works.empty()) throw UsageError("", "--merge", "takes forest parts, not work folders (no training)");
  if (!tree_range.empty() || on_slurm) throw UsageError("", "--merge", "not with --trees or --slurm");
  const smseg::forest::Forest f =
      smseg::forest::merge_forest_parts(std::vector<smseg::fs::path>(parts.begin(), parts.end()));
  smseg::forest::save_forest(f, out);
  std::cout << "merged " << parts.size() << " parts (" << f.trees.size() << " trees) -> " << out << "\n";
  return 0;
}

void check_slurm_options(const smseg::forest::SlurmTraining& slurm, const smseg::forest::TrainParams& p,
                         const std::string& tree_range, const std::string& corpus) {
  using smseg::UsageError;
  if (!tree_range.empty()) throw UsageError("", "--trees", "not with --slurm (it splits the trees itself, see --tasks)");
  if (!corpus.empty()) throw UsageError("", "--export-corpus", "not with --slurm; export it with a local run");
  if (slurm.tasks != 0) smseg::as_usage([&] { return smseg::forest::split_trees(p.M, slurm.tasks, "--tasks"); });
  if (!(slurm.mode.poll_seconds > 0.0)) throw UsageError("", "--poll", "must be a positive number of seconds");
}

/// This run's arguments for an array task: the same, without the options the task gets its own way.
std::vector<std::string> task_args(int argc, char** argv) {
  return smseg::slurm::without_options(std::vector<std::string>(argv + 1, argv + argc), {"--slurm", "-q", "--quiet", "--no-wait", "--slurm-dry-run"},
                                       {"--tasks", "--slurm-dir", "--slurm-arg", "--poll", "-o", "--out", "--trees"});
}

/// Frames without a tracked point teach the trees nothing but the class prior: with none in any
/// training frame (a camera that does not move, blank frames) the forest would be single leaves, so
/// training stops; with some, a warning names them.
void check_points(const smseg::stacks::StackSet& set, bool quiet) {
  const auto empty = smseg::stacks::frames_without_points(set);
  if (empty.empty()) return;
  const std::string which = smseg::stacks::frames_without_points_message(set, empty);
  if (empty.size() == set.dataset.frames.size())
    throw smseg::Error("", "", which + ": no training frame holds a tracked point (a camera that does not move? blank "
                                       "frames?), so there is nothing to learn; no forest written");
  if (!quiet) std::cerr << "train-forest: warning: " << which << "; they teach the trees only the class prior\n";
}

struct Args {
  std::vector<std::string> works;
  std::string frames = "0:", features_opt, learned_from, out, corpus;
  smseg::forest::TrainParams p;
  int threads = 0, corpus_tree = 0;
  bool quiet = false, mirror = false;
  std::vector<double> exposures;
  std::string tree_range;
  std::vector<std::string> merge;
  smseg::forest::SlurmTraining slurm;
  bool on_slurm = false;
  std::string slurm_dir;
  bool no_wait = false;
};

void add_options(CLI::App& app, Args& a) {
  using namespace smseg;
  app.add_option("WORK", a.works, "work folders (from extract-features); frames of all are pooled (not with --merge)");
  app.add_option("--train-frames", a.frames, "labelled frames used for training, A:B half-open (0:101 = first 101)")
      ->capture_default_str();
  forest::train_params_table().add_to(app, a.p);
  app.add_option("--trees", a.tree_range,
                 "train only trees A..B-1 of the M (A:B half-open; A: = up to M) and write a forest part, for --merge");
  app.add_option("--merge", a.merge, "join these forest parts (from --trees) into the forest -o; no training")
      ->expected(1, -1);
  slurm::add_options(app,
                     {"train as a Slurm job array (sbatch) and a gather job that merges the parts into -o; wait for both",
                      "array tasks, each training a range of trees (1..M; 0: one per tree)",
                      "job folder (job.sh, logs/, parts/), kept; a rerun submits only missing parts (default: OUT.slurm)",
                      "-o"},
                     a.on_slurm, a.slurm.tasks, a.slurm_dir, a.slurm.sbatch_options, a.no_wait, a.slurm.mode);
  app.add_option("--features", a.features_opt, "comma-separated features to use (default: all in the stacks)");
  app.add_flag("--mirror", a.mirror,
               "also train on every frame mirrored left to right (its channels mirrored as they would be: fOx "
               "negated, fG1 and fG3 swapped, fCol kept; texton channels refused)");
  app.add_option("--exposures", a.exposures,
                 "also train on every frame (and mirror) as the camera would have seen it with each of these "
                 "fractions of the light, comma-separated (Lab and gradient channels mapped "
                 "as exposure maps them, geometry kept; texton and auto-context channels refused)")
      ->delimiter(',')
      ->check(smseg::options::in_range(0.01, 0.99));
  app.add_option("--learned-from", a.learned_from, "comma-separated forest files whose chosen windows --windows learned follows");
  add_threads_option(app, a.threads, "the forest does not depend on it");
  app.add_option("--export-corpus", a.corpus, "also write the training corpus of one tree as CSV (label, then every candidate's value)");
  app.add_option("--corpus-tree", a.corpus_tree, "which tree's corpus --export-corpus writes (0..M-1)")->capture_default_str()
      ->check(options::in_range(0, 99999));
  app.add_flag("-q,--quiet", a.quiet, "no progress on stderr");
  app.add_option("-o,--out", a.out, "forest file to write (JSON; a forest part with --trees)")->required();
}

/// What the training frames are given with: " and their mirrors", " at exposures 1, 0.5", both or "".
std::string copies_said(const Args& a) {
  std::string said = a.mirror ? " and their mirrors" : "";
  if (a.exposures.empty()) return said;
  said += " at exposures 1";
  for (double k : a.exposures) {
    std::ostringstream number;
    number << k;
    said += ", " + number.str();
  }
  return said;
}

/// --windows learned: the windows the --learned-from forests chose.
void resolve_learned_windows(Args& a) {
  using namespace smseg;
  if (a.p.windows.mode == forest::WindowSampling::Learned) {
    const auto files = smseg::split_comma_list(a.learned_from);
    if (files.empty()) throw Error("", "--learned-from", "--windows learned needs the forests to learn from");
    std::vector<forest::Forest> earlier;
    for (const auto& f : files) earlier.push_back(forest::load_forest(f));
    a.p.windows.learned = forest::learned_windows(earlier);
  } else if (!a.learned_from.empty()) {
    throw Error("", "--learned-from", "only with --windows learned");
  }
}

/// Checks the training options (UsageError / Error naming the option); the tree range of --trees.
std::optional<smseg::forest::TreeRange> check_training_options(Args& a, const smseg::OptionNames& option_of) {
  using namespace smseg;
  if (a.works.empty()) throw UsageError("", "WORK", "name at least one work folder (or --merge parts)");
  if (!a.on_slurm && (a.slurm.tasks != 0 || !a.slurm_dir.empty() || !a.slurm.sbatch_options.empty() || a.no_wait ||
                      a.slurm.mode.dry_run))
    throw UsageError("", "--tasks, --slurm-dir, --slurm-arg, --no-wait, --slurm-dry-run", "only with --slurm");
  resolve_learned_windows(a);
  a.p.progress = !a.quiet;
  validate_options(option_of, [&] { a.p.validate(""); });
  if (!a.on_slurm) forest::Classifier::default_simd_target();  // a bad SMSEG_SIMD before the stacks are read
  if (!a.corpus.empty() && (a.corpus_tree < 0 || a.corpus_tree >= a.p.M))
    throw UsageError("", "--corpus-tree", "is " + std::to_string(a.corpus_tree) + ", expected 0.." + std::to_string(a.p.M - 1));
  std::optional<forest::TreeRange> trees;
  if (!a.tree_range.empty()) trees = as_usage([&] { return forest::TreeRange::parse(a.tree_range, "--trees", a.p.M); });
  as_usage([&] { stacks::check_exposures(a.exposures, "--exposures"); });
  if (a.on_slurm) check_slurm_options(a.slurm, a.p, a.tree_range, a.corpus);
  return trees;
}

/// The training frames of the work folders, checked for tracked points.
smseg::stacks::StackSet open_training_stacks(const Args& a) {
  using namespace smseg;
  const auto range = stacks::FrameRange::parse(a.frames, "--train-frames");
  stacks::StackSet set = stacks::open_stacks(std::vector<fs::path>(a.works.begin(), a.works.end()), range, true,
                                                 true, smseg::split_comma_list(a.features_opt));
  check_points(set, a.quiet);
  stacks::lighten_frames(set, a.p.lightness);  // before mirrors and darker copies: they copy it
  if (a.mirror && a.on_slurm)  // the tasks mirror their own frames: here only whether every channel can be
    stacks::mirror_plan(set.dataset.features, set.manifests.front().manifest_path().string());
  else if (a.mirror)
    stacks::add_mirrored_frames(set);
  if (a.on_slurm)  // likewise: whether every channel can be darkened
    for (double k : a.exposures) stacks::exposure_plan(set.dataset.features, k, set.manifests.front().manifest_path().string());
  else if (!a.exposures.empty())
    stacks::add_exposed_frames(set, a.exposures);
  if (!a.quiet)
    std::cerr << "train-forest: " << set.origin.size() << " labelled frames" << copies_said(a) << ", "
              << set.dataset.features.size() << " features, K=" << a.p.K << " M=" << a.p.M << "\n";
  return set;
}

/// --slurm: the data checked here, trained there.
int train_on_slurm(Args& a, const std::string& on_frames, int argc, char** argv) {
  using namespace smseg;
  a.slurm.program = slurm::current_executable();
  a.slurm.args = task_args(argc, argv);
  a.slurm.params = a.p;
  a.slurm.dir = a.slurm_dir.empty() ? fs::path(a.out + ".slurm") : fs::path(a.slurm_dir);
  a.slurm.out = a.out;
  a.slurm.mode.wait = !a.no_wait;
  a.slurm.mode.progress = !a.quiet;
  if (!forest::train_forest_slurm(a.slurm)) return 0;  // dry run, or the gather job will write -o
  return report(forest::load_forest(a.out), "of training " + on_frames + ", Slurm job folder " + a.slurm.dir.string(),
                a.out);
}

/// What a training reads, which -o must not overwrite: the work folders and their manifests, the parts
/// to merge, the forests --learned-from follows.
std::vector<smseg::fs::path> training_inputs(const Args& a) {
  std::vector<smseg::fs::path> inputs;
  for (const auto& w : a.works) inputs.insert(inputs.end(), {smseg::fs::path(w), smseg::fs::path(w) / "stacks.json"});
  inputs.insert(inputs.end(), a.merge.begin(), a.merge.end());
  for (const auto& f : smseg::split_comma_list(a.learned_from)) inputs.push_back(f);
  return inputs;
}

int train(Args& a, const smseg::OptionNames& option_of, int argc, char** argv) {
  using namespace smseg;
  // The forest (whole, a part or merged) is written atomically; what killed runs of this host left
  // between write and rename goes now. Temporaries of live runs (other Slurm tasks writing parts into
  // the same folder) and of other hosts are left alone.
  if (!a.out.empty()) remove_stale_temporaries(fs::absolute(a.out).parent_path());
  std::optional<OutputLock> one_writer;  // not the Slurm submitter: its gather job writes -o
  if (!a.on_slurm) one_writer.emplace(a.out, training_inputs(a));
  if (!a.merge.empty()) return merge_parts(a.merge, a.works, a.tree_range, a.on_slurm, a.out);
  const std::optional<forest::TreeRange> trees = check_training_options(a, option_of);
  const stacks::StackSet set = open_training_stacks(a);
  const std::string on_frames =
      "on " + std::to_string(set.origin.size()) + " frames" + copies_said(a);
  if (a.on_slurm) return train_on_slurm(a, on_frames, argc, argv);
  if (!a.corpus.empty()) forest::export_corpus_csv(set.dataset, a.p, a.corpus_tree, a.corpus);
  if (trees) {
    const forest::Forest part = forest::train_forest_trees(set.dataset, a.p, *trees);
    forest::save_forest_part(part, *trees, a.out, stacks::training_data_record(set));
    return report(part, "trees " + trees->to_string() + " of " + std::to_string(a.p.M) + " " + on_frames, a.out);
  }
  return save_and_report(forest::train_forest(set.dataset, a.p), a.out, on_frames);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Train a forest of extremely randomized trees (Geurts et al. 2006; thesis 2.3.3, 3.2.4) on the\n"
      "labelled frames of one or more work folders made by extract-features. Each tree draws Ks\n"
      "sampling windows and Kt tests (labelled pixels); the candidate attributes are all (window,\n"
      "feature) pairs, plus the four texton tests at Ks offsets with --textons. Same seed, same forest,\n"
      "whatever the thread count and however the trees are shared out: --trees A:B trains only trees\n"
      "A..B-1 into a forest part, --merge joins parts into the forest, and --slurm does both as a Slurm\n"
      "job array (one task per range of trees) followed by a gather job that merges the parts into -o;\n"
      "paths must be on a file system the nodes share. See docs/distributed.md.",
      "train-forest"};
  Args args;
  add_options(app, args);
  const OptionNames option_of = forest::train_params_table().option_names();
  return run_tool(app, argc, argv, args.threads,
                  [&] { return naming_options(option_of, [&] { return train(args, option_of, argc, argv); }); });
}
