#include "smseg/stacks/stream_features.hpp"

namespace smseg::stacks {

FeatureStream::FeatureStream(cv::Size size, const FeatureOptions& options, int min_track_frames)
    : size_(size), min_track_frames_(min_track_frames), height_reference_(options.height_reference) {
  options.validate();
  if (!options.causal) throw Error("", "features.causal", "a stream can only compute causal features");
}

StreamFramePoints FeatureStream::advance(const frontend::StreamFrame& frame) {
  // The frame's observations whose tracks have passed the track-length filter (video_from_tracks'
  // causal rule), in track order as the whole-sequence extraction lists them.
  StreamFramePoints points;
  auto& obs = points.video.observations.emplace_back();
  for (const frontend::StreamObservation& o : frame.observations) {
    if (o.seen < min_track_frames_) continue;
    Observation p;
    p.track = o.track;
    p.x = o.pixel.x;
    p.y = o.pixel.y;
    p.cam = o.point;
    obs.push_back(p);
  }
  points.video.poses.push_back(frame.pose);
  if (frame.index == 0 && height_reference_ == HeightReference::Camera) {
    FeatureOptions o;  // the causal reference: the first camera's height (reference_camera_height)
    o.causal = true;
    o.height_reference = HeightReference::Camera;
    attributes_ = CausalPointAttributes(reference_camera_height(o, points.video.poses));
  }
  FrameAttributes fa;
  attributes_.add_frame(frame.pose, obs, fa);
  attributes_.keep_only(frame.live_tracks);
  points.attrs.world.push_back(std::move(fa.world));
  points.attrs.fH.push_back(std::move(fa.fH));
  points.attrs.fC.push_back(std::move(fa.fC));
  points.attrs.fR.push_back(std::move(fa.fR));
  return points;
}

void FeatureStream::tables(const StreamFramePoints& points, std::vector<cv::Mat>& rasters,
                           std::vector<cv::Mat>& sats) const {
  rasterise_features(points.video, points.attrs, 0, size_, rasters);
  sats.resize(rasters.size());
  for (std::size_t k = 0; k < rasters.size(); ++k) summed_area_table(rasters[k], sats[k]);
}

const std::vector<cv::Mat>& FeatureStream::push(const frontend::StreamFrame& frame) {
  tables(advance(frame), rasters_, sats_);
  return sats_;
}

}  // namespace smseg::stacks
