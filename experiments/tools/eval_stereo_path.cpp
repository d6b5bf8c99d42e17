// eval-stereo-path: accuracy of a front end's output (WORK/tracks.json, from the stereo front end or
// from monocular structure from motion, `extract-features --motion sfm`) against a synthetic sequence's
// ground truth: absolute trajectory error (rigid and similarity alignment) as metres and as a share of
// the path length, relative pose error per frame pair, and the relative depth error of the tracked
// points. For SfM work folders it also repeats what the SfM reported (focal length and its source,
// reprojection RMS, key frames, posed / still / bridged frames).
#include <cstdio>

#include <opencv2/imgcodecs.hpp>

#include "smseg/common/cli.hpp"
#include "smseg/common/output.hpp"
#include "smseg/experiments/eval_stereo_path.hpp"

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{"Accuracy of the front end (stereo or monocular SfM) against a synthetic sequence's ground truth: absolute\n"
               "trajectory error (camera centres, rigid and similarity Umeyama alignment) in metres and as a\n"
               "share of the ground-truth path length, relative pose error per frame pair, and the median\n"
               "relative depth error of the tracked points (WORK/tracks.json) against the ground-truth depth.",
               "eval-stereo-path"};
  std::string seq_path, work, out, plot_path;
  app.add_option("sequence", seq_path, "sequence folder (or its sequence.json), with ground-truth poses and depth")
      ->required();
  app.add_option("work", work, "work folder holding tracks.json (or the tracks file itself)")->required();
  app.add_option("-o,--output", out, "result JSON file (default: none, report on stdout only)");
  app.add_option("--plot", plot_path, "top-down PNG of both paths (red: ground truth, black: estimate)");
  return run_tool(app, argc, argv, [&] {
    for (const auto& [output, option] : {std::pair{out, "-o"}, std::pair{plot_path, "--plot"}})
      if (!output.empty()) check_output_apart(output, {seq_path, work}, option);
    const experiments::StereoPathEvaluation e = experiments::evaluate_stereo_path(seq_path, work);
    std::fputs(experiments::stereo_path_report(e).c_str(), stdout);
    if (!out.empty()) write_json_atomic(out, experiments::stereo_path_json(e));
    if (!plot_path.empty()) sequence::write_image_atomic(plot_path, experiments::stereo_path_plot(e, 700));
    return 0;
  });
}
