#include "smseg/frontend/tracking.hpp"
#include "smseg/frontend/sparse_stereo.hpp"

#include "smseg/common/names.hpp"
#include "smseg/frontend/stereo.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/video/tracking.hpp>

namespace smseg::frontend {

namespace {
constexpr std::array<EnumName<KeypointMethod>, 4> kKeypointMethodNames{{{KeypointMethod::Sift, "sift"},
                                                                       {KeypointMethod::Orb, "orb"},
                                                                       {KeypointMethod::Akaze, "akaze"},
                                                                       {KeypointMethod::Gftt, "gftt"}}};
constexpr std::array<EnumName<FrameTracker>, 2> kFrameTrackerNames{
    {{FrameTracker::Descriptors, "descriptors"}, {FrameTracker::Klt, "klt"}}};
}  // namespace

KeypointMethod parse_keypoint_method(const std::string& name, const std::string& field) {
  return value_named(kKeypointMethodNames, name, field);
}
const char* keypoint_method_name(KeypointMethod m) { return name_of(kKeypointMethodNames, m); }
FrameTracker parse_frame_tracker(const std::string& name, const std::string& field) {
  return value_named(kFrameTrackerNames, name, field);
}
const char* frame_tracker_name(FrameTracker t) { return name_of(kFrameTrackerNames, t); }

FrameTracker parse_stereo_tracker(const std::string& name, const std::string& field) {
  return name == "auto" ? FrameTracker::Klt : parse_frame_tracker(name, field);
}

KeypointMethod default_keypoints(FrameTracker t) {
  return t == FrameTracker::Klt ? KeypointMethod::Gftt : KeypointMethod::Sift;
}

KeypointMethod parse_keypoint_method(const std::string& name, FrameTracker tracker, const std::string& field) {
  return name == "auto" ? default_keypoints(tracker) : parse_keypoint_method(name, field);
}

void KltOptions::validate(const std::string& prefix) const {
  if (window < 5 || window > 101) throw Error("", prefix + ".klt_window", "must be in 5..101");
  if (!(max_backward_px > 0)) throw Error("", prefix + ".klt_max_backward_px", "must be positive");
  if (!(min_distance_px >= 0)) throw Error("", prefix + ".klt_min_distance_px", "must be >= 0");
}

void TrackingOptions::validate() const {
  if (max_keypoints < 1 || max_keypoints > 100000)
    throw Error("", "tracking.max_keypoints", "must be in 1..100000, got " + std::to_string(max_keypoints));
  if (!(sift_contrast_threshold > 0 && sift_contrast_threshold < 1))
    throw Error("", "tracking.sift_contrast_threshold", "must be in (0, 1)");
  if (!(akaze_threshold > 0 && akaze_threshold < 1)) throw Error("", "tracking.akaze_threshold", "must be in (0, 1)");
  if (!(gftt_quality > 0 && gftt_quality < 1)) throw Error("", "tracking.gftt_quality", "must be in (0, 1)");
  if (!(max_descriptor_distance >= 0)) throw Error("", "tracking.max_descriptor_distance", "must be >= 0 (0 = off)");
  if (!(max_pixel_motion >= 0)) throw Error("", "tracking.max_pixel_motion", "must be >= 0 (0 = off)");
}

void TrackFilterOptions::validate() const {
  if (min_frames < 1 || min_frames > 100000)
    throw Error("", "filters.min_frames", "must be in 1..100000, got " + std::to_string(min_frames));
}

int descriptor_norm(KeypointMethod m) { return m == KeypointMethod::Sift ? cv::NORM_L2 : cv::NORM_HAMMING; }

FrameKeypoints detect_keypoints(const cv::Mat& gray, const TrackingOptions& o) {
  if (gray.empty() || gray.type() != CV_8UC1) throw Error("", "image", "keypoint detection needs a CV_8UC1 image");
  cv::Ptr<cv::Feature2D> det;
  switch (o.detector) {
    case KeypointMethod::Sift: det = cv::SIFT::create(o.max_keypoints, 3, o.sift_contrast_threshold); break;
    case KeypointMethod::Orb: det = cv::ORB::create(o.max_keypoints); break;
    case KeypointMethod::Akaze:
      det = cv::AKAZE::create(cv::AKAZE::DESCRIPTOR_MLDB, 0, 3, static_cast<float>(o.akaze_threshold));
      break;
    case KeypointMethod::Gftt: det = cv::GFTTDetector::create(o.max_keypoints, o.gftt_quality, 4.0, 3); break;
  }
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  if (o.detector == KeypointMethod::Gftt)
    det->detect(gray, kps);  // positions only
  else
    det->detectAndCompute(gray, cv::noArray(), kps, desc);
  // Strongest first, ties by position, capped: deterministic whatever the detector's own order.
  std::vector<int> order(kps.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    if (kps[a].response != kps[b].response) return kps[a].response > kps[b].response;
    if (kps[a].pt.y != kps[b].pt.y) return kps[a].pt.y < kps[b].pt.y;
    if (kps[a].pt.x != kps[b].pt.x) return kps[a].pt.x < kps[b].pt.x;
    return kps[a].size < kps[b].size;
  });
  if (static_cast<int>(order.size()) > o.max_keypoints) order.resize(o.max_keypoints);
  FrameKeypoints out;
  out.keypoints.reserve(order.size());
  if (!order.empty() && !desc.empty()) out.descriptors.create(static_cast<int>(order.size()), desc.cols, desc.type());
  for (std::size_t i = 0; i < order.size(); ++i) {
    out.keypoints.push_back(kps[order[i]]);
    if (!desc.empty()) desc.row(order[i]).copyTo(out.descriptors.row(static_cast<int>(i)));
  }
  return out;
}

std::vector<cv::Point2f> klt_step(const cv::Mat& prev_img, const std::vector<cv::Point2f>& prev_px, const cv::Mat& img,
                                  const std::vector<cv::Point2f>& detected, int max_points, const KltOptions& o,
                                  std::vector<cv::DMatch>& matches) {
  matches.clear();
  std::vector<cv::Point2f> px;
  if (img.empty() || img.type() != CV_8UC1) throw Error("", "image", "KLT tracking needs a CV_8UC1 image");
  if (!prev_px.empty()) {
    if (prev_img.size() != img.size() || prev_img.type() != img.type())
      throw Error("", "image", "KLT tracking needs two images of one size and type");
    const cv::Size win(o.window, o.window);
    const cv::TermCriteria crit(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, 0.01);
    const cv::Rect2f inside(0, 0, static_cast<float>(img.cols - 1), static_cast<float>(img.rows - 1));
    std::vector<cv::Point2f> fwd, back;
    std::vector<std::uint8_t> st1, st2;
    std::vector<float> err;
    cv::calcOpticalFlowPyrLK(prev_img, img, prev_px, fwd, st1, err, win, 3, crit);
    cv::calcOpticalFlowPyrLK(img, prev_img, fwd, back, st2, err, win, 3, crit);
    for (std::size_t i = 0; i < fwd.size(); ++i) {
      if (!st1[i] || !st2[i] || !inside.contains(fwd[i])) continue;
      if (cv::norm(back[i] - prev_px[i]) > o.max_backward_px) continue;
      matches.emplace_back(static_cast<int>(i), static_cast<int>(px.size()), 0.f);
      px.push_back(fwd[i]);
    }
  }
  // New points where no kept one is near: a grid of min_distance cells, neighbours checked in 3x3 cells.
  const float cell = static_cast<float>(std::max(1.0, o.min_distance_px));
  const float min_dist2 = static_cast<float>(o.min_distance_px * o.min_distance_px);
  const int gw = static_cast<int>(img.cols / cell) + 2, gh = static_cast<int>(img.rows / cell) + 2;
  std::vector<std::vector<cv::Point2f>> grid(static_cast<std::size_t>(gw) * gh);
  auto cell_of = [&](const cv::Point2f& p) {
    return std::pair<int, int>(std::clamp(static_cast<int>(p.x / cell), 0, gw - 1),
                               std::clamp(static_cast<int>(p.y / cell), 0, gh - 1));
  };
  for (const auto& p : px) {
    const auto [gx, gy] = cell_of(p);
    grid[static_cast<std::size_t>(gy) * gw + gx].push_back(p);
  }
  for (const auto& p : detected) {
    if (static_cast<int>(px.size()) >= max_points) break;
    const auto [gx, gy] = cell_of(p);
    bool near = false;
    for (int dy = -1; dy <= 1 && !near; ++dy)
      for (int dx = -1; dx <= 1 && !near; ++dx) {
        const int x = gx + dx, y = gy + dy;
        if (x < 0 || y < 0 || x >= gw || y >= gh) continue;
        for (const auto& q : grid[static_cast<std::size_t>(y) * gw + x])
          if ((p - q).dot(p - q) < min_dist2) {
            near = true;
            break;
          }
      }
    if (near) continue;
    px.push_back(p);
    grid[static_cast<std::size_t>(gy) * gw + gx].push_back(p);
  }
  return px;
}

void drop_far_matches(std::vector<cv::DMatch>& matches, const std::vector<cv::Point2f>& pa,
                      const std::vector<cv::Point2f>& pb, const TrackingOptions& o) {
  std::erase_if(matches, [&](const cv::DMatch& d) {
    if (o.max_descriptor_distance > 0 && d.distance > o.max_descriptor_distance) return true;
    if (o.max_pixel_motion > 0) {
      const cv::Point2f v = pb[d.trainIdx] - pa[d.queryIdx];
      if (std::hypot(v.x, v.y) > o.max_pixel_motion) return true;
    }
    return false;
  });
}

std::vector<cv::DMatch> match_symmetric(const cv::Mat& a, const cv::Mat& b, int norm) {
  std::vector<cv::DMatch> out;
  if (a.empty() || b.empty()) return out;
  if (a.cols != b.cols || a.type() != b.type())
    throw Error("", "descriptors", "the two descriptor sets differ in length or type");
  cv::Mat dist;
  const bool hamming = norm == cv::NORM_HAMMING || norm == cv::NORM_HAMMING2;
  cv::batchDistance(a, b, dist, hamming ? CV_32S : CV_32F, cv::noArray(), norm);
  if (dist.type() != CV_32F) dist.convertTo(dist, CV_32F);
  const int na = a.rows, nb = b.rows;
  std::vector<int> best_of_a(na, -1), best_of_b(nb, -1);
  std::vector<float> dist_a(na, std::numeric_limits<float>::infinity()),
      dist_b(nb, std::numeric_limits<float>::infinity());
  for (int i = 0; i < na; ++i) {
    const float* row = dist.ptr<float>(i);
    for (int j = 0; j < nb; ++j) {
      const float d = row[j];
      if (d < dist_a[i]) dist_a[i] = d, best_of_a[i] = j;  // strict: ties keep the lower index
      if (d < dist_b[j]) dist_b[j] = d, best_of_b[j] = i;
    }
  }
  for (int i = 0; i < na; ++i) {
    const int j = best_of_a[i];
    if (j >= 0 && best_of_b[j] == i) out.emplace_back(i, j, dist_a[i]);
  }
  return out;
}

Eigen::Vector3d backproject(double x, double y, double d, double fx, double fy, double cx, double cy,
                            double baseline) {
  const double Z = fx * baseline / d;
  return {(x - cx) * Z / fx, (y - cy) * Z / fy, Z};
}

FrameObservations observe_keypoints(const std::vector<cv::KeyPoint>& kps, const cv::Mat& disparity,
                                    const cv::Mat& labels, const sequence::Calibration& calib) {
  std::vector<cv::Point2f> pixels;
  pixels.reserve(kps.size());
  for (const auto& k : kps) pixels.push_back(k.pt);
  return observe_points(pixels, disparity, labels, calib);
}

FrameObservations observe_points(const std::vector<cv::Point2f>& pixels, const cv::Mat& disparity, const cv::Mat& labels,
                                 const sequence::Calibration& calib) {
  return observe_sampled(pixels, FrameDisparity(disparity).sample(pixels), labels, calib);
}

FrameObservations observe_sampled(const std::vector<cv::Point2f>& pixels, const std::vector<float>& disparities,
                                  const cv::Mat& labels, const sequence::Calibration& calib) {
  if (disparities.size() != pixels.size()) throw Error("", "disparity", "one disparity per pixel needed");
  if (!calib.fx || !calib.baseline) throw Error("", "calibration", "stereo needs fx and the baseline");
  const double fx = *calib.fx, fy = calib.fy.value_or(fx), B = *calib.baseline;
  FrameObservations f;
  const std::size_t n = pixels.size();
  f.pixels = pixels;
  f.disparities.resize(n);
  f.points.assign(n, Eigen::Vector3d::Zero());
  f.labels.assign(n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    const cv::Point2f p = pixels[i];
    const float d = disparities[i];
    const bool ok = std::isfinite(d) && d > 0;
    f.disparities[i] = ok ? d : kInvalidDisparity;
    if (ok) f.points[i] = backproject(p.x, p.y, d, fx, fy, calib.cx, calib.cy, B);
    if (!labels.empty()) {
      const int x = std::clamp(static_cast<int>(std::lround(p.x)), 0, labels.cols - 1);
      const int y = std::clamp(static_cast<int>(std::lround(p.y)), 0, labels.rows - 1);
      const std::uint8_t l = labels.at<std::uint8_t>(y, x);
      f.labels[i] = l == sequence::kVoid ? -1 : l;
    }
  }
  return f;
}

std::vector<std::vector<int>> chain_matches(const std::vector<int>& counts,
                                            const std::vector<std::vector<cv::DMatch>>& matches, int* track_count) {
  const std::size_t n = counts.size();
  if (n > 0 && matches.size() != n - 1)
    throw Error("", "matches", "need one match list per consecutive frame pair");
  std::vector<std::vector<int>> id(n);
  int next = 0;
  for (std::size_t t = 0; t < n; ++t) {
    id[t].assign(counts[t], -1);
    if (t > 0) {
      for (const auto& m : matches[t - 1]) {
        if (m.queryIdx < 0 || m.queryIdx >= counts[t - 1] || m.trainIdx < 0 || m.trainIdx >= counts[t])
          throw Error("", "matches", "match index out of range in frame pair " + std::to_string(t - 1));
        if (id[t][m.trainIdx] != -1)
          throw Error("", "matches", "keypoint matched twice in frame " + std::to_string(t));
        id[t][m.trainIdx] = id[t - 1][m.queryIdx];
      }
    }
    for (int& v : id[t])
      if (v == -1) v = next++;
  }
  if (track_count) *track_count = next;
  return id;
}

std::vector<Track> build_tracks(const std::vector<FrameObservations>& frames,
                                const std::vector<std::vector<cv::DMatch>>& matches, const TrackFilterOptions& opt,
                                FilterCounts& c, std::vector<Track>* after_disparity) {
  opt.validate();
  c = FilterCounts{};
  std::vector<int> counts;
  for (const auto& f : frames) counts.push_back(static_cast<int>(f.pixels.size()));
  int ntracks = 0;
  const auto id = chain_matches(counts, matches, &ntracks);
  c.tracks = ntracks;
  std::vector<Track> all(ntracks);
  for (std::size_t t = 0; t < frames.size(); ++t) {
    const auto& f = frames[t];
    for (std::size_t i = 0; i < f.pixels.size(); ++i) {
      ++c.observations;
      if (!(f.disparities[i] > 0)) {  // filter 1: no valid disparity
        ++c.removed_no_disparity_obs;
        continue;
      }
      Track& tr = all[id[t][i]];
      tr.frames.push_back(static_cast<int>(t));
      tr.pixels.push_back(f.pixels[i]);
      tr.disparities.push_back(f.disparities[i]);
      tr.points.push_back(f.points[i]);
      tr.labels.push_back(f.labels.empty() ? -1 : f.labels[i]);
    }
  }
  std::vector<Track> kept;
  std::vector<Track> after1;
  for (auto& tr : all) {
    if (tr.size() == 0) {
      ++c.removed_no_disparity_tracks;
      continue;
    }
    if (after_disparity) after1.push_back(tr);
    if (static_cast<int>(tr.size()) < opt.min_frames) {  // filter 2: too short
      ++c.removed_short_tracks;
      c.removed_short_obs += static_cast<long>(tr.size());
      continue;
    }
    int label = -1;
    bool consistent = true;
    for (int l : tr.labels) {
      if (l < 0) continue;
      if (label < 0) label = l;
      else if (l != label) consistent = false;
    }
    if (label < 0) {  // filter 3: never labelled (counted always, removed for training)
      ++c.unlabelled_tracks;
      c.unlabelled_obs += static_cast<long>(tr.size());
      if (opt.require_label) continue;
    }
    if (!consistent) {  // filter 4: inconsistent labels (counted always, removed for training)
      ++c.removed_inconsistent_tracks;
      c.removed_inconsistent_obs += static_cast<long>(tr.size());
      if (opt.require_label) continue;
      label = -1;  // no class of its own
    }
    tr.label = label;
    ++c.kept_tracks;
    c.kept_obs += static_cast<long>(tr.size());
    kept.push_back(std::move(tr));
  }
  c.unlabelled_removed = opt.require_label;
  c.inconsistent_removed = opt.require_label;
  if (after_disparity) *after_disparity = std::move(after1);
  return kept;
}

}  // namespace smseg::frontend
