#pragma once
// The stereo front end one frame at a time, for live video (label-stream): each stereo pair is
// matched, its keypoints followed from the previous frame, its camera pose chained, and its tracked
// points handed on, before the next pair is seen. It is the whole-sequence front end
// (run_stereo_front_end) run causally: with the same options the same disparities, keypoints,
// matches, track ids, pair motions and poses, frame for frame (tests/eval/test_label_stream.cpp).
//
// What it cannot know yet is whether a track will live long enough for the track-length filter
// (TrackFilterOptions::min_frames): a frame's observation is handed on with the number of valid
// observations its track has had so far (`seen`), and the causal features use it only from
// min_frames on (stacks' causal rule, video_from_tracks).

#include <cstdint>
#include <memory>
#include <string>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "smseg/frontend/disparity_offset.hpp"
#include "smseg/frontend/motion.hpp"
#include "smseg/frontend/sparse_stereo.hpp"
#include "smseg/frontend/tracking.hpp"
#include "smseg/sequence/sequence.hpp"

namespace smseg::frontend {

/// One keypoint of the streamed frame with a valid disparity.
struct StreamObservation {
  int track = -1;          ///< track id, in order of first appearance (the whole-sequence chain_matches ids)
  cv::Point2f pixel;
  float disparity = 0;
  Eigen::Vector3d point{0, 0, 0};  ///< camera frame, metres
  int seen = 0;            ///< valid observations of the track up to this frame, this one included
};

/// Milliseconds of each step of one streamed frame.
struct StreamFrontEndTimes {
  double disparity = 0, keypoints = 0, tracking = 0, motion = 0;
};

struct StreamFrame {
  int index = 0;                                ///< frames pushed before this one
  sequence::Pose pose;                                    ///< camera-to-world
  std::optional<PairMotion> motion;             ///< the pair (index - 1, index); none for the first frame
  std::vector<StreamObservation> observations;  ///< ascending track id
  std::vector<int> live_tracks;                 ///< ids of every keypoint of the frame, valid or not, ascending
  StreamFrontEndTimes ms;
};

class StereoFrontEndStream {
 public:
  /// Needs fx, the baseline and a camera height (the options' or the calibration's sequence's);
  /// Error naming `source` and the field otherwise. The `given` disparity method needs a sequence
  /// folder and is refused.
  StereoFrontEndStream(const sequence::Calibration& calibration, std::optional<double> camera_height,
                       const FrontEndOptions& options, const std::string& source);

  /// The work of a stereo pair that needs no earlier frame (disparity, keypoints): callable from any
  /// thread, for several pairs at once (a pipeline), while advance() runs on an earlier one.
  struct Prepared {
    cv::Mat left;
    FrameDisparity disparity;  ///< the dense map, or the sparse matcher's pair matched at the tracked points
    FrameKeypoints keypoints;
    StreamFrontEndTimes ms;
  };
  /// Pairs of 8-bit grey images of one size (Error otherwise).
  Prepared prepare(const cv::Mat& left_gray, const cv::Mat& right_gray) const;

  /// The next frame, in order: tracking, track ids, motion and pose (Error when its size differs
  /// from the first frame's, or when the stream still needs its calibration).
  StreamFrame advance(Prepared&& pair);

  /// With disparity_offset auto, the offset is estimated from the first frames (kOffsetFrames, fewer
  /// when the video is shorter) before any frame is given out, exactly as the whole-sequence front
  /// end estimates it: calibrate() takes them, prepared and in order, holds the offset and returns
  /// their frames; advance() then follows from the next one.
  bool needs_calibration() const { return opt_.disparity_offset.mode == DisparityOffsetChoice::Mode::Auto && !estimate_; }
  std::vector<StreamFrame> calibrate(std::vector<Prepared>&& first);
  double disparity_offset() const { return offset_; }  ///< pixels added to every disparity (once calibrated)
  const std::optional<OffsetEstimate>& offset_estimate() const { return estimate_; }

  /// prepare() then advance().
  StreamFrame push(const cv::Mat& left_gray, const cv::Mat& right_gray) { return advance(prepare(left_gray, right_gray)); }

 private:
  // A frame followed from the previous one: its observations before the disparity offset and its
  // matches to the previous frame. Tracking does not depend on the offset, so calibrate() tracks the
  // first frames once and gives them out (emit) once their offset is known.
  struct Tracked {
    FrameObservations obs;
    std::vector<cv::DMatch> matches;
    StreamFrontEndTimes ms;
  };
  Tracked track(Prepared&& pair);
  StreamFrame emit(Tracked&& frame);
  // The frame's observations and its matches to the previous frame (klt or descriptors).
  FrameObservations observe(const Prepared& pair, std::vector<cv::DMatch>& matches);
  // Track ids of the frame's keypoints from the matches (chain_matches, one frame at a time).
  std::vector<int> chain(const FrameObservations& obs, const std::vector<cv::DMatch>& matches);

  sequence::Calibration calib_;
  FrontEndOptions opt_;
  StereoCamera camera_;
  double camera_height_ = 0;
  cv::Size size_;  // the first frame's
  int index_ = 0;    // frames given out
  int tracked_ = 0;  // frames tracked
  int next_track_ = 0;
  double offset_ = 0;  // pixels added to every disparity
  std::optional<OffsetEstimate> estimate_;  // disparity_offset auto, once calibrated
  // The previous frame: its image and points (klt) or keypoint pixels and descriptors (descriptors), its
  // observations, track ids and valid observations.
  cv::Mat prev_img_, prev_desc_;
  std::vector<cv::Point2f> prev_px_;
  FrameObservations prev_obs_;
  std::vector<int> prev_ids_;
  std::vector<int> prev_seen_;  // per keypoint of the previous frame: its track's valid observations so far
  std::optional<RigidMotion> previous_motion_;  // the last good pair's motion (constant velocity)
  struct Path;                  // the chained camera path (pair_motion.hpp's PathChain)
  std::shared_ptr<Path> path_;
};

}  // namespace smseg::frontend
