#pragma once
// Labelling a live stream (label-stream): each stereo pair goes through the stereo front end one frame
// at a time (frontend/stream.hpp), or each image of a monocular video through the causal visual
// odometry (sfm/mono_stream.hpp, StreamOptions::mono), its causal feature stack is made in memory
// (stacks/stream_features.hpp: no stack file is written) and the forest labels it per pixel or by
// grid or superpixel voting (label_frame). With the same options its labels are those of
// `extract-features --causal` + `eval-forest` on the same frames (tests/eval/test_label_stream.cpp).

#include <chrono>
#include <functional>
#include <optional>
#include <string>

#include <opencv2/core.hpp>
#include <tbb/enumerable_thread_specific.h>

#include "smseg/eval/evaluate.hpp"
#include "smseg/frontend/stream.hpp"
#include "smseg/sfm/mono_stream.hpp"
#include "smseg/stacks/stream_features.hpp"

namespace smseg::eval {

struct StreamOptions {
  frontend::FrontEndOptions front_end;  ///< the stereo front end (as extract-features takes it)
  EvalOptions eval;                     ///< per pixel, grid or superpixel voting, smoothing; frames and pictures unused
  /// Set: a monocular stream, the visual odometry with these options (extract-features --motion vo's,
  /// stacks::visual_odometry_options) instead of the stereo front end; heights from the ground under
  /// each camera (the vo front end's HeightReference::Camera).
  std::optional<sfm::SfmOptions> mono;
};

/// Milliseconds of each stage of one frame.
struct StreamStageTimes {
  double read = 0;      ///< the source's time to give the pair
  frontend::StreamFrontEndTimes front_end;
  double features = 0;  ///< point attributes, rasters and summed-area tables
  double classify = 0;  ///< regions, classification, voting and smoothing (label_frame)
};

class StreamLabeller {
 public:
  /// The forest must have been trained on `size` frames and read only the structure-and-motion
  /// features (and textons, from the left image); Error naming `forest_file` otherwise. Calibration
  /// and camera height as StereoFrontEndStream needs them (Error naming `source`).
  StreamLabeller(const forest::Forest& forest, const std::string& forest_file, const sequence::Calibration& calibration,
                 std::optional<double> camera_height, cv::Size size, const StreamOptions& options,
                 const std::string& source);

  /// The first half of a frame's work, which needs no earlier frame (disparity, keypoints): thread-safe,
  /// so that a pipeline prepares the next pairs while label() runs (8-bit grey images; a monocular
  /// stream ignores right_gray).
  frontend::StereoFrontEndStream::Prepared prepare(const cv::Mat& left_gray, const cv::Mat& right_gray) const;

  /// One frame after the in-order half of its work (tracking, motion, its points' causal attributes):
  /// all classify() needs.
  struct Tracked {
    cv::Mat left;   ///< the prepared 8-bit grey left image
    int frame_index = 0;
    stacks::StreamFramePoints points;
    frontend::StreamFrontEndTimes front_end_ms;
    double attributes_ms = 0;
  };

  /// The in-order half of the next prepared pair's work: frame after frame, one at a time (the front
  /// end and the causal attributes carry state). `frame_index` keys the voting pixels (a sequence's
  /// frame number, as eval-forest uses it).
  Tracked track(frontend::StereoFrontEndStream::Prepared&& pair, int frame_index);

  /// The rest of a tracked frame's work (its feature tables, classification, voting, smoothing): needs no
  /// other frame, so a pipeline classifies frame t on one thread while track() runs on frame t + 1.
  /// Returns the class positions (CV_8UC1).
  cv::Mat classify(const Tracked& frame, StreamStageTimes* times = nullptr) const;

  /// track() then classify().
  cv::Mat label(frontend::StereoFrontEndStream::Prepared&& pair, int frame_index, StreamStageTimes* times = nullptr) {
    return classify(track(std::move(pair), frame_index), times);
  }

  /// With the stereo front end's disparity_offset auto, the stream first estimates its offset from its
  /// first frames (frontend::kOffsetFrames, or all of a shorter video): calibrate() takes them prepared,
  /// in order, with their frame indices, and returns them tracked (last_frame() is the last of them);
  /// track() follows from the next one.
  bool needs_calibration() const { return stereo_ && stereo_->needs_calibration(); }
  std::vector<Tracked> calibrate(std::vector<frontend::StereoFrontEndStream::Prepared>&& first,
                                 const std::vector<int>& frame_indices);
  /// Pixels, once calibrated (a monocular stream: 0, it has no disparities).
  double disparity_offset() const { return stereo_ ? stereo_->disparity_offset() : 0.0; }

  /// prepare() then label().
  cv::Mat push(const cv::Mat& left_gray, const cv::Mat& right_gray, int frame_index, StreamStageTimes* times = nullptr) {
    return label(prepare(left_gray, right_gray), frame_index, times);
  }

  /// The last frame's front-end result (pose, observations).
  const frontend::StreamFrame& last_frame() const { return frame_; }

 private:
  // The front end's frame_ (whose left image is `left`) tracked: its points' attributes added.
  Tracked tracked_(const cv::Mat& left, int frame_index);

  std::vector<int> table_of_feature_;  // per forest feature: its index in structure_feature_names()
  forest::Classifier classifier_;
  EvalOptions eval_;
  cv::Size size_;
  std::optional<frontend::StereoFrontEndStream> stereo_;  // one of the two
  std::optional<sfm::MonoFrontEndStream> mono_;
  stacks::FeatureStream features_;
  frontend::StreamFrame frame_;
  struct TableBuffers {
    std::vector<cv::Mat> rasters, sats;
  };
  mutable tbb::enumerable_thread_specific<TableBuffers> buffers_;  // classify()'s, one set per thread
};

/// One stereo pair of a stream, as a source gives it.
struct StreamInput {
  int index = 0;        ///< the frame's number (keys the voting pixels)
  cv::Mat left, right;  ///< 8-bit grey
  cv::Mat left_bgr;     ///< optional: the colour image, for pictures
  std::chrono::steady_clock::time_point arrived;  ///< when reading it began (latency counts from here)
};
/// Fills the next pair; false at the end of the stream.
using StreamSource = std::function<bool(StreamInput&)>;
/// Takes each labelled frame, in order.
using StreamSink = std::function<void(const StreamInput&, const cv::Mat& labels, const StreamStageTimes&)>;

/// Runs a stream through the labeller as a pipeline of five stages: pairs are read in order, up to
/// `in_flight` of them prepared (disparity, keypoints) in parallel, tracked in order, classified in
/// parallel and handed to the sink in order. Only tracking runs one frame at a time: the tables and the
/// forest of frame t run beside the tracking of frame t + 1, the sink of an earlier frame beside both.
/// The labels are those of labeller.push() frame after frame, whatever the thread count. A labeller
/// that needs its calibration holds its first frames in the tracking stage (the reading and preparing
/// of the next go on) and tracks them all at the last of them. Returns the number of frames.
int run_stream(StreamLabeller& labeller, const StreamSource& source, const StreamSink& sink, std::size_t in_flight = 3);

}  // namespace smseg::eval
