// label-stream's frame sources, per-frame outputs, stage log and summary (stream_output.hpp).
#include "smseg/eval/stream_output.hpp"

#include <algorithm>
#include <cstdio>
#include <numeric>

#include <opencv2/highgui.hpp>
#include <opencv2/imgproc.hpp>

#include "smseg/common/error.hpp"
#include "smseg/common/options.hpp"
#include "smseg/eval/render.hpp"
#include "smseg/frontend/tracks_io.hpp"

namespace smseg::eval {

namespace fs = std::filesystem;

const options::Table<LabelStreamOptions>& label_stream_options_table() {
  static const options::Table<LabelStreamOptions> table = [] {
    options::Table<LabelStreamOptions> t("label_stream", options::kCommandLine);
    t.text("frames", "--frames", "frames of the sequence folder to stream, A:B half-open (the stream starts at A)",
           [](auto& o) -> auto& { return o.frames; });
    t.text("cameras", "--cameras", "two live sources L,R (camera indices or video files / URLs)",
           [](auto& o) -> auto& { return o.cameras; });
    t.text("side_by_side", "--side-by-side", "one video (file, URL or camera index) whose frames hold left | right",
           [](auto& o) -> auto& { return o.side_by_side; });
    t.number("max_frames", "--max-frames", "stop after this many frames of a live source (0: until it ends)",
             [](auto& o) -> auto& { return o.max_frames; }, 0, 1000000000);
    t.number("in_flight", "--in-flight",
             "frames in the pipeline at once (1: one at a time, the lowest latency; more: higher throughput "
             "when a frame's parallel work (disparity, keypoints, feature tables, forest) takes longer than "
             "its tracking)",
             [](auto& o) -> auto& { return o.in_flight; }, 1, 16);
    t.flag("no_labels", "--no-labels", "do not write OUT/labels/ (timing the rest alone)",
           [](auto& o) -> auto& { return o.no_labels; });
    t.flag("overlays", "--overlays", "also write OUT/overlays/NNNNNN_overlay.png (labels over the left image)",
           [](auto& o) -> auto& { return o.output.overlays; });
    t.text("overlay_video", "--overlay-video",
           "also write the overlays as one MJPG video OUT/VIDEO (e.g. overlay.avi)",
           [](auto& o) -> auto& { return o.output.video; });
    t.number("video_fps", "--video-fps", "frame rate written in the overlay video",
             [](auto& o) -> auto& { return o.output.video_fps; }, 0.1, 1000.0);
    t.flag("show", "--show", "show the overlay in a window as it is made (q or Esc stops)",
           [](auto& o) -> auto& { return o.output.show; });
    return t;
  }();
  return table;
}

namespace {

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

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

std::string stem(int frame) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%06d", frame);
  return buf;
}

}  // namespace

SequenceFrames::SequenceFrames(const sequence::Sequence& seq, const stacks::FrameRange& range) : seq_(seq) {
  next_ = std::max(0, range.begin);
  end_ = std::min(seq.frame_count(), range.end);
  if (next_ >= end_)
    throw Error("", "--frames", range.str() + " selects none of the " + std::to_string(seq.frame_count()) +
                                         " frames of " + seq.manifest.string());
}

bool SequenceFrames::next(StreamInput& p, bool want_colour) {
  if (next_ >= end_) return false;
  p.index = next_++;
  p.left = seq_.load_left_gray(p.index);
  p.right = seq_.kind == sequence::SequenceKind::Stereo ? seq_.load_right_gray(p.index) : cv::Mat();
  p.left_bgr = want_colour ? seq_.load_left(p.index) : cv::Mat();
  return true;
}

VideoFrames::VideoFrames(const std::string& left, const std::string& right, cv::Size size, int max_frames)
    : size_(size), max_frames_(max_frames) {
  name_ = right.empty() ? left : left + " + " + right;
  left_ = open_capture(left, right.empty() ? "--side-by-side" : "--cameras");
  if (!right.empty()) right_ = open_capture(right, "--cameras");
  side_by_side_ = right.empty();
}

bool VideoFrames::next(StreamInput& p, bool) {
  if (max_frames_ > 0 && count_ >= max_frames_) return false;
  cv::Mat l, r;
  if (!left_.read(l) || l.empty()) return false;
  if (side_by_side_) {
    if (l.cols % 2 != 0 || cv::Size(l.cols / 2, l.rows) != size_)
      throw Error(name_, "frame " + std::to_string(count_),
                  "is " + size_text(l.cols, l.rows) + ", a side-by-side pair of " +
                      size_text(size_.width, size_.height) + " images must be " +
                      size_text(2 * size_.width, size_.height));
    r = l(cv::Rect(size_.width, 0, size_.width, size_.height)).clone();
    l = l(cv::Rect(0, 0, size_.width, size_.height)).clone();
  } else if (!right_.read(r) || r.empty()) {
    return false;
  }
  if (l.size() != size_ || r.size() != size_)
    throw Error(name_, "frame " + std::to_string(count_),
                "the cameras give " + size_text(l.cols, l.rows) + " and " + size_text(r.cols, r.rows) +
                    ", the calibration is for " + size_text(size_.width, size_.height));
  p.index = count_++;
  p.left_bgr = l.channels() == 3 ? l : cv::Mat();
  if (p.left_bgr.empty()) cv::cvtColor(l, p.left_bgr, cv::COLOR_GRAY2BGR);
  p.left = to_gray(l);
  p.right = to_gray(r);
  return true;
}

double StageLog::median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double StageLog::mean(const std::vector<double>& v) {
  return v.empty() ? 0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

void StageLog::add(const StreamStageTimes& t, double write, double total) {
  const double v[8] = {t.read, t.front_end.disparity, t.front_end.keypoints, t.front_end.tracking,
                       t.front_end.motion, t.features, t.classify, write};
  for (int k = 0; k < 8; ++k) ms[k].push_back(v[k]);
  latency.push_back(total);
}

Json StageLog::stages() const {
  Json j = Json::object();
  for (std::size_t k = 0; k < names.size(); ++k) j[names[k]] = {{"mean", mean(ms[k])}, {"median", median(ms[k])}};
  return j;
}

double StageLog::latency_quantile(double q) const {
  if (latency.empty()) return 0;
  std::vector<double> v = latency;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

StreamWriter::StreamWriter(const fs::path& staging, const fs::path& out, const sequence::Sequence& seq,
                           const StreamOutputOptions& options)
    : staging_(staging), seq_(seq), options_(options) {
  if (options.labels) fs::create_directories(staging / "labels");
  if (options.overlays) fs::create_directories(staging / "overlays");
  if (!options.video.empty() && !video_.open((staging / options.video).string(),
                                             cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), options.video_fps, seq.size))
    throw Error((out / options.video).string(), "--overlay-video", "cannot be written (MJPG)");
  colour_ = options.overlays || options.show || video_.isOpened();
}

bool StreamWriter::write(const StreamInput& pair, const cv::Mat& labels) {
  const std::string base = stem(pair.index);
  cv::Mat coloured;
  if (options_.labels || colour_) coloured = sequence::colour_labels(labels, seq_);
  if (options_.labels) sequence::write_image_atomic(staging_ / "labels" / (base + "_labels.png"), coloured);
  if (!colour_) return true;
  const cv::Mat over = overlay(pair.left_bgr, coloured);
  if (options_.overlays) sequence::write_image_atomic(staging_ / "overlays" / (base + "_overlay.png"), over);
  if (video_.isOpened()) video_.write(over);
  if (!options_.show) return true;
  cv::imshow("label-stream", over);
  const int key = cv::waitKey(1);
  return !(key == 'q' || key == 27);
}

Json stream_summary(const StreamRun& run, const StreamOptions& options, const StageLog& log) {
  const int n = static_cast<int>(log.latency.size());
  return {{"format", "smseg-label-stream"},
          {"version", 1},
          {"source", run.source},
          {"forest", run.forest_file},
          {"frames", n},
          {"first_frame", run.first_frame},
          {"last_frame", run.last_frame},
          {"image_size", {{"width", run.image_size.width}, {"height", run.image_size.height}}},
          {"mode", options.eval.mode()},
          {"grid", options.eval.grid},
          {"superpixels", options.eval.superpixels},
          {"votes", options.eval.votes},
          {"threads", run.threads},
          {"in_flight", run.in_flight},
          {"front_end", options.mono ? Json{{"method", "vo"}, {"vo", sfm::sfm_options_to_json(*options.mono)}}
                                     : frontend::front_end_options_to_json(options.front_end)},
          {"disparity_offset_px", run.disparity_offset},
          {"seconds", run.seconds},
          {"frames_per_second", n / run.seconds},
          {"latency_ms_median", log.latency_quantile(0.5)},
          {"latency_ms_p90", log.latency_quantile(0.9)},
          {"latency_ms_max", log.latency_quantile(1.0)},
          {"stage_ms", log.stages()},
          {"stopped_by_user", run.stopped_by_user},
          {"frames_without_points", run.frames_without_points}};
}

std::vector<std::string> stream_report_lines(const StreamRun& run, const StageLog& log, const fs::path& out,
                                             bool quiet) {
  const int n = static_cast<int>(log.latency.size());
  char line[256];
  std::snprintf(line, sizeof line, "%d frames in %.2f s: %.1f frames per second, latency median %.1f ms (p90 %.1f ms)",
                n, run.seconds, n / run.seconds, log.latency_quantile(0.5), log.latency_quantile(0.9));
  std::vector<std::string> lines = {line};
  if (quiet) return lines;
  std::string stages = "milliseconds per frame (mean / median):";
  for (std::size_t k = 0; k < log.names.size(); ++k) {
    std::snprintf(line, sizeof line, " %s %.2f/%.2f", log.names[k].c_str(), StageLog::mean(log.ms[k]),
                  StageLog::median(log.ms[k]));
    stages += line;
  }
  lines.push_back(stages);
  lines.push_back("labels: " + (out / "labels").string() + "/, summary: " + (out / "summary.json").string());
  return lines;
}

}  // namespace smseg::eval
