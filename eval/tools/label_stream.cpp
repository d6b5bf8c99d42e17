// label-stream: label a stereo video as it comes, frame by frame (the on-line labeller of the thesis's
// future work): the stereo front end, causal features and the forest per frame, no stack on disk.
#include <algorithm>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <numeric>

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/highgui.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "smseg/common/cli.hpp"
#include "smseg/common/options.hpp"
#include "smseg/common/option_names.hpp"
#include "smseg/common/output.hpp"
#include "smseg/eval/render.hpp"
#include "smseg/eval/stream.hpp"
#include "smseg/frontend/tracks_io.hpp"
#include "smseg/stacks/extract.hpp"

namespace {

using namespace smseg;
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

volatile std::sig_atomic_t g_stop = 0;  // SIGINT / SIGTERM: finish the frame, write the summary, stop
extern "C" void on_stop_signal(int) { g_stop = 1; }

// Stereo pairs from wherever frames come from: index is the sequence's frame number (counted from 0
// for live sources); left_bgr is filled only when pictures need it.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual bool next(eval::StreamInput& pair, bool want_colour) = 0;  // false at the end
};

// The frames of a stereo sequence folder.
class SequenceFrames : public FrameSource {
 public:
  SequenceFrames(const features::Sequence& seq, const features::FrameRange& range) : seq_(seq) {
    next_ = std::max(0, range.begin);
    end_ = std::min(seq.frame_count(), range.end);
    if (next_ >= end_)
      throw Error("", "--frames", range.str() + " selects none of the " + std::to_string(seq.frame_count()) +
                                           " frames of " + seq.manifest.string());
  }
  bool next(eval::StreamInput& p, bool want_colour) override {
    if (next_ >= end_) return false;
    p.index = next_++;
    p.left = seq_.load_left_gray(p.index);
    p.right = seq_.load_right_gray(p.index);
    p.left_bgr = want_colour ? seq_.load_left(p.index) : cv::Mat();
    return true;
  }

 private:
  const features::Sequence& seq_;
  int next_ = 0, end_ = 0;
};

// A camera index ("0") or a file / URL, as cv::VideoCapture takes them.
cv::VideoCapture open_capture(const std::string& what, const std::string& option) {
  cv::VideoCapture cap;
  const bool index = !what.empty() && std::all_of(what.begin(), what.end(), ::isdigit);
  const bool file = !index && what.find("://") == std::string::npos && what.find('%') == std::string::npos;
  std::error_code ec;
  if (file && !fs::is_regular_file(what, ec)) throw Error(what, option, "no such video file");
  const bool ok = index ? cap.open(std::stoi(what)) : cap.open(what);
  if (!ok || !cap.isOpened()) throw Error(what, option, "cannot be opened as a video source");
  return cap;
}

cv::Mat to_gray(const cv::Mat& bgr) {
  cv::Mat g;
  if (bgr.channels() == 1) return bgr;
  cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
  return g;
}

// Live or recorded video: two captures (left, right) or one side-by-side video (left half | right half).
class VideoFrames : public FrameSource {
 public:
  VideoFrames(const std::string& left, const std::string& right, cv::Size size, int max_frames)
      : size_(size), max_frames_(max_frames) {
    name_ = right.empty() ? left : left + " + " + right;
    left_ = open_capture(left, right.empty() ? "--side-by-side" : "--cameras");
    if (!right.empty()) right_ = open_capture(right, "--cameras");
    side_by_side_ = right.empty();
  }
  bool next(eval::StreamInput& p, bool) override {
    if (max_frames_ > 0 && count_ >= max_frames_) return false;
    cv::Mat l, r;
    if (!left_.read(l) || l.empty()) return false;
    if (side_by_side_) {
      if (l.cols % 2 != 0 || cv::Size(l.cols / 2, l.rows) != size_)
        throw Error(name_, "frame " + std::to_string(count_),
                    "is " + std::to_string(l.cols) + "x" + std::to_string(l.rows) + ", a side-by-side pair of " +
                        std::to_string(size_.width) + "x" + std::to_string(size_.height) + " images must be " +
                        std::to_string(2 * size_.width) + "x" + std::to_string(size_.height));
      r = l(cv::Rect(size_.width, 0, size_.width, size_.height)).clone();
      l = l(cv::Rect(0, 0, size_.width, size_.height)).clone();
    } else if (!right_.read(r) || r.empty()) {
      return false;
    }
    if (l.size() != size_ || r.size() != size_)
      throw Error(name_, "frame " + std::to_string(count_),
                  "the cameras give " + std::to_string(l.cols) + "x" + std::to_string(l.rows) + " and " +
                      std::to_string(r.cols) + "x" + std::to_string(r.rows) + ", the calibration is for " +
                      std::to_string(size_.width) + "x" + std::to_string(size_.height));
    p.index = count_++;
    p.left_bgr = l.channels() == 3 ? l : cv::Mat();
    if (p.left_bgr.empty()) cv::cvtColor(l, p.left_bgr, cv::COLOR_GRAY2BGR);
    p.left = to_gray(l);
    p.right = to_gray(r);
    return true;
  }

 private:
  cv::VideoCapture left_, right_;
  std::string name_;
  bool side_by_side_ = false;
  cv::Size size_;
  int max_frames_ = 0, count_ = 0;
};

// Per-stage milliseconds of every frame, and their summary.
struct StageLog {
  std::vector<std::string> names = {"read", "disparity", "keypoints", "tracking", "motion", "features", "classify", "write"};
  std::vector<std::vector<double>> ms = std::vector<std::vector<double>>(8);
  std::vector<double> latency;

  static double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  }
  static double mean(const std::vector<double>& v) {
    return v.empty() ? 0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  }
  void add(const eval::StreamStageTimes& t, double write, double total) {
    const double v[8] = {t.read, t.front_end.disparity, t.front_end.keypoints, t.front_end.tracking,
                         t.front_end.motion, t.features, t.classify, write};
    for (int k = 0; k < 8; ++k) ms[k].push_back(v[k]);
    latency.push_back(total);
  }
  Json stages() const {
    Json j = Json::object();
    for (std::size_t k = 0; k < names.size(); ++k) j[names[k]] = {{"mean", mean(ms[k])}, {"median", median(ms[k])}};
    return j;
  }
  double latency_quantile(double q) const {
    if (latency.empty()) return 0;
    std::vector<double> v = latency;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
  }
};

std::string stem(int frame) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%06d", frame);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Label a stereo video frame by frame, as it comes (on-line use): per frame the stereo front end\n"
      "(disparity, keypoints followed from the previous frame, camera motion), the causal structure-and-\n"
      "motion features in memory (what extract-features --causal computes; no stack is written) and the\n"
      "forest, per pixel or by grid or superpixel voting (as eval-forest). Frames come from a stereo\n"
      "sequence folder, or live from two cameras (--cameras L,R) or a side-by-side video (--side-by-side),\n"
      "whose calibration and camera height are then the SEQUENCE folder's. Writes OUT/labels/NNNNNN_labels.png\n"
      "(class colours), optionally OUT/overlays/ and an overlay video, and OUT/summary.json (frames per\n"
      "second, latency, milliseconds per stage); OUT is built beside itself and swapped in whole at the end.\n"
      "Ctrl-C stops after the current frame and still writes everything.",
      "label-stream"};
  std::string seq_dir, forest_file, out, frames = "0:", cameras, side_by_side, video;
  eval::StreamOptions opt;
  features::ExtractOptions front_end;  // the stereo front end's part, resolved as extract-features does
  int threads = 0, max_frames = 0, in_flight = 3;
  double video_fps = 15;
  bool no_labels = false, overlays = false, show = false, quiet = false;
  app.add_option("SEQUENCE", seq_dir, "stereo sequence folder (holding sequence.json); with --cameras or --side-by-side "
                                      "only its calibration, camera height, image size and classes are used")
      ->required();
  app.add_option("FOREST", forest_file, "forest file from train-forest (trained on --causal stacks of this size)")
      ->required();
  app.add_option("-o,--out", out, "output folder")->required();
  app.add_option("--frames", frames, "frames of the sequence folder to stream, A:B half-open (the stream starts at A)")
      ->capture_default_str();
  auto* cams = app.add_option("--cameras", cameras, "two live sources L,R (camera indices or video files / URLs)");
  app.add_option("--side-by-side", side_by_side, "one video (file, URL or camera index) whose frames hold left | right")
      ->excludes(cams);
  app.add_option("--max-frames", max_frames, "stop after this many frames of a live source (0: until it ends)")
      ->capture_default_str();
  app.add_option("--in-flight", in_flight,
                 "frames in the pipeline at once (1: one at a time, the lowest latency; more: higher throughput "
                 "when disparity and keypoints take longer than the rest)")
      ->capture_default_str()
      ->check(CLI::Range(1, 16));
  eval::eval_options_table().add_to(app, opt.eval, {"grid", "superpixels", "votes", "vote", "trees", "seed"});
  features::extract_options_table().add_to(app, front_end,
                                           {"stereo", "num_disparities", "block_size", "keypoints", "max_keypoints",
                                            "gftt_quality", "tracker", "min_track_frames", "no_refine", "camera_height"});
  app.add_flag("--no-labels", no_labels, "do not write OUT/labels/ (timing the rest alone)");
  app.add_flag("--overlays", overlays, "also write OUT/overlays/NNNNNN_overlay.png (labels over the left image)");
  app.add_option("--overlay-video", video, "also write the overlays as one MJPG video OUT/VIDEO (e.g. overlay.avi)");
  app.add_option("--video-fps", video_fps, "frame rate written in the overlay video")->capture_default_str();
  app.add_flag("--show", show, "show the overlay in a window as it is made (q or Esc stops)");
  add_threads_option(app, threads, "the labels do not depend on it");
  app.add_flag("-q,--quiet", quiet, "only the summary line");
  return run_tool(app, argc, argv, threads, [&] {
    // OpenCV's video back ends log every failed attempt; the tool says what failed in one line.
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    if (front_end.front_end.stereo.method == features::StereoMethod::Given)
      throw UsageError("", "--stereo", "given disparities cannot be streamed: use bm or sgbm");
    validate_options(features::extract_options_table().option_names(), [&] {
      front_end.resolve();
      front_end.front_end.validate();
    });
    opt.front_end = front_end.front_end;
    opt.front_end.progress = false;
    if (max_frames < 0) throw UsageError("", "--max-frames", "must be >= 0");
    if (!(video_fps > 0 && video_fps <= 1000)) throw UsageError("", "--video-fps", "must be in (0, 1000]");
    if (!video.empty() && fs::path(video).filename() != fs::path(video))
      throw UsageError("", "--overlay-video", "is a file name inside OUT, not a path: '" + video + "'");
    as_usage([&] { opt.eval.validate(); });
    const features::FrameRange range = as_usage([&] { return features::FrameRange::parse(frames, "--frames"); });
    std::string left_cam, right_cam;
    if (!cameras.empty()) {
      const auto comma = cameras.find(',');
      if (comma == std::string::npos || comma == 0 || comma + 1 == cameras.size())
        throw UsageError("", "--cameras", "expected two sources L,R, got '" + cameras + "'");
      left_cam = cameras.substr(0, comma);
      right_cam = cameras.substr(comma + 1);
    }
    const bool live = !cameras.empty() || !side_by_side.empty();

    const features::Sequence seq = features::load_sequence(seq_dir);
    if (!live && seq.kind != features::SequenceKind::Stereo)
      throw Error(seq.manifest.string(), "kind", "label-stream needs a stereo sequence; this one is mono");
    const forest::Forest forest = forest::load_forest(forest_file);
    eval::StreamLabeller labeller(forest, forest_file, seq.calibration, seq.camera_height, seq.size, opt,
                                  seq.manifest.string());
    std::unique_ptr<FrameSource> source;
    if (live)
      source = std::make_unique<VideoFrames>(side_by_side.empty() ? left_cam : side_by_side, right_cam, seq.size,
                                             max_frames);
    else
      source = std::make_unique<SequenceFrames>(seq, range);

    FolderReplacement replacement(out);
    const fs::path staging = replacement.staging();
    if (!no_labels) fs::create_directories(staging / "labels");
    if (overlays) fs::create_directories(staging / "overlays");
    cv::VideoWriter writer;
    if (!video.empty() &&
        !writer.open((staging / video).string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), video_fps, seq.size))
      throw Error((fs::path(out) / video).string(), "--overlay-video", "cannot be written (MJPG)");
    const bool colour = overlays || show || writer.isOpened();
    auto write_outputs = [&](const eval::StreamInput& pair, const cv::Mat& labels) {
      const std::string base = stem(pair.index);
      cv::Mat coloured;
      if (!no_labels || colour) coloured = features::colour_labels(labels, seq);
      if (!no_labels) features::write_image_atomic(staging / "labels" / (base + "_labels.png"), coloured);
      if (!colour) return;
      const cv::Mat over = eval::overlay(pair.left_bgr, coloured);
      if (overlays) features::write_image_atomic(staging / "overlays" / (base + "_overlay.png"), over);
      if (writer.isOpened()) writer.write(over);
      if (show) {
        cv::imshow("label-stream", over);
        const int key = cv::waitKey(1);
        if (key == 'q' || key == 27) g_stop = 1;
      }
    };
    std::signal(SIGINT, on_stop_signal);
    std::signal(SIGTERM, on_stop_signal);

    StageLog log;
    const auto wall0 = Clock::now();
    int first = -1, last = -1;
    eval::run_stream(
        labeller, [&](eval::StreamInput& in) { return !g_stop && source->next(in, colour); },
        [&](const eval::StreamInput& in, const cv::Mat& labels, const eval::StreamStageTimes& times) {
          const auto tw = Clock::now();
          write_outputs(in, labels);
          log.add(times, ms_since(tw), ms_since(in.arrived));
          if (first < 0) first = in.index;
          last = in.index;
        },
        static_cast<std::size_t>(in_flight));
    const double wall_s = ms_since(wall0) / 1000;
    writer.release();
    const int n = static_cast<int>(log.latency.size());
    if (n == 0) throw Error(live ? (side_by_side.empty() ? cameras : side_by_side) : seq_dir, "", "gave no frame");
    const double fps = n / wall_s;
    Json summary = {{"format", "smseg-label-stream"},
                    {"version", 1},
                    {"source", live ? (side_by_side.empty() ? "cameras " + cameras : "side-by-side " + side_by_side)
                                    : fs::absolute(seq.root).string()},
                    {"forest", forest_file},
                    {"frames", n},
                    {"first_frame", first},
                    {"last_frame", last},
                    {"image_size", {{"width", seq.size.width}, {"height", seq.size.height}}},
                    {"mode", opt.eval.mode()},
                    {"grid", opt.eval.grid},
                    {"superpixels", opt.eval.superpixels},
                    {"votes", opt.eval.votes},
                    {"threads", threads},
                    {"in_flight", in_flight},
                    {"front_end", features::front_end_options_to_json(opt.front_end)},
                    {"seconds", wall_s},
                    {"frames_per_second", fps},
                    {"latency_ms_median", log.latency_quantile(0.5)},
                    {"latency_ms_p90", log.latency_quantile(0.9)},
                    {"latency_ms_max", log.latency_quantile(1.0)},
                    {"stage_ms", log.stages()},
                    {"stopped_by_user", g_stop != 0}};
    write_json_atomic(staging / "summary.json", summary);
    replacement.commit();
    char line[256];
    std::snprintf(line, sizeof line, "%d frames in %.2f s: %.1f frames per second, latency median %.1f ms (p90 %.1f ms)",
                  n, wall_s, fps, log.latency_quantile(0.5), log.latency_quantile(0.9));
    std::cout << line << "\n";
    if (!quiet) {
      std::cout << "milliseconds per frame (mean / median):";
      for (std::size_t k = 0; k < log.names.size(); ++k) {
        std::snprintf(line, sizeof line, " %s %.2f/%.2f", log.names[k].c_str(), StageLog::mean(log.ms[k]),
                      StageLog::median(log.ms[k]));
        std::cout << line;
      }
      std::cout << "\nlabels: " << (fs::path(out) / "labels").string() << "/, summary: "
                << (fs::path(out) / "summary.json").string() << "\n";
    }
    return 0;
  });
}
