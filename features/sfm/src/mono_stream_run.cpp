// The monocular stream over a whole sequence (run_mono_stream_front_end, mono_stream.hpp): the "vo" front
// end of extract-features, whose tracks and poses are exactly what a live stream knew at each frame.
#include <memory>
#include <cmath>
#include <map>

#include "smseg/common/error.hpp"
#include "smseg/common/progress.hpp"
#include "smseg/sfm/mono_stream.hpp"
#include "smseg/sfm/sfm_summary.hpp"

namespace smseg::sfm {

namespace {

// Appends the frame's observations to their tracks (ordered by track id, the stream's order).
void add_observations(const frontend::StreamFrame& frame, int sequence_frame, std::map<int, frontend::Track>& tracks) {
  for (const frontend::StreamObservation& o : frame.observations) {
    frontend::Track& t = tracks[o.track];
    t.frames.push_back(sequence_frame);
    t.pixels.push_back(o.pixel);
    t.disparities.push_back(o.disparity);
    t.points.push_back(o.point);
    t.labels.push_back(-1);
  }
}

// The track-length filter (the only one: every observation handed on has a point), counted as the
// stereo front end counts its filters.
void keep_long_tracks(std::map<int, frontend::Track>& tracks, int min_frames, frontend::FrontEndResult& res) {
  frontend::FilterCounts& fc = res.summary.filters;
  fc.tracks = static_cast<long>(tracks.size());
  for (auto& [id, t] : tracks) {
    fc.observations += static_cast<long>(t.size());
    if (static_cast<int>(t.size()) < min_frames) {
      ++fc.removed_short_tracks;
      fc.removed_short_obs += static_cast<long>(t.size());
      continue;
    }
    ++fc.kept_tracks;
    fc.kept_obs += static_cast<long>(t.size());
    res.tracks.push_back(std::move(t));
  }
}

std::shared_ptr<const SfmSummary> stream_summary(const MonoFrontEndStream& stream, const SfmOptions& options, long points) {
  const MonoStreamCounts& c = stream.counts();
  auto summary = std::make_shared<SfmSummary>();
  SfmSummary& s = *summary;
  s.tracker = "klt";
  s.focal = stream.focal();
  s.focal_source = options.focal ? "option" : "manifest";
  s.keyframes = c.keyframes;
  s.posed_frames = c.posed;
  s.bridged_frames = c.bridged + c.unposed;
  s.points_3d = points;
  s.observations = c.observations;
  s.reprojection_rms_px = c.observations > 0 ? std::sqrt(c.reprojection_sq / c.observations) : 0;
  s.scale = c.scale;
  s.ground_inliers = c.ground_inliers;
  s.seconds_sfm = c.frames > 0 ? c.seconds_motion / c.frames : 0;
  s.seconds_ba = c.frames > 0 ? c.seconds_ba / c.frames : 0;
  return summary;
}

}  // namespace

frontend::FrontEndResult run_mono_stream_front_end(const sequence::Sequence& seq, const SfmOptions& options) {
  options.validate();
  const int first = options.first_frame;
  const int last = options.last_frame < 0 ? seq.frame_count() : std::min(options.last_frame, seq.frame_count());
  if (first < 0 || first >= last)
    throw Error(seq.manifest.string(), "first_frame", "selects none of the " + std::to_string(seq.frame_count()) + " frames");
  MonoFrontEndStream stream(seq.calibration, seq.camera_height, seq.size, options, seq.manifest.string());
  frontend::FrontEndResult res;
  res.first_frame = first;
  std::map<int, frontend::Track> tracks;
  Progress progress("vo", last - first, options.progress);
  double keypoint_ms = 0, tracking_ms = 0;
  for (int f = first; f < last; ++f) {
    frontend::StreamFrame frame = stream.push(seq.load_left_gray(f));
    add_observations(frame, f, tracks);
    res.poses.push_back(frame.pose);
    if (frame.motion) res.pair_motions.push_back(*frame.motion);
    keypoint_ms += frame.ms.keypoints;
    tracking_ms += frame.ms.tracking;
    progress.tick();
  }
  progress.finish();
  const int n = last - first;
  keep_long_tracks(tracks, options.filters.min_frames, res);
  frontend::FrontEndSummary& s = res.summary;
  s.frames = n;
  s.keypoints = stream.counts().keypoints;
  frontend::summarise_tracks_and_motion(res, n, [&res](std::size_t k) { return res.pair_motions[k].points > 0; });
  s.seconds.keypoints = keypoint_ms / 1000 / n;
  s.seconds.matching = tracking_ms / 1000 / n;
  s.seconds.motion = stream.counts().seconds_motion / n;
  s.own = stream_summary(stream, options, static_cast<long>(res.tracks.size()));
  return res;
}

}  // namespace smseg::sfm
