#include "smseg/features/tracking.hpp"

#include "smseg/features/stereo.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

namespace smseg::features {

KeypointMethod parse_keypoint_method(const std::string& name, const std::string& field) {
  if (name == "sift") return KeypointMethod::Sift;
  if (name == "orb") return KeypointMethod::Orb;
  if (name == "akaze") return KeypointMethod::Akaze;
  throw Error("", field, "unknown keypoint detector '" + name + "' (expected sift, orb or akaze)");
}

const char* keypoint_method_name(KeypointMethod m) {
  switch (m) {
    case KeypointMethod::Sift: return "sift";
    case KeypointMethod::Orb: return "orb";
    case KeypointMethod::Akaze: return "akaze";
  }
  return "?";
}

void TrackingOptions::validate() const {
  if (max_keypoints < 1 || max_keypoints > 100000)
    throw Error("", "tracking.max_keypoints", "must be in 1..100000, got " + std::to_string(max_keypoints));
  if (!(sift_contrast_threshold > 0 && sift_contrast_threshold < 1))
    throw Error("", "tracking.sift_contrast_threshold", "must be in (0, 1)");
  if (!(akaze_threshold > 0 && akaze_threshold < 1)) throw Error("", "tracking.akaze_threshold", "must be in (0, 1)");
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
  }
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
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
  if (!order.empty()) out.descriptors.create(static_cast<int>(order.size()), desc.cols, desc.type());
  for (std::size_t i = 0; i < order.size(); ++i) {
    out.keypoints.push_back(kps[order[i]]);
    desc.row(order[i]).copyTo(out.descriptors.row(static_cast<int>(i)));
  }
  return out;
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
                                    const cv::Mat& labels, const Calibration& calib) {
  if (disparity.type() != CV_32FC1) throw Error("", "disparity", "expected CV_32FC1");
  if (!calib.fx || !calib.baseline) throw Error("", "calibration", "stereo needs fx and the baseline");
  const double fx = *calib.fx, fy = calib.fy.value_or(fx), B = *calib.baseline;
  FrameObservations f;
  const std::size_t n = kps.size();
  f.pixels.resize(n);
  f.disparities.resize(n);
  f.points.assign(n, Eigen::Vector3d::Zero());
  f.labels.assign(n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    const cv::Point2f p = kps[i].pt;
    f.pixels[i] = p;
    const int x = std::clamp(static_cast<int>(std::lround(p.x)), 0, disparity.cols - 1);
    const int y = std::clamp(static_cast<int>(std::lround(p.y)), 0, disparity.rows - 1);
    const float d = disparity.at<float>(y, x);
    const bool ok = std::isfinite(d) && d > 0;
    f.disparities[i] = ok ? d : kInvalidDisparity;
    if (ok) f.points[i] = backproject(p.x, p.y, d, fx, fy, calib.cx, calib.cy, B);
    if (!labels.empty()) {
      const std::uint8_t l = labels.at<std::uint8_t>(y, x);
      f.labels[i] = l == kVoid ? -1 : l;
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

}  // namespace smseg::features
