// The stereo front end: disparity -> keypoints -> matching -> tracks -> filters -> motion -> path.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include "smseg/frontend/motion.hpp"
#include "smseg/frontend/sparse_stereo.hpp"
#include "smseg/common/progress.hpp"

namespace smseg::frontend {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr int kChunk = 32;  // frames whose descriptors are held at once

}  // namespace

void FrontEndOptions::validate() const {
  stereo.validate();
  tracking.validate();
  klt.validate("front_end");
  if (tracker == FrameTracker::Descriptors && tracking.detector == KeypointMethod::Gftt)
    throw Error("", "tracking.detector", "gftt corners have no descriptors: use them with the klt tracker (--tracker klt)");
  filters.validate();
  motion.validate();
  refine.validate();
  gravity.validate();
  if (camera_height && !(*camera_height > 0)) throw Error("", "camera_height", "must be positive (metres)");
  if (first_frame < 0) throw Error("", "first_frame", "must be >= 0");
  if (last_frame != -1 && last_frame <= first_frame)
    throw Error("", "last_frame", "must be -1 (to the end) or greater than first_frame");
}

void summarise_tracks_and_motion(FrontEndResult& res, int n, const std::function<bool(std::size_t)>& counted) {
  FrontEndSummary& s = res.summary;
  const int first = res.first_frame;
  std::vector<int> per_frame(n, 0);
  std::vector<int> lengths;
  for (const auto& tr : res.tracks) {
    lengths.push_back(static_cast<int>(tr.size()));
    for (int f : tr.frames) ++per_frame[f - first];
  }
  if (n > 0) {
    long total = 0;
    for (int v : per_frame) total += v;
    s.valid_points_per_frame_mean = static_cast<double>(total) / n;
    s.valid_points_per_frame_min = *std::min_element(per_frame.begin(), per_frame.end());
  }
  if (!lengths.empty()) {
    std::sort(lengths.begin(), lengths.end());
    double sum = 0;
    for (int l : lengths) sum += l;
    s.track_length_mean = sum / static_cast<double>(lengths.size());
    s.track_length_median = lengths[lengths.size() / 2];
    s.track_length_max = lengths.back();
  }
  int good = 0;
  double ratio_sum = 0, ratio_min = 1;
  for (std::size_t k = 0; k < res.pair_motions.size(); ++k) {
    const auto& pm = res.pair_motions[k];
    if (pm.bridged) {
      ++s.bad_pairs;
      s.bridged_pairs.push_back(first + static_cast<int>(k));
      continue;
    }
    if (counted && !counted(k)) continue;
    const double r = pm.points > 0 ? static_cast<double>(pm.inliers) / pm.points : 0;
    ++good;
    ratio_sum += r;
    ratio_min = std::min(ratio_min, r);
  }
  s.inlier_ratio_mean = good ? ratio_sum / good : 0;
  s.inlier_ratio_min = good ? ratio_min : 0;
}

namespace {

/// Per frame: the left image, its disparity, the keypoints and the labels.
struct FrameInput {
  cv::Mat left, labels;
  FrameDisparity disparity;
  FrameKeypoints keypoints;
};

/// The camera height the world origin is put under: the option's, else the sequence's; the sequence
/// must be a stereo one with a focal length and a baseline.
double checked_camera_height(const sequence::Sequence& seq, const FrontEndOptions& o) {
  const std::string manifest = seq.manifest.string();
  if (seq.kind != sequence::SequenceKind::Stereo) throw Error(manifest, "kind", "the stereo front end needs a stereo sequence");
  if (!seq.calibration.fx || !(*seq.calibration.fx > 0))
    throw Error(manifest, "calibration.fx", "the stereo front end needs the focal length");
  if (!seq.calibration.baseline || !(*seq.calibration.baseline > 0))
    throw Error(manifest, "calibration.baseline", "the stereo front end needs the stereo baseline");
  const std::optional<double> height = o.camera_height ? o.camera_height : seq.camera_height;
  if (!height)
    throw Error(manifest, "camera_height",
                "needed to put the world origin on the ground under the first camera (give it in the manifest "
                "or as an option)");
  return *height;
}

/// The frames [first, first + n) of one front-end run, what the tracker makes of them (observations and
/// matches between consecutive frames), and the time each stage took per frame.
struct FrameStage {
  const sequence::Sequence& seq;
  const FrontEndOptions& o;
  int first, n;
  std::vector<FrameObservations> obs;
  std::vector<std::vector<cv::DMatch>> matches;
  std::vector<double> t_disp, t_kp, t_match;
  Progress progress;
  std::atomic<int> done{0};

  FrameStage(const sequence::Sequence& s, const FrontEndOptions& opts, int first_frame, int frames)
      : seq(s), o(opts), first(first_frame), n(frames), obs(n), matches(std::max(0, n - 1)), t_disp(n), t_kp(n),
        t_match(std::max(0, n - 1)), progress("front end", n, opts.progress) {}

  /// Frame first + i: the left image, its disparity (timed), the keypoints (timed) and the labels.
  FrameInput load_frame(int i) {
    const int f = first + i;
    FrameInput in;
    auto t0 = Clock::now();
    in.left = seq.load_left_gray(f);
    if (o.stereo.method == StereoMethod::Given) {
      in.disparity = FrameDisparity(frame_disparity(seq, f, o.stereo));
    } else {
      try {
        // As computed: the offset is added to the observations once it is known (apply_offset).
        in.disparity = prepare_disparity(in.left, seq.load_right_gray(f), o.stereo);
      } catch (const Error& e) {
        if (!e.file().empty()) throw;
        throw Error(seq.manifest.string(), "frames[" + std::to_string(f) + "]", e.what());
      }
    }
    t_disp[i] = since(t0);
    t0 = Clock::now();
    in.keypoints = detect_keypoints(in.left, o.tracking);
    if (seq.is_labelled(f)) in.labels = seq.load_labels(f);
    t_kp[i] = since(t0);
    progress.tick();
    if (o.on_frame) o.on_frame(++done, n);
    return in;
  }
};

/// The KLT tracker as a pipeline: frames loaded, matched in stereo and detected in parallel, then followed
/// by KLT in order (each frame's points are those followed from the previous frame plus new ones). At
/// most `tokens` frames are in flight.
void track_klt(FrameStage& st) {
  using Item = std::pair<int, std::shared_ptr<FrameInput>>;
  const FrontEndOptions& o = st.o;
  int next = 0;
  cv::Mat prev_img;
  std::vector<cv::Point2f> prev_px;
  auto follow = [&](const Item& item) {
    const auto& [i, in] = item;
    const auto t0 = Clock::now();
    std::vector<cv::Point2f> detected;
    detected.reserve(in->keypoints.keypoints.size());
    for (const auto& k : in->keypoints.keypoints) detected.push_back(k.pt);
    std::vector<cv::DMatch> m;
    prev_px = klt_step(prev_img, prev_px, in->left, detected, o.tracking.max_keypoints, o.klt, m);
    st.obs[i] = observe_points(prev_px, in->disparity, in->labels, st.seq.calibration);
    prev_img = in->left;
    if (i > 0) {
      st.matches[i - 1] = std::move(m);
      st.t_match[i - 1] = since(t0);
    }
  };
  const int tokens = 4 * std::max(1, tbb::this_task_arena::max_concurrency());
  tbb::parallel_pipeline(static_cast<std::size_t>(tokens),
                         tbb::make_filter<void, int>(tbb::filter_mode::serial_in_order,
                                                     [&](tbb::flow_control& fc) {
                                                       if (next >= st.n) fc.stop();
                                                       return next++;
                                                     }) &
                             tbb::make_filter<int, Item>(tbb::filter_mode::parallel,
                                                         [&](int i) {
                                                           return std::make_pair(
                                                               i, std::make_shared<FrameInput>(st.load_frame(i)));
                                                         }) &
                             tbb::make_filter<Item, void>(tbb::filter_mode::serial_in_order, follow));
}

/// Matches the descriptors of frames t and t + 1 (timed).
void match_pair(FrameStage& st, int t, const cv::Mat& a, const cv::Mat& b) {
  const auto t0 = Clock::now();
  std::vector<cv::DMatch> m = match_symmetric(a, b, descriptor_norm(st.o.tracking.detector));
  drop_far_matches(m, st.obs[t].pixels, st.obs[t + 1].pixels, st.o.tracking);
  st.matches[t] = std::move(m);
  st.t_match[t] = since(t0);
}

/// The descriptor tracker, kChunk frames at a time: frames loaded in parallel, then the pair joining the
/// previous chunk matched, then the pairs inside this chunk in parallel.
void track_descriptors(FrameStage& st) {
  cv::Mat prev_desc;  // descriptors of the last frame of the previous chunk
  for (int c0 = 0; c0 < st.n; c0 += kChunk) {
    const int c1 = std::min(st.n, c0 + kChunk);
    std::vector<cv::Mat> desc(c1 - c0);
    tbb::parallel_for(tbb::blocked_range<int>(c0, c1, 1), [&](const tbb::blocked_range<int>& r) {
      for (int i = r.begin(); i < r.end(); ++i) {
        FrameInput in = st.load_frame(i);
        st.obs[i] = observe_keypoints(in.keypoints.keypoints, in.disparity, in.labels, st.seq.calibration);
        desc[i - c0] = in.keypoints.descriptors;
      }
    });
    if (c0 > 0) match_pair(st, c0 - 1, prev_desc, desc[0]);
    tbb::parallel_for(tbb::blocked_range<int>(c0, c1 - 1, 1), [&](const tbb::blocked_range<int>& r) {
      for (int t = r.begin(); t < r.end(); ++t) match_pair(st, t, desc[t - c0], desc[t + 1 - c0]);
    });
    prev_desc = desc.back();
  }
}

/// Tracks from the observations and matches (frame indices the sequence's), the tracks the motion is
/// estimated from into for_motion.
std::vector<Track> sequence_tracks(const FrameStage& st, FilterCounts& counts, std::vector<Track>& for_motion) {
  std::vector<Track> tracks = build_tracks(st.obs, st.matches, st.o.filters, counts, &for_motion);
  if (st.first != 0) {
    for (auto* list : {&tracks, &for_motion})
      for (auto& tr : *list)
        for (int& f : tr.frames) f += st.first;
  }
  return tracks;
}

/// Pair motions, the chained camera path and (with --gravity estimate) the levelled world.
void estimate_path(FrontEndResult& res, const std::vector<Track>& for_motion, const FrameStage& st, double height) {
  const FrontEndOptions& o = st.o;
  res.pair_motions =
      estimate_pair_motions(for_motion, st.first, st.n, o.motion, StereoCamera::from(st.seq.calibration), o.refine);
  res.poses = chain_poses(res.pair_motions, height);
  if (o.gravity.method == GravityMethod::Estimate) {
    res.summary.gravity = estimate_gravity(res.poses, st.first, res.tracks, height, o.gravity);
    level_world(res.poses, res.summary.gravity->up);
  }
}

/// Observations of the first frames (at most kOffsetFrames) with the calibration's offset, and the
/// matches between them: what the streamed front end sees before it holds its offset.
OffsetEstimate self_calibrate(const FrameStage& st) {
  const std::size_t m = std::min<std::size_t>(kOffsetFrames, st.obs.size());
  std::vector<FrameObservations> first(st.obs.begin(), st.obs.begin() + static_cast<std::ptrdiff_t>(m));
  for (auto& f : first) offset_observations(f, st.seq.calibration.disparity_offset, st.seq.calibration);
  const std::vector<std::vector<cv::DMatch>> matches(st.matches.begin(),
                                                     st.matches.begin() + static_cast<std::ptrdiff_t>(m > 0 ? m - 1 : 0));
  return estimate_disparity_offset(first, matches, StereoCamera::from(st.seq.calibration));
}

/// Adds the run's disparity offset (disparity_offset.hpp) to every observation, as the calibration's
/// offset added to the disparity maps would; computed disparities only (given ones are true already).
void apply_offset(FrameStage& st, FrontEndSummary& s) {
  if (st.o.stereo.method == StereoMethod::Given) return;
  const sequence::Calibration& calib = st.seq.calibration;
  switch (st.o.disparity_offset.mode) {
    case DisparityOffsetChoice::Mode::Calibration: s.disparity_offset = calib.disparity_offset; break;
    case DisparityOffsetChoice::Mode::Pixels: s.disparity_offset = st.o.disparity_offset.pixels; break;
    case DisparityOffsetChoice::Mode::Auto:
      s.offset_estimate = self_calibrate(st);
      s.disparity_offset = calib.disparity_offset + s.offset_estimate->extra;
      break;
  }
  for (auto& f : st.obs) offset_observations(f, s.disparity_offset, calib);
}

double mean_over(const std::vector<double>& v, int denom) {
  double a = 0;
  for (double x : v) a += x;
  return denom > 0 ? a / denom : 0.0;
}

}  // namespace

FrontEndResult run_stereo_front_end(const sequence::Sequence& seq, const FrontEndOptions& o) {
  const auto wall0 = Clock::now();
  o.validate();
  const double height = checked_camera_height(seq, o);
  const int first = o.first_frame;
  const int n = seq.range_end(first, o.last_frame) - first;
  FrameStage st(seq, o, first, n);
  if (o.tracker == FrameTracker::Klt) track_klt(st);
  if (o.tracker == FrameTracker::Descriptors) track_descriptors(st);
  st.progress.finish();
  FrontEndResult res;
  apply_offset(st, res.summary);
  long keypoints = 0;
  for (const auto& f : st.obs) keypoints += static_cast<long>(f.pixels.size());

  res.first_frame = first;
  auto t0 = Clock::now();
  std::vector<Track> for_motion;
  FilterCounts counts;
  res.tracks = sequence_tracks(st, counts, for_motion);
  const double t_tracks = since(t0);
  t0 = Clock::now();
  estimate_path(res, for_motion, st, height);
  const double t_motion = since(t0);

  FrontEndSummary& s = res.summary;
  s.frames = n;
  s.keypoints = keypoints;
  s.filters = counts;
  summarise_tracks_and_motion(res, n);
  s.seconds.disparity = mean_over(st.t_disp, n);
  s.seconds.keypoints = mean_over(st.t_kp, n);
  s.seconds.matching = mean_over(st.t_match, n);
  s.seconds.tracks = n > 0 ? t_tracks / n : 0;
  s.seconds.motion = n > 0 ? t_motion / n : 0;
  s.seconds.total_wall = since(wall0);
  return res;
}

}  // namespace smseg::frontend
