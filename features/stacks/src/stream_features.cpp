#include "smseg/stacks/stream_features.hpp"

namespace smseg::stacks {

FeatureStream::FeatureStream(cv::Size size, const FeatureOptions& options, int min_track_frames)
    : size_(size), min_track_frames_(min_track_frames), height_reference_(options.height_reference) {
  options.validate();
  if (!options.causal) throw Error("", "features.causal", "a stream can only compute causal features");
  video_.poses.resize(1);
  video_.observations.resize(1);
  attrs_.world.resize(1);
  attrs_.fH.resize(1);
  attrs_.fC.resize(1);
  attrs_.fR.resize(1);
}

const std::vector<cv::Mat>& FeatureStream::push(const frontend::StreamFrame& frame) {
  // The frame's observations whose tracks have passed the track-length filter (video_from_tracks'
  // causal rule), in track order as the whole-sequence extraction lists them.
  auto& obs = video_.observations[0];
  obs.clear();
  for (const frontend::StreamObservation& o : frame.observations) {
    if (o.seen < min_track_frames_) continue;
    Observation p;
    p.track = o.track;
    p.x = o.pixel.x;
    p.y = o.pixel.y;
    p.cam = o.point;
    obs.push_back(p);
  }
  video_.poses[0] = frame.pose;
  if (frame.index == 0 && height_reference_ == HeightReference::Camera) {
    FeatureOptions o;  // the causal reference: the first camera's height (reference_camera_height)
    o.causal = true;
    o.height_reference = HeightReference::Camera;
    attributes_ = CausalPointAttributes(reference_camera_height(o, video_.poses));
  }
  FrameAttributes fa;
  attributes_.add_frame(frame.pose, obs, fa);
  attributes_.keep_only(frame.live_tracks);
  attrs_.world[0] = std::move(fa.world);
  attrs_.fH[0] = std::move(fa.fH);
  attrs_.fC[0] = std::move(fa.fC);
  attrs_.fR[0] = std::move(fa.fR);
  rasterise_features(video_, attrs_, 0, size_, rasters_);
  sats_.resize(rasters_.size());
  for (std::size_t k = 0; k < rasters_.size(); ++k) summed_area_table(rasters_[k], sats_[k]);
  return sats_;
}

}  // namespace smseg::stacks
