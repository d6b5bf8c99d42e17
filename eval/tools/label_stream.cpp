// label-stream: label a stereo or monocular video as it comes, frame by frame (the on-line labeller of
// the thesis's future work): the stereo front end (or, on a mono sequence, the causal visual odometry),
// causal features and the forest per frame, no stack on disk.
#include <csignal>
#include <iostream>
#include <memory>

#include <opencv2/core/utils/logger.hpp>

#include "smseg/common/cli.hpp"
#include "smseg/common/options.hpp"
#include "smseg/common/option_names.hpp"
#include "smseg/common/output.hpp"
#include "smseg/eval/stream.hpp"
#include "smseg/eval/stream_output.hpp"
#include "smseg/stacks/extract.hpp"

namespace {

using namespace smseg;
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

volatile std::sig_atomic_t g_stop = 0;  // SIGINT / SIGTERM: finish the frame, write the summary, stop
extern "C" void on_stop_signal(int) { g_stop = 1; }

struct Args {
  std::string seq_dir, forest_file, out;
  eval::LabelStreamOptions own;      // sources and outputs
  eval::StreamOptions opt;
  stacks::ExtractOptions front_end;  // the stereo front end's part, resolved as extract-features does
  int threads = 0;
  bool quiet = false;
  std::string left_cam, right_cam;  // --cameras split
  bool live() const { return !own.cameras.empty() || !own.side_by_side.empty(); }
  std::string live_source() const { return own.side_by_side.empty() ? own.cameras : own.side_by_side; }
};

void add_options(CLI::App& app, Args& a) {
  app.add_option("SEQUENCE", a.seq_dir, "stereo or mono sequence folder (holding sequence.json; mono: the visual odometry "
                                        "of extract-features --motion vo); with --cameras or --side-by-side (stereo) "
                                        "only its calibration, camera height, image size and classes are used")
      ->required();
  app.add_option("FOREST", a.forest_file, "forest file from train-forest (trained on --causal stacks of this size)")
      ->required();
  app.add_option("-o,--out", a.out, "output folder")->required();
  const auto& own = eval::label_stream_options_table();
  own.add_to(app, a.own, {"frames", "cameras", "side_by_side", "max_frames", "in_flight"});
  app.get_option("--side-by-side")->excludes("--cameras");
  eval::eval_options_table().add_to(app, a.opt.eval, {"grid", "superpixels", "votes", "vote", "trees", "seed"});
  stacks::extract_options_table().add_to(app, a.front_end,
                                           {"stereo", "num_disparities", "block_size", "lr_check", "keypoints", "max_keypoints",
                                            "gftt_quality", "tracker", "min_track_frames", "no_refine", "camera_height",
                                            "disparity_offset", "focal", "reprojection_threshold", "keyframe_motion",
                                            "ba_window"});
  own.add_to(app, a.own, {"no_labels", "overlays", "overlay_video", "video_fps", "show"});
  add_threads_option(app, a.threads, "the labels do not depend on it");
  app.add_flag("-q,--quiet", a.quiet, "only the summary line");
}

// Resolves and checks what the command line gave (UsageError); the frame range for a sequence folder.
stacks::FrameRange validate(Args& a) {
  if (a.front_end.front_end.stereo.method == frontend::StereoMethod::Given)
    throw UsageError("", "--stereo", "given disparities cannot be streamed: use bm, sparse or sgbm");
  validate_options(stacks::extract_options_table().option_names(), [&] {
    a.front_end.resolve();
    a.front_end.front_end.validate();
  });
  a.opt.front_end = a.front_end.front_end;
  a.opt.front_end.progress = false;
  a.own.output.labels = !a.own.no_labels;
  const std::string& video = a.own.output.video;
  if (a.own.max_frames < 0) throw UsageError("", "--max-frames", "must be >= 0");
  if (!(a.own.output.video_fps > 0 && a.own.output.video_fps <= 1000))
    throw UsageError("", "--video-fps", "must be in (0, 1000]");
  if (!video.empty() && fs::path(video).filename() != fs::path(video))
    throw UsageError("", "--overlay-video", "is a file name inside OUT, not a path: '" + video + "'");
  as_usage([&] { a.opt.eval.validate(); });
  const stacks::FrameRange range = as_usage([&] { return stacks::FrameRange::parse(a.own.frames, "--frames"); });
  const std::string& cameras = a.own.cameras;
  if (!cameras.empty()) {
    const auto comma = cameras.find(',');
    if (comma == std::string::npos || comma == 0 || comma + 1 == cameras.size())
      throw UsageError("", "--cameras", "expected two sources L,R, got '" + cameras + "'");
    a.left_cam = cameras.substr(0, comma);
    a.right_cam = cameras.substr(comma + 1);
  }
  return range;
}

// A mono sequence: the causal visual odometry (extract-features --motion vo's) instead of stereo.
void use_visual_odometry(Args& a, const sequence::Sequence& seq) {
  if (a.live())
    throw UsageError(seq.manifest.string(), a.own.cameras.empty() ? "--side-by-side" : "--cameras",
                     "live sources are stereo pairs; this sequence is mono");
  a.opt.mono = stacks::visual_odometry_options(a.front_end);
  a.opt.mono->progress = false;
}

std::unique_ptr<eval::FrameSource> open_source(const Args& a, const sequence::Sequence& seq,
                                               const stacks::FrameRange& range) {
  if (a.live())
    return std::make_unique<eval::VideoFrames>(a.own.side_by_side.empty() ? a.left_cam : a.own.side_by_side,
                                               a.right_cam, seq.size, a.own.max_frames);
  return std::make_unique<eval::SequenceFrames>(seq, range);
}

int label_stream(Args& a) {
  // OpenCV's video back ends log every failed attempt; the tool says what failed in one line.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  const stacks::FrameRange range = validate(a);
  const OutputLock one_writer(a.out, {a.seq_dir, a.forest_file});
  const sequence::Sequence seq = sequence::load_sequence(a.seq_dir);
  if (seq.kind == sequence::SequenceKind::Mono) use_visual_odometry(a, seq);
  const forest::Forest forest = forest::load_forest(a.forest_file);
  eval::StreamLabeller labeller(forest, a.forest_file, seq.calibration, seq.camera_height, seq.size, a.opt,
                                seq.manifest.string());
  const std::unique_ptr<eval::FrameSource> source = open_source(a, seq, range);
  FolderReplacement replacement(a.out);
  eval::StreamWriter writer(replacement.staging(), a.out, seq, a.own.output);
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);

  eval::StageLog log;
  eval::StreamRun run{a.live() ? (a.own.side_by_side.empty() ? "cameras " + a.own.cameras
                                                               : "side-by-side " + a.own.side_by_side)
                               : fs::absolute(seq.root).string(),
                      a.forest_file, seq.size};
  run.threads = a.threads;
  run.in_flight = a.own.in_flight;
  const auto wall0 = Clock::now();
  eval::run_stream(
      labeller, [&](eval::StreamInput& in) { return !g_stop && source->next(in, writer.needs_colour()); },
      [&](const eval::StreamInput& in, const cv::Mat& labels, const eval::StreamStageTimes& times) {
        const auto tw = Clock::now();
        if (!writer.write(in, labels)) g_stop = 1;
        log.add(times, ms_since(tw), ms_since(in.arrived));
        if (labeller.last_frame().observations.empty()) ++run.frames_without_points;
        if (run.first_frame < 0) run.first_frame = in.index;
        run.last_frame = in.index;
      },
      static_cast<std::size_t>(a.own.in_flight));
  run.seconds = ms_since(wall0) / 1000;
  run.disparity_offset = labeller.disparity_offset();
  writer.close();
  if (log.latency.empty()) throw Error(a.live() ? a.live_source() : a.seq_dir, "", "gave no frame");
  run.stopped_by_user = g_stop != 0;
  write_json_atomic(replacement.staging() / "summary.json", eval::stream_summary(run, a.opt, log));
  replacement.commit();
  for (const std::string& line : eval::stream_report_lines(run, log, a.out, a.quiet)) std::cout << line << "\n";
  if (run.frames_without_points > 0)
    std::cerr << "label-stream: warning: " << run.frames_without_points << " of " << log.latency.size()
              << " frames had no tracked point (black, blank or featureless images?); they are labelled from the class "
                 "prior alone\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Label a stereo or monocular video frame by frame, as it comes (on-line use): per frame the stereo\n"
      "front end (disparity, keypoints followed from the previous frame, camera motion) or, on a mono\n"
      "sequence, the causal visual odometry of extract-features --motion vo (KLT tracks, PnP, local bundle\n"
      "adjustment, scale from the camera height above the ground; needs --focal or the manifest's fx), the\n"
      "causal structure-and-motion features in memory (what extract-features --causal computes; no stack\n"
      "is written) and the forest, per pixel or by grid or superpixel voting (as eval-forest). Frames come\n"
      "from a sequence folder, or live from two cameras (--cameras L,R) or a side-by-side video\n"
      "(--side-by-side), whose calibration and camera height are then the SEQUENCE folder's. Writes\n"
      "OUT/labels/NNNNNN_labels.png (class colours), optionally OUT/overlays/ and an overlay video, and\n"
      "OUT/summary.json (frames per second, latency, milliseconds per stage); OUT is built beside itself\n"
      "and swapped in whole at the end. Ctrl-C stops after the current frame and still writes everything.",
      "label-stream"};
  Args args;
  add_options(app, args);
  return run_tool(app, argc, argv, args.threads, [&] { return label_stream(args); });
}
