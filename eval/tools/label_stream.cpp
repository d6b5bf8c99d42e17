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
  std::string seq_dir, forest_file, out, frames = "0:", cameras, side_by_side;
  eval::StreamOptions opt;
  stacks::ExtractOptions front_end;  // the stereo front end's part, resolved as extract-features does
  eval::StreamOutputOptions output;
  int threads = 0, max_frames = 0, in_flight = 3;
  bool no_labels = false, quiet = false;
  std::string left_cam, right_cam;  // --cameras split
  bool live() const { return !cameras.empty() || !side_by_side.empty(); }
  std::string live_source() const { return side_by_side.empty() ? cameras : side_by_side; }
};

void add_options(CLI::App& app, Args& a) {
  app.add_option("SEQUENCE", a.seq_dir, "stereo or mono sequence folder (holding sequence.json; mono: the visual odometry "
                                        "of extract-features --motion vo); with --cameras or --side-by-side (stereo) "
                                        "only its calibration, camera height, image size and classes are used")
      ->required();
  app.add_option("FOREST", a.forest_file, "forest file from train-forest (trained on --causal stacks of this size)")
      ->required();
  app.add_option("-o,--out", a.out, "output folder")->required();
  app.add_option("--frames", a.frames, "frames of the sequence folder to stream, A:B half-open (the stream starts at A)")
      ->capture_default_str();
  auto* cams = app.add_option("--cameras", a.cameras, "two live sources L,R (camera indices or video files / URLs)");
  app.add_option("--side-by-side", a.side_by_side, "one video (file, URL or camera index) whose frames hold left | right")
      ->excludes(cams);
  app.add_option("--max-frames", a.max_frames, "stop after this many frames of a live source (0: until it ends)")
      ->capture_default_str()->check(options::in_range(0, 1000000000));
  app.add_option("--in-flight", a.in_flight,
                 "frames in the pipeline at once (1: one at a time, the lowest latency; more: higher throughput "
                 "when disparity and keypoints take longer than the rest)")
      ->capture_default_str()
      ->check(options::in_range(1, 16));
  eval::eval_options_table().add_to(app, a.opt.eval, {"grid", "superpixels", "votes", "vote", "trees", "seed"});
  stacks::extract_options_table().add_to(app, a.front_end,
                                           {"stereo", "num_disparities", "block_size", "keypoints", "max_keypoints",
                                            "gftt_quality", "tracker", "min_track_frames", "no_refine", "camera_height",
                                            "focal", "reprojection_threshold", "keyframe_motion", "ba_window"});
  app.add_flag("--no-labels", a.no_labels, "do not write OUT/labels/ (timing the rest alone)");
  app.add_flag("--overlays", a.output.overlays, "also write OUT/overlays/NNNNNN_overlay.png (labels over the left image)");
  app.add_option("--overlay-video", a.output.video, "also write the overlays as one MJPG video OUT/VIDEO (e.g. overlay.avi)");
  app.add_option("--video-fps", a.output.video_fps, "frame rate written in the overlay video")->capture_default_str()
      ->check(options::in_range(0.1, 1000.0));
  app.add_flag("--show", a.output.show, "show the overlay in a window as it is made (q or Esc stops)");
  add_threads_option(app, a.threads, "the labels do not depend on it");
  app.add_flag("-q,--quiet", a.quiet, "only the summary line");
}

// Resolves and checks what the command line gave (UsageError); the frame range for a sequence folder.
stacks::FrameRange validate(Args& a) {
  if (a.front_end.front_end.stereo.method == frontend::StereoMethod::Given)
    throw UsageError("", "--stereo", "given disparities cannot be streamed: use bm or sgbm");
  validate_options(stacks::extract_options_table().option_names(), [&] {
    a.front_end.resolve();
    a.front_end.front_end.validate();
  });
  a.opt.front_end = a.front_end.front_end;
  a.opt.front_end.progress = false;
  a.output.labels = !a.no_labels;
  const std::string& video = a.output.video;
  if (a.max_frames < 0) throw UsageError("", "--max-frames", "must be >= 0");
  if (!(a.output.video_fps > 0 && a.output.video_fps <= 1000)) throw UsageError("", "--video-fps", "must be in (0, 1000]");
  if (!video.empty() && fs::path(video).filename() != fs::path(video))
    throw UsageError("", "--overlay-video", "is a file name inside OUT, not a path: '" + video + "'");
  as_usage([&] { a.opt.eval.validate(); });
  const stacks::FrameRange range = as_usage([&] { return stacks::FrameRange::parse(a.frames, "--frames"); });
  if (!a.cameras.empty()) {
    const auto comma = a.cameras.find(',');
    if (comma == std::string::npos || comma == 0 || comma + 1 == a.cameras.size())
      throw UsageError("", "--cameras", "expected two sources L,R, got '" + a.cameras + "'");
    a.left_cam = a.cameras.substr(0, comma);
    a.right_cam = a.cameras.substr(comma + 1);
  }
  return range;
}

// A mono sequence: the causal visual odometry (extract-features --motion vo's) instead of stereo.
void use_visual_odometry(Args& a, const sequence::Sequence& seq) {
  if (a.live())
    throw UsageError(seq.manifest.string(), a.cameras.empty() ? "--side-by-side" : "--cameras",
                     "live sources are stereo pairs; this sequence is mono");
  a.opt.mono = stacks::visual_odometry_options(a.front_end);
  a.opt.mono->progress = false;
}

std::unique_ptr<eval::FrameSource> open_source(const Args& a, const sequence::Sequence& seq,
                                               const stacks::FrameRange& range) {
  if (a.live())
    return std::make_unique<eval::VideoFrames>(a.side_by_side.empty() ? a.left_cam : a.side_by_side, a.right_cam,
                                               seq.size, a.max_frames);
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
  eval::StreamWriter writer(replacement.staging(), a.out, seq, a.output);
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);

  eval::StageLog log;
  eval::StreamRun run{a.live() ? (a.side_by_side.empty() ? "cameras " + a.cameras : "side-by-side " + a.side_by_side)
                               : fs::absolute(seq.root).string(),
                      a.forest_file, seq.size};
  run.threads = a.threads;
  run.in_flight = a.in_flight;
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
      static_cast<std::size_t>(a.in_flight));
  run.seconds = ms_since(wall0) / 1000;
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
