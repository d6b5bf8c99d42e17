#pragma once
// label-stream's surroundings of the streamed labeller (stream.hpp): where the stereo pairs come from
// (a sequence folder, two cameras or a side-by-side video), what is written per frame (labels,
// overlays, an overlay video, a window), the per-stage timing log and the run's summary.json.

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "smseg/common/io.hpp"
#include "smseg/eval/stream.hpp"
#include "smseg/sequence/sequence.hpp"
#include "smseg/stacks/stack.hpp"

namespace smseg::eval {

/// Stereo pairs from wherever frames come from: index is the sequence's frame number (counted from 0
/// for live sources); left_bgr is filled only when pictures need it.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual bool next(StreamInput& pair, bool want_colour) = 0;  ///< false at the end
};

/// The frames [range) of a stereo sequence folder; Error (option --frames) when it selects none.
class SequenceFrames : public FrameSource {
 public:
  SequenceFrames(const sequence::Sequence& seq, const stacks::FrameRange& range);
  bool next(StreamInput& pair, bool want_colour) override;

 private:
  const sequence::Sequence& seq_;
  int next_ = 0, end_ = 0;
};

/// Live or recorded video: two captures (left, right) or, when `right` is empty, one side-by-side
/// video (left half | right half). Each is a camera index ("0") or a file / URL, as cv::VideoCapture
/// takes them. Frames must be `size` (a side-by-side frame twice as wide); at most `max_frames` (0: all).
class VideoFrames : public FrameSource {
 public:
  VideoFrames(const std::string& left, const std::string& right, cv::Size size, int max_frames);
  bool next(StreamInput& pair, bool want_colour) override;

 private:
  cv::VideoCapture left_, right_;
  std::string name_;
  bool side_by_side_ = false;
  cv::Size size_;
  int max_frames_ = 0, count_ = 0;
};

/// Per-stage milliseconds of every frame, and their summary.
struct StageLog {
  std::vector<std::string> names = {"read", "disparity", "keypoints", "tracking", "motion", "features", "classify", "write"};
  std::vector<std::vector<double>> ms = std::vector<std::vector<double>>(8);
  std::vector<double> latency;

  static double median(std::vector<double> v);
  static double mean(const std::vector<double>& v);
  void add(const StreamStageTimes& t, double write, double total);
  /// {stage: {"mean", "median"}} in milliseconds.
  Json stages() const;
  /// The latency below which the fraction q of frames lie (q = 1: the largest).
  double latency_quantile(double q) const;
};

/// What label-stream writes of each labelled frame, inside the output's staging folder.
struct StreamOutputOptions {
  bool labels = true;    ///< labels/NNNNNN_labels.png
  bool overlays = false; ///< overlays/NNNNNN_overlay.png
  std::string video;     ///< an MJPG overlay video of this file name (empty: none)
  double video_fps = 15;
  bool show = false;     ///< a window showing each overlay
};

/// label-stream's own options: where its frames come from and what it writes (the stereo front end's
/// and the voting's are extract_options_table's and eval_options_table's).
struct LabelStreamOptions {
  std::string frames = "0:";  ///< frames of the sequence folder, A:B half-open
  std::string cameras;        ///< two live sources "L,R" (camera indices or video files / URLs)
  std::string side_by_side;   ///< one video whose frames hold left | right
  int max_frames = 0;         ///< of a live source (0: until it ends)
  int in_flight = 3;          ///< frames in the pipeline at once
  bool no_labels = false;     ///< write no labels/ (output.labels = false)
  StreamOutputOptions output;
};

/// LabelStreamOptions' fields, declared once (options.hpp): label-stream's options of its own.
const options::Table<LabelStreamOptions>& label_stream_options_table();

class StreamWriter {
 public:
  /// Makes the folders under `staging`; Error naming `out`/video when the video cannot be written.
  StreamWriter(const std::filesystem::path& staging, const std::filesystem::path& out, const sequence::Sequence& seq,
               const StreamOutputOptions& options);
  /// Whether the pairs need their colour image (for overlays).
  bool needs_colour() const { return colour_; }
  /// Writes one frame's outputs; false when the window's user asked to stop (q or Esc).
  bool write(const StreamInput& pair, const cv::Mat& labels);
  /// Finishes the video.
  void close() { video_.release(); }

 private:
  std::filesystem::path staging_;
  const sequence::Sequence& seq_;
  StreamOutputOptions options_;
  cv::VideoWriter video_;
  bool colour_ = false;
};

/// The run's facts for summary.json besides the stage log.
struct StreamRun {
  std::string source;  ///< "cameras L,R", "side-by-side V" or the sequence folder
  std::string forest_file;
  cv::Size image_size;
  int first_frame = -1, last_frame = -1;
  int threads = 0, in_flight = 0;
  double seconds = 0;
  bool stopped_by_user = false;
  /// Frames whose front end tracked no point (black, blank or featureless images): labelled from the
  /// class prior alone, which the report says.
  int frames_without_points = 0;
  double disparity_offset = 0;  ///< pixels the front end added to every disparity (self-calibrated with auto)
};

/// label-stream's summary.json ("smseg-label-stream", version 1).
Json stream_summary(const StreamRun& run, const StreamOptions& options, const StageLog& log);

/// The lines label-stream prints: the rate and latency line, then unless `quiet` the milliseconds per
/// stage and where the labels and summary are.
std::vector<std::string> stream_report_lines(const StreamRun& run, const StageLog& log, const std::filesystem::path& out,
                                             bool quiet);

}  // namespace smseg::eval
