// The stereo front end one frame at a time (stream.hpp). Each step is the one run_stereo_front_end
// takes for that frame, in the same order and with the same functions, so that the two agree exactly.

#include "smseg/frontend/stream.hpp"

#include <algorithm>
#include <chrono>
#include <numeric>

#include "smseg/frontend/disparity_offset.hpp"

#include "pair_motion.hpp"

namespace smseg::frontend {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

}  // namespace

struct StereoFrontEndStream::Path {
  explicit Path(double camera_height) : chain(camera_height) {}
  detail::PathChain chain;
};

StereoFrontEndStream::StereoFrontEndStream(const sequence::Calibration& calibration, std::optional<double> camera_height,
                                           const FrontEndOptions& options, const std::string& source)
    : calib_(calibration), opt_(options) {
  opt_.validate();
  if (opt_.stereo.method == StereoMethod::Given)
    throw Error(source, "stereo", "disparities given with a sequence cannot be streamed: use bm, sparse or sgbm");
  if (!calib_.fx || !(*calib_.fx > 0)) throw Error(source, "calibration.fx", "the stereo front end needs the focal length");
  if (!calib_.baseline || !(*calib_.baseline > 0))
    throw Error(source, "calibration.baseline", "the stereo front end needs the stereo baseline");
  const std::optional<double> height = opt_.camera_height ? opt_.camera_height : camera_height;
  if (!height || !(*height > 0))
    throw Error(source, "camera_height",
                "needed to put the world origin on the ground under the first camera (give it in the manifest or "
                "as an option)");
  camera_height_ = *height;
  camera_ = StereoCamera::from(calib_);
  path_ = std::make_shared<Path>(camera_height_);
  if (opt_.disparity_offset.mode == DisparityOffsetChoice::Mode::Calibration) offset_ = calib_.disparity_offset;
  if (opt_.disparity_offset.mode == DisparityOffsetChoice::Mode::Pixels) offset_ = opt_.disparity_offset.pixels;
}

StereoFrontEndStream::Prepared StereoFrontEndStream::prepare(const cv::Mat& left, const cv::Mat& right) const {
  if (left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size() || left.empty())
    throw Error("", "stereo pair", "must be two 8-bit grey images of one size");
  Prepared p;
  p.left = left.clone();  // kept as the previous image (klt): the caller may reuse its buffer
  auto t0 = Clock::now();
  p.disparity = prepare_disparity(left, right, opt_.stereo);  // the offset is added to the observations (emit)
  p.ms.disparity = ms_since(t0);
  t0 = Clock::now();
  p.keypoints = detect_keypoints(left, opt_.tracking);
  p.ms.keypoints = ms_since(t0);
  return p;
}

FrameObservations StereoFrontEndStream::observe(const Prepared& in, std::vector<cv::DMatch>& matches) {
  FrameObservations obs;
  if (opt_.tracker == FrameTracker::Klt) {
    std::vector<cv::Point2f> detected;
    detected.reserve(in.keypoints.keypoints.size());
    for (const auto& k : in.keypoints.keypoints) detected.push_back(k.pt);
    prev_px_ = klt_step(prev_img_, prev_px_, in.left, detected, opt_.tracking.max_keypoints, opt_.klt, matches);
    obs = observe_points(prev_px_, in.disparity, cv::Mat(), calib_);
    prev_img_ = in.left;
    if (tracked_ == 0) matches.clear();
  } else {
    obs = observe_keypoints(in.keypoints.keypoints, in.disparity, cv::Mat(), calib_);
    if (tracked_ > 0) {
      matches = match_symmetric(prev_desc_, in.keypoints.descriptors, descriptor_norm(opt_.tracking.detector));
      drop_far_matches(matches, prev_px_, obs.pixels, opt_.tracking);
    }
    prev_desc_ = in.keypoints.descriptors;
    prev_px_ = obs.pixels;
  }
  return obs;
}

std::vector<int> StereoFrontEndStream::chain(const FrameObservations& obs, const std::vector<cv::DMatch>& matches) {
  // As chain_matches: a matched keypoint continues its track, the others start new ones in keypoint order.
  std::vector<int> ids(obs.pixels.size(), -1);
  for (const auto& m : matches) ids[m.trainIdx] = prev_ids_[m.queryIdx];
  for (int& id : ids)
    if (id == -1) id = next_track_++;
  return ids;
}

StereoFrontEndStream::Tracked StereoFrontEndStream::track(Prepared&& in) {
  const cv::Mat& left = in.left;
  if (tracked_ > 0 && left.size() != size_)
      throw Error("", "frame " + std::to_string(tracked_),
                  "is " + std::to_string(left.cols) + "x" + std::to_string(left.rows) + ", the stream started at " +
                      std::to_string(size_.width) + "x" + std::to_string(size_.height));
  size_ = left.size();
  Tracked t;
  t.ms = in.ms;
  const auto t0 = Clock::now();
  t.obs = observe(in, t.matches);
  t.ms.tracking = ms_since(t0);
  ++tracked_;
  return t;
}

StreamFrame StereoFrontEndStream::advance(Prepared&& in) {
  if (needs_calibration())
    throw Error("", "disparity_offset", "auto: the stream estimates it from its first frames (calibrate) before any other");
  return emit(track(std::move(in)));
}

std::vector<StreamFrame> StereoFrontEndStream::calibrate(std::vector<Prepared>&& first) {
  if (!needs_calibration()) throw Error("", "disparity_offset", "the stream holds its offset already");
  std::vector<Tracked> tracked;
  for (auto& p : first) tracked.push_back(track(std::move(p)));
  // What the whole-sequence front end estimates from: the calibration's offset added, the matches of each pair.
  std::vector<FrameObservations> obs;
  std::vector<std::vector<cv::DMatch>> matches;
  for (const Tracked& t : tracked) {
    obs.push_back(t.obs);
    offset_observations(obs.back(), calib_.disparity_offset, calib_);
    if (obs.size() > 1) matches.push_back(t.matches);
  }
  estimate_ = estimate_disparity_offset(obs, matches, camera_);
  offset_ = calib_.disparity_offset + estimate_->extra;
  std::vector<StreamFrame> out;
  for (auto& t : tracked) out.push_back(emit(std::move(t)));
  return out;
}

StreamFrame StereoFrontEndStream::emit(Tracked&& in) {
  StreamFrame out;
  out.index = index_;
  out.ms = in.ms;
  auto t0 = Clock::now();
  FrameObservations& obs = in.obs;
  offset_observations(obs, offset_, calib_);
  const std::vector<cv::DMatch>& matches = in.matches;
  const std::vector<int> ids = chain(obs, matches);
  const std::size_t n = obs.pixels.size();
  std::vector<int> from(n, -1);  // the matched keypoint of the previous frame
  for (const auto& m : matches) from[m.trainIdx] = m.queryIdx;
  std::vector<int> seen(n);
  for (std::size_t i = 0; i < n; ++i)
    seen[i] = (from[i] >= 0 ? prev_seen_[from[i]] : 0) + (obs.disparities[i] > 0 ? 1 : 0);
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return ids[a] < ids[b]; });
  for (int i : order) {
    out.live_tracks.push_back(ids[i]);
    if (obs.disparities[i] > 0) out.observations.push_back({ids[i], obs.pixels[i], obs.disparities[i], obs.points[i], seen[i]});
  }
  out.ms.tracking += ms_since(t0);

  // The pair's motion from the tracks with valid observations in both frames, in track order.
  t0 = Clock::now();
  if (index_ == 0) {
    out.pose = path_->chain.first();
  } else {
    detail::PairData d;
    for (int i : order) {
      const int q = from[i];
      if (q < 0 || !(obs.disparities[i] > 0) || !(prev_obs_.disparities[q] > 0)) continue;
      d.P.push_back(prev_obs_.points[q]);
      d.Q.push_back(obs.points[i]);
      d.ma.emplace_back(prev_obs_.pixels[q].x, prev_obs_.pixels[q].y, prev_obs_.disparities[q]);
      d.mb.emplace_back(obs.pixels[i].x, obs.pixels[i].y, obs.disparities[i]);
    }
    std::vector<detail::Candidate> cands =
        detail::pair_candidates(d, static_cast<std::uint64_t>(index_ - 1), opt_.motion, &camera_, &opt_.refine);
    PairMotion pm = detail::choose_pair_motion(cands, d, previous_motion_, opt_.motion, &camera_, &opt_.refine);
    out.pose = path_->chain.step(pm);
    out.motion = pm;
  }
  out.ms.motion = ms_since(t0);

  prev_obs_ = obs;
  prev_ids_ = ids;
  prev_seen_ = std::move(seen);
  ++index_;
  return out;
}

}  // namespace smseg::frontend
