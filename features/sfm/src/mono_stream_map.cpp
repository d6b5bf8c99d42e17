// Monocular visual odometry one frame at a time (mono_stream.hpp): the map. The first map of an
// initialisation and the world it is placed in, and what a key frame does: triangulation of the new
// tracks, the local bundle adjustment, the ground plane's scale.
#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "mono_stream_state.hpp"

namespace smseg::sfm {

using namespace mono_stream;
using sfm_matching::median;

namespace {

// Key frames kept for triangulation (the bundle adjustment takes the last ba_window of them).
constexpr std::size_t kKeptKeyframes = 20;
// Each key frame moves the scale this share (in log) of the way towards the camera height the ground
// plane measures, and at most kMaxScaleStep: one plane fitted to a kerb or a car does not jump the path.
constexpr double kScaleGain = 0.3;
constexpr double kMaxScaleStep = 0.05;

}  // namespace

// The camera's height above the ground: the densest band of the candidates' depths below the camera
// along `up` (a level plane through the ground points, its offset found by a 1-D mode search), their
// median. A plane fitted freely (fit_ground_plane) tilts with the points' depth noise, and a tilt of 2
// degrees moves the height measured 10 m ahead by 35 cm: on KITTI and the synthetic corridor the free
// plane's heights came out low, and scaling the map to them made every depth 10-15 % too large.
std::optional<double> MonoFrontEndStream::State::height_above_ground(const CamPose& at, const Eigen::Vector3d& up,
                                                                     const std::vector<Eigen::Vector3d>& points,
                                                                     int min_inliers, int* inliers) const {
  const Eigen::Vector3d C = at.centre();
  std::vector<double> depths;
  const double lowest_row = intrinsics.cy + options.ground_min_row_share * size.height;
  for (const Eigen::Vector3d& X : points) {
    const Eigen::Vector3d xc = at.R * X + at.t;
    if (!(xc.z() > 0) || intrinsics.f * xc.y() / xc.z() + intrinsics.cy <= lowest_row) continue;
    const double h = (C - X).dot(up);
    if (h > 0) depths.push_back(h);
  }
  if (static_cast<int>(depths.size()) < std::max(3, min_inliers)) return std::nullopt;
  std::sort(depths.begin(), depths.end());
  const double band = 2 * options.ground_threshold * median(depths);
  std::size_t best = 0, best_count = 0;  // the band [depths[best], depths[best] + band] holding most
  for (std::size_t i = 0, j = 0; i < depths.size(); ++i) {
    while (j < depths.size() && depths[j] <= depths[i] + band) ++j;
    if (j - i >= best_count) {  // ties: the lower band (the ground lies under what stands on it)
      best_count = j - i;
      best = i;
    }
  }
  if (static_cast<int>(best_count) < std::max(3, min_inliers)) return std::nullopt;
  if (inliers) *inliers = static_cast<int>(best_count);
  return depths[best + best_count / 2];
}

bool MonoFrontEndStream::State::place_initial_map(const CamPose& B, const std::vector<std::pair<int, Eigen::Vector3d>>& made,
                                                  const std::vector<cv::Point2f>& px, const std::vector<int>& ids) {
  std::vector<Eigen::Vector3d> points;
  for (const auto& m : made) points.push_back(m.second);
  // The reference camera is the origin. Before the world is placed it is taken to be level (the stereo
  // front end's assumption; a plane fitted to the first pair's points tilts by degrees), after that
  // "up" is the world's, as the path has it.
  const Eigen::Vector3d up = world_placed ? Eigen::Vector3d(reference_pose.R.col(1)) : Eigen::Vector3d(0, -1, 0);
  int inliers = 0;
  // The first pair sees few ground points (KITTI: 5-15): any three give its first scale.
  const std::optional<double> h = height_above_ground(CamPose{}, up, points, 3, &inliers);
  const double s = height / h.value_or(1.0);  // no ground seen: one unit stands for the camera height
  // The map's metric coordinates (s times the reference camera's frame) into the world: X_w = Rwr X + Twr.
  Eigen::Matrix3d Rwr;
  Eigen::Vector3d Twr;
  if (!world_placed) {  // world Y up, Z the reference camera's axis, the origin on the ground under it
    Rwr = Eigen::Vector3d(-1, -1, 1).asDiagonal();
    Twr = Eigen::Vector3d(0, height, 0);
  } else {  // the reference frame's pose as the path stands
    Rwr = reference_pose.R.transpose();
    Twr = -reference_pose.R.transpose() * reference_pose.t;
  }
  for (const auto& [id, X] : made) {
    TrackState& t = tracks[id];
    t.point = Rwr * (s * X) + Twr;
    t.has_point = true;
  }
  reference_pose.R = Rwr.transpose();
  reference_pose.t = -Rwr.transpose() * Twr;
  pose.R = B.R * Rwr.transpose();
  pose.t = -pose.R * Twr + s * B.t;
  previous_pose = pose;
  have_previous = false;
  world_placed = mapped = true;
  ++counts.initialisations;
  counts.scale = s;
  counts.ground_inliers = inliers;
  keyframes.clear();
  keyframes.push_back({keyframe_count++, reference_frame, reference_pose});
  for (std::size_t k = 0; k < reference_ids.size(); ++k) {
    const auto it = tracks.find(reference_ids[k]);
    if (it != tracks.end()) it->second.keyframe_pixels.emplace_back(keyframes.back().number, reference_px[k]);
  }
  add_keyframe(px, ids);
  return true;
}

const Keyframe* MonoFrontEndStream::State::keyframe(int number) const {
  if (keyframes.empty() || number < keyframes.front().number) return nullptr;
  const std::size_t k = static_cast<std::size_t>(number - keyframes.front().number);
  return k < keyframes.size() ? &keyframes[k] : nullptr;
}

bool MonoFrontEndStream::State::is_keyframe(const std::vector<cv::Point2f>& px, const std::vector<int>& ids) const {
  std::unordered_map<int, int> at;
  for (std::size_t i = 0; i < keyframe_ids.size(); ++i) at[keyframe_ids[i]] = static_cast<int>(i);
  std::vector<double> motion;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const auto it = at.find(ids[i]);
    if (it != at.end()) motion.push_back(cv::norm(px[i] - keyframe_px[it->second]));
  }
  // Half the last key frame's tracks lost: a new one before the map thins out.
  return 2 * motion.size() < keyframe_ids.size() || median(motion) >= options.keyframe_motion_px;
}

void MonoFrontEndStream::State::add_keyframe(const std::vector<cv::Point2f>& px, const std::vector<int>& ids) {
  keyframes.push_back({keyframe_count++, index, pose});
  for (std::size_t i = 0; i < ids.size(); ++i) tracks[ids[i]].keyframe_pixels.emplace_back(keyframes.back().number, px[i]);
  triangulate_new(px, ids);
  const auto t0 = Clock::now();
  adjust_window(px, ids);
  counts.seconds_ba += ms_since(t0) / 1000;
  correct_scale(ids);
  while (keyframes.size() > std::max<std::size_t>(kKeptKeyframes, options.ba_window)) keyframes.pop_front();
  keyframe_px = px;
  keyframe_ids = ids;
  ++counts.keyframes;
}

// Tracks without a point, between their oldest kept key-frame observation and this key frame.
void MonoFrontEndStream::State::triangulate_new(const std::vector<cv::Point2f>& px, const std::vector<int>& ids) {
  const double min_angle = options.min_triangulation_angle_deg * M_PI / 180;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    TrackState& t = tracks[ids[i]];
    if (t.has_point) continue;
    for (const auto& [number, pixel] : t.keyframe_pixels) {
      const Keyframe* k = keyframe(number);
      if (!k) continue;
      if (k->frame == index) break;
      Eigen::Vector3d X;
      if (sfm_front_end::triangulate(k->pose, pose, pixel, px[i], intrinsics, options.reprojection_threshold_px,
                                     min_angle, X)) {
        t.point = X;
        t.has_point = true;
      }
      break;
    }
  }
}

// The last ba_window key frames (the two oldest fixed: the gauge) and the points of the live tracks seen
// in two of them; then the points this key frame cannot explain are dropped (their tracks may be
// triangulated again from here on).
void MonoFrontEndStream::State::adjust_window(const std::vector<cv::Point2f>& px, const std::vector<int>& ids) {
  const std::size_t w = std::min<std::size_t>(options.ba_window, keyframes.size());
  const std::size_t first = keyframes.size() - w;
  const int first_number = keyframes[first].number;
  std::vector<BaCamera> cams(w);
  for (std::size_t j = 0; j < w; ++j) {
    cams[j].R = keyframes[first + j].pose.R;
    cams[j].t = keyframes[first + j].pose.t;
    cams[j].fixed = j < 2;
  }
  std::vector<Eigen::Vector3d> points;
  std::vector<BaObservation> obs;
  std::vector<TrackState*> adjusted;
  for (int id : ids) {
    TrackState& t = tracks[id];
    if (!t.has_point) continue;
    const auto seen = std::count_if(t.keyframe_pixels.begin(), t.keyframe_pixels.end(),
                                    [&](const auto& o) { return o.first >= first_number; });
    if (seen < 2) continue;
    for (const auto& [number, pixel] : t.keyframe_pixels)
      if (number >= first_number) obs.push_back({number - first_number, static_cast<int>(points.size()), {pixel.x, pixel.y}});
    points.push_back(t.point);
    adjusted.push_back(&t);
  }
  if (!points.empty() && w > 2) {
    BaOptions ba;
    ba.iterations = options.ba_iterations;
    bundle_adjust(cams, points, obs, intrinsics.f, intrinsics.cx, intrinsics.cy, ba);
    for (std::size_t j = 2; j < w; ++j) keyframes[first + j].pose = {cams[j].R, cams[j].t};
    for (std::size_t k = 0; k < points.size(); ++k) adjusted[k]->point = points[k];
    pose = keyframes.back().pose;
  }
  for (std::size_t i = 0; i < ids.size(); ++i) {
    TrackState& t = tracks[ids[i]];
    if (!t.has_point ||
        sfm_front_end::reprojection_error(pose, t.point, px[i], intrinsics) <= 3 * options.reprojection_threshold_px)
      continue;
    t.has_point = false;
    t.keyframe_pixels.erase(t.keyframe_pixels.begin(), t.keyframe_pixels.end() - 1);
  }
}

void MonoFrontEndStream::State::correct_scale(const std::vector<int>& ids) {
  std::vector<Eigen::Vector3d> points;
  for (int id : ids) {
    const TrackState& t = tracks[id];
    if (t.has_point) points.push_back(t.point);
  }
  const std::optional<double> h =
      height_above_ground(pose, Eigen::Vector3d::UnitY(), points, options.ground_min_inliers, nullptr);
  if (!h) return;
  const double step = std::clamp(kScaleGain * std::log(height / *h), -kMaxScaleStep, kMaxScaleStep);
  scale_about(pose.centre(), std::exp(step));
}

// Scales the map (points, key frames, the previous pose) by `factor` about `centre`.
void MonoFrontEndStream::State::scale_about(const Eigen::Vector3d& centre, double factor) {
  for (auto& [id, t] : tracks)
    if (t.has_point) t.point = centre + factor * (t.point - centre);
  auto scale_pose = [&](CamPose& P) { P.t = -P.R * (centre + factor * (P.centre() - centre)); };
  for (Keyframe& k : keyframes) scale_pose(k.pose);
  scale_pose(previous_pose);
  scale_pose(pose);
}

}  // namespace smseg::sfm
