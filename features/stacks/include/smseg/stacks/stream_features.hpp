#pragma once
// The causal feature stack of one streamed frame (label-stream): what extract-features --causal
// writes for that frame, computed from the stream's frames so far, in memory.

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/frontend/stream.hpp"
#include "smseg/stacks/point_features.hpp"

namespace smseg::stacks {

class FeatureStream {
 public:
  /// `min_track_frames`: the front end's TrackFilterOptions::min_frames (the causal track rule).
  /// HeightReference::Camera measures heights from the ground under each camera, the first frame's
  /// camera height its reference (as extract-features --causal); any other, world Y.
  FeatureStream(cv::Size size, const FeatureOptions& options, int min_track_frames);

  /// The frame's six summed-area tables (structure_feature_names() order; CV_64FC1, (H+1) x (W+1)),
  /// valid until the next push.
  const std::vector<cv::Mat>& push(const frontend::StreamFrame& frame);

 private:
  cv::Size size_;
  int min_track_frames_;
  HeightReference height_reference_;
  CausalPointAttributes attributes_;
  PointCloudVideo video_;    // this frame alone
  PointAttributes attrs_;    // this frame alone
  std::vector<cv::Mat> rasters_, sats_;
};

}  // namespace smseg::stacks
