#pragma once
// The causal feature stack of one streamed frame (label-stream): what extract-features --causal
// writes for that frame, computed from the stream's frames so far, in memory.

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/frontend/stream.hpp"
#include "smseg/stacks/point_features.hpp"

namespace smseg::stacks {

/// One streamed frame's points and their causal attributes: all its tables are made from.
struct StreamFramePoints {
  PointCloudVideo video;  ///< this frame alone
  PointAttributes attrs;  ///< this frame alone
};

class FeatureStream {
 public:
  /// `min_track_frames`: the front end's TrackFilterOptions::min_frames (the causal track rule).
  /// HeightReference::Camera measures heights from the ground under each camera, the first frame's
  /// camera height its reference (as extract-features --causal); any other, world Y.
  FeatureStream(cv::Size size, const FeatureOptions& options, int min_track_frames);

  /// The frame's points and attributes. In order, frame after frame: the causal attributes carry each
  /// track's history from one frame to the next.
  StreamFramePoints advance(const frontend::StreamFrame& frame);

  /// The frame's six summed-area tables (structure_feature_names() order; CV_64FC1, (H+1) x (W+1)) into
  /// `sats`, through `rasters` (both reused). Needs no other frame: callable from any thread, for several
  /// frames at once, while advance() runs on a later one.
  void tables(const StreamFramePoints& points, std::vector<cv::Mat>& rasters, std::vector<cv::Mat>& sats) const;

  /// advance() then tables(), into buffers of its own, valid until the next push.
  const std::vector<cv::Mat>& push(const frontend::StreamFrame& frame);

 private:
  cv::Size size_;
  int min_track_frames_;
  HeightReference height_reference_;
  CausalPointAttributes attributes_;
  std::vector<cv::Mat> rasters_, sats_;  // push()'s
};

}  // namespace smseg::stacks
