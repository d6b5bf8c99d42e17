// eval-forest: label the test frames of work folders with a forest; scores, results.json, pictures.
#include <cmath>
#include <cstdio>
#include <iostream>

#include <tbb/global_control.h>

#include "smseg/cli.hpp"
#include "smseg/eval/evaluate.hpp"

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Evaluate a forest on the labelled frames of one or more work folders (thesis 2.3.4, 3.2.7):\n"
      "each pixel runs through every tree and takes the class of maximum summed leaf distribution,\n"
      "or with --grid B the image is cut into B x B cells and V random pixels of each cell vote.\n"
      "Prints global accuracy, class-average accuracy, mean IoU and the row-normalised confusion\n"
      "matrix; writes OUT/results.json and, per test frame, OUT/frames/NNNNNN_{labels,overlay,error,\n"
      "montage}.png. Void pixels never count.",
      "eval-forest"};
  std::string forest_file, frames = "0:", out;
  std::vector<std::string> works;
  eval::EvalOptions opt;
  int threads = 0;
  bool no_pictures = false, quiet = false;
  app.add_option("FOREST", forest_file, "forest file from train-forest")->required();
  app.add_option("WORK", works, "work folders (from extract-features)")->required();
  app.add_option("--test-frames", frames, "labelled frames to test, A:B half-open (110: = from 110 on)")
      ->capture_default_str();
  app.add_option("--grid", opt.grid, "grid voting cell size B in pixels (0: per pixel)")->capture_default_str();
  app.add_option("--votes", opt.votes, "V: voting pixels per grid cell")->capture_default_str();
  app.add_option("--seed", opt.seed, "seed for where the voting pixels fall")->capture_default_str();
  app.add_option("--threads", threads, "worker threads (0: all cores)")->capture_default_str();
  app.add_flag("--no-pictures", no_pictures, "write results.json only");
  app.add_flag("-q,--quiet", quiet, "no progress and no table on stderr/stdout, just the summary line");
  app.add_option("-o,--out", out, "output folder")->required();
  return run_tool(app, argc, argv, [&] {
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
    opt.frames = features::FrameRange::parse(frames, "--test-frames");
    opt.progress = !quiet;
    if (!no_pictures) opt.pictures = fs::path(out) / "frames";
    opt.validate();
    const forest::Forest f = forest::load_forest(forest_file);
    const std::vector<fs::path> work_paths(works.begin(), works.end());
    const eval::EvalResult r = eval::evaluate(f, work_paths, opt);
    write_json_atomic(fs::path(out) / "results.json", r.to_json(f, opt, works));
    char line[256];
    std::snprintf(line, sizeof line,
                  "%zu test frames: global accuracy %.1f%%, class-average accuracy %.1f%%, mean IoU %.1f%%, "
                  "%.2f ms per frame (%s)",
                  r.frames.size(), 100 * r.confusion.global_accuracy(), 100 * r.confusion.class_average_accuracy(),
                  100 * r.confusion.mean_iou(), 1000 * r.seconds_per_frame,
                  opt.grid > 0 ? ("grid B=" + std::to_string(opt.grid) + " V=" + std::to_string(opt.votes)).c_str()
                               : "per pixel");
    std::cout << line << "\n";
    if (!quiet) {
      std::cout << "\nConfusion matrix (rows: ground truth, columns: output; % of the row):\n"
                << r.confusion.table(f.classes) << "\n";
      std::cout << "results: " << (fs::path(out) / "results.json").string();
      if (!no_pictures) std::cout << "\npictures: " << opt.pictures.string() << "/";
      std::cout << "\n";
    }
    return 0;
  });
}
