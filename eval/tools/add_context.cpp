// add-context: work folders whose stacks also hold a forest's class posteriors, for an auto-context
// second forest (context.hpp).
#include <cstdio>
#include <iostream>

#include "smseg/common/cli.hpp"
#include "smseg/common/options.hpp"
#include "smseg/common/output.hpp"
#include "smseg/eval/context.hpp"

namespace {

smseg::Json report_json(const smseg::eval::ContextReport& r, const std::string& forest,
                        const std::vector<std::string>& works, const std::vector<smseg::fs::path>& outs, int folds) {
  smseg::Json folders = smseg::Json::array();
  for (std::size_t i = 0; i < works.size(); ++i)
    folders.push_back({{"source", works[i]}, {"out", outs[i].filename().string()}});
  return {{"format", "smseg-context"},
          {"version", 1},
          {"forest", forest},
          {"folds", folds},
          {"frames_per_fold", r.frames_per_fold},
          {"frames_written", r.frames_written},
          {"out_of_fold_frames", r.out_of_fold_frames},
          {"train_seconds", r.train_seconds},
          {"label_seconds", r.label_seconds},
          {"work_folders", folders}};
}

}  // namespace

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Auto-context: write, for each work folder, a work folder OUT/<its name> whose stacks hold the\n"
      "forest's features (or --features) and one channel per class, fCtx:<class>, the forest's posterior\n"
      "of that class at each pixel. OUT stores only the new channels: it reads the others, the greyscale\n"
      "and the labels from WORK, which its stacks.json names with a digest (WORK moved or extracted again\n"
      "makes OUT refused: run add-context again). train-forest and eval-forest on those folders\n"
      "give a second forest whose windows read the first one's output around each pixel.\n"
      "Training folders need --folds K: their labelled frames are cut into K contiguous folds and each\n"
      "fold gets the posteriors of a forest trained, with FOREST's parameters and features, on the other\n"
      "folds only, so that no frame's posteriors have seen its own labels (the second forest would trust\n"
      "them too much). Test folders: without --folds, FOREST labels every frame. Frames without labels\n"
      "always get FOREST's posteriors. OUT is built beside itself and swapped in whole at the end.\n"
      "See docs/camvid.md, \"Auto-context\".",
      "add-context"};
  std::string forest_file, frames = "0:", keep, out;
  std::vector<std::string> works;
  eval::ContextOptions opt;
  int threads = 0;
  bool quiet = false;
  app.add_option("FOREST", forest_file, "the first forest (train-forest); its parameters train the fold forests")
      ->required();
  app.add_option("WORK", works, "work folders (from extract-features)")->required();
  app.add_option("--folds", opt.folds,
                 "out-of-fold posteriors for training folders: K >= 2 contiguous folds of the labelled frames "
                 "(0: FOREST labels every frame, for test folders)")
      ->capture_default_str()->check(smseg::options::in_range(0, 1000000));
  app.add_option("--frames", frames, "frames written (and, with --folds, trained on), A:B half-open")
      ->capture_default_str();
  app.add_option("--features", keep, "comma-separated features copied besides the context channels (default: FOREST's)");
  app.add_option("--memory-mb", opt.memory_mb, "memory budget of each fold forest's training in MiB (train-forest's)")
      ->check(smseg::options::in_range<std::size_t>(1, std::size_t{1} << 30))  // 1 MiB .. 1 PiB
      ->capture_default_str();
  add_threads_option(app, threads, "the output does not depend on it");
  app.add_flag("-q,--quiet", quiet, "no progress on stderr");
  app.add_option("-o,--out", out, "output folder: OUT/<name of each WORK>/ and OUT/context.json")->required();
  return run_tool(app, argc, argv, threads, [&] {
    if (opt.folds == 1) throw UsageError("", "--folds", "is 1: out of fold needs at least 2 folds (0: no folds)");
    opt.frames = stacks::FrameRange::parse(frames, "--frames");
    opt.keep = smseg::split_comma_list(keep);
    opt.progress = !quiet;
    const OutputLock one_writer(out, paths_of(works, {forest_file}));
    const forest::Forest forest = forest::load_forest(forest_file);
    FolderReplacement replacement(out);
    const std::vector<fs::path> outs = folders_by_name(works, replacement.staging());
    const eval::ContextReport r =
        eval::add_context(forest, forest_file, std::vector<fs::path>(works.begin(), works.end()), outs, opt);
    write_json_atomic(replacement.staging() / "context.json", report_json(r, forest_file, works, outs, opt.folds));
    replacement.commit();
    char line[256];
    std::snprintf(line, sizeof line, "%d frames of %zu work folders with %zu context channels (%s) in %.1f s -> %s\n",
                  r.frames_written, works.size(), forest.classes.size(),
                  opt.folds ? (std::to_string(r.out_of_fold_frames) + " out of " + std::to_string(opt.folds) + " folds")
                                  .c_str()
                            : "from the forest",
                  r.train_seconds + r.label_seconds, out.c_str());
    std::cout << line;
    return 0;
  });
}
