// Monocular visual odometry one frame at a time (mono_stream.hpp): the per-frame flow, tracking,
// initialisation and PnP. What a key frame does is in mono_stream_map.cpp.
#include "smseg/sfm/mono_stream.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "mono_stream_state.hpp"
#include "smseg/common/error.hpp"

namespace smseg::sfm {

using namespace mono_stream;
using sfm_matching::median;

namespace {

// The first pose of the stereo convention (initial_pose) as world to camera.
CamPose first_pose(double height) {
  const sequence::Pose p = frontend::initial_pose(height);
  CamPose P;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) P.R(c, r) = p.R[3 * r + c];
  P.t = -P.R * Eigen::Vector3d(p.t[0], p.t[1], p.t[2]);
  return P;
}

sequence::Pose camera_to_world(const CamPose& P) {
  sequence::Pose out;
  const Eigen::Vector3d c = P.centre();
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) out.R[3 * r + k] = P.R(k, r);
  out.t = {c.x(), c.y(), c.z()};
  return out;
}

void to_cv(const CamPose& P, cv::Mat& rvec, cv::Mat& tvec) {
  cv::Mat R;
  cv::eigen2cv(P.R, R);
  cv::Rodrigues(R, rvec);
  cv::eigen2cv(P.t, tvec);
}

// How many of the correspondences the pose reprojects within thr pixels.
int explained(const CamPose& P, const sfm_front_end::PnpProblem& pr, const Intrinsics& in, double thr) {
  int n = 0;
  for (std::size_t i = 0; i < pr.obj.size(); ++i) {
    const Eigen::Vector3d X(pr.obj[i].x, pr.obj[i].y, pr.obj[i].z);
    n += sfm_front_end::reprojection_error(P, X, cv::Point2f(pr.img[i]), in) <= thr;
  }
  return n;
}

// Levenberg-Marquardt on the correspondences that `start` reprojects within `gate` pixels.
bool refine_from(const CamPose& start, const sfm_front_end::PnpProblem& pr, const Intrinsics& in, const cv::Mat& K,
                 double gate, CamPose& out) {
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  for (std::size_t i = 0; i < pr.obj.size(); ++i) {
    const Eigen::Vector3d X(pr.obj[i].x, pr.obj[i].y, pr.obj[i].z);
    if (sfm_front_end::reprojection_error(start, X, cv::Point2f(pr.img[i]), in) > gate) continue;
    obj.push_back(pr.obj[i]);
    img.push_back(pr.img[i]);
  }
  if (obj.size() < 6) return false;
  cv::Mat rvec, tvec;
  to_cv(start, rvec, tvec);
  cv::solvePnPRefineLM(obj, img, K, cv::noArray(), rvec, tvec);
  return sfm_front_end::pose_from_cv(rvec, tvec, out);
}

}  // namespace

// ---- construction ----

MonoFrontEndStream::MonoFrontEndStream(const sequence::Calibration& calibration, std::optional<double> camera_height,
                                       cv::Size size, const SfmOptions& options, const std::string& source)
    : state_(std::make_unique<State>()) {
  options.validate();
  State& s = *state_;
  s.options = options;
  s.size = size;
  s.source = source;
  const std::optional<double> focal = options.focal ? options.focal : calibration.fx;
  if (!focal || !(*focal > 0))
    throw Error(source, "focal",
                "the monocular stream needs the focal length (--focal or the manifest's fx; a stream cannot "
                "self-calibrate: extract-features --motion sfm estimates one and prints it)");
  const std::optional<double> height = options.camera_height ? options.camera_height : camera_height;
  if (!height || !(*height > 0))
    throw Error(source, "camera_height", "the monocular stream takes its metric scale from the camera height: give it "
                                         "in the manifest or as --camera-height");
  s.height = *height;
  s.intrinsics.f = *focal;
  s.intrinsics.cx = calibration.cx;
  s.intrinsics.cy = calibration.cy;
  if (calibration.cx == 0 && calibration.cy == 0) {  // as sfm_camera: the image centre
    s.intrinsics.cx = (size.width - 1) / 2.0;
    s.intrinsics.cy = (size.height - 1) / 2.0;
  }
  s.K = s.intrinsics.K();
  s.pose = s.previous_pose = first_pose(s.height);
}

MonoFrontEndStream::~MonoFrontEndStream() = default;
MonoFrontEndStream::MonoFrontEndStream(MonoFrontEndStream&&) noexcept = default;

double MonoFrontEndStream::focal() const { return state_->intrinsics.f; }
const MonoStreamCounts& MonoFrontEndStream::counts() const { return state_->counts; }

frontend::StereoFrontEndStream::Prepared MonoFrontEndStream::prepare(const cv::Mat& gray) const {
  if (gray.type() != CV_8UC1 || gray.empty()) throw Error(state_->source, "frame", "must be an 8-bit grey image");
  frontend::StereoFrontEndStream::Prepared p;
  p.left = gray.clone();  // kept as the previous image: the caller may reuse its buffer
  const auto t0 = Clock::now();
  p.keypoints = frontend::detect_keypoints(gray, state_->options.tracking);
  p.ms.keypoints = ms_since(t0);
  return p;
}

// ---- per frame ----

frontend::StreamFrame MonoFrontEndStream::advance(frontend::StereoFrontEndStream::Prepared&& in) {
  State& s = *state_;
  if (in.left.size() != s.size)
    throw Error(s.source, "frame " + std::to_string(s.index),
                "is " + std::to_string(in.left.cols) + "x" + std::to_string(in.left.rows) + ", the stream is " +
                    std::to_string(s.size.width) + "x" + std::to_string(s.size.height));
  frontend::StreamFrame out;
  out.index = s.index;
  out.ms = in.ms;
  auto t0 = Clock::now();
  std::vector<cv::Point2f> px;
  std::vector<int> ids;
  s.follow(in, px, ids);
  out.ms.tracking = ms_since(t0);
  t0 = Clock::now();
  const CamPose before = s.pose;
  frontend::PairMotion pm;
  if (s.reference_frame < 0) s.start_reference(px, ids);
  const CamPose predicted = s.predicted_pose();
  if (s.mapped) {
    CamPose P;
    pm.inliers = s.pose_by_pnp(px, ids, P, pm.points);
    pm.ok = pm.inliers >= s.options.min_pnp_points;
    s.previous_pose = s.pose;
    s.pose = pm.ok ? P : predicted;
    s.have_previous = true;
    if (!pm.ok) s.start_reference(px, ids);  // lost: a new map from this frame on
  } else {
    if (s.world_placed) {
      s.previous_pose = s.pose;
      s.pose = predicted;
    }
    pm.ok = s.try_initialise(px, ids);
  }
  if (s.mapped && s.is_keyframe(px, ids))
    s.add_keyframe(px, ids);
  else if (s.mapped && pm.ok)
    s.triangulate_new(px, ids);  // points as soon as their rays part, not only at key frames
  s.counts.posed += pm.ok;
  s.counts.bridged += !pm.ok && s.world_placed;
  s.counts.unposed += !s.world_placed;
  if (s.index > 0) {
    pm.bridged = !pm.ok;
    pm.motion.R = s.pose.R * before.R.transpose();
    pm.motion.t = s.pose.t - pm.motion.R * before.t;
    out.motion = pm;
  }
  s.handover(px, ids, out);
  s.forget_dead_tracks(ids);
  s.prev_px = std::move(px);
  s.prev_ids = std::move(ids);
  s.prev_img = in.left;
  out.ms.motion = ms_since(t0);
  s.counts.seconds_motion += out.ms.motion / 1000;
  ++s.counts.frames;
  ++s.index;
  return out;
}

void MonoFrontEndStream::State::follow(const frontend::StereoFrontEndStream::Prepared& in, std::vector<cv::Point2f>& px,
                                       std::vector<int>& ids) {
  std::vector<cv::Point2f> detected;
  detected.reserve(in.keypoints.keypoints.size());
  for (const cv::KeyPoint& k : in.keypoints.keypoints) detected.push_back(k.pt);
  counts.keypoints += static_cast<long>(detected.size());
  std::vector<cv::DMatch> matches;
  px = frontend::klt_step(prev_img, prev_px, in.left, detected, options.tracking.max_keypoints, options.klt, matches);
  if (prev_px.empty()) matches.clear();
  // As chain_matches: a followed point continues its track, the others start new ones in order.
  ids.assign(px.size(), -1);
  for (const cv::DMatch& m : matches) ids[m.trainIdx] = prev_ids[m.queryIdx];
  for (int& id : ids)
    if (id == -1) id = next_track++;
}

// The reference a new map starts from: this frame (its pose as it stands), its tracks and pixels.
void MonoFrontEndStream::State::start_reference(const std::vector<cv::Point2f>& px, const std::vector<int>& ids) {
  reference_frame = index;
  reference_pose = pose;
  reference_px = px;
  reference_ids = ids;
  mapped = false;
  keyframes.clear();
  for (auto& [id, t] : tracks) {
    t.has_point = false;
    t.keyframe_pixels.clear();
  }
}

CamPose MonoFrontEndStream::State::predicted_pose() const {
  if (!have_previous) return pose;
  CamPose P;  // the last step again: T_t+1 = T_t T_t-1^-1 T_t
  const Eigen::Matrix3d dR = pose.R * previous_pose.R.transpose();
  const Eigen::Vector3d dt = pose.t - dR * previous_pose.t;
  P.R = dR * pose.R;
  P.t = dR * pose.t + dt;
  return P;
}

bool MonoFrontEndStream::State::try_initialise(const std::vector<cv::Point2f>& px, const std::vector<int>& ids) {
  std::unordered_map<int, int> at;
  for (std::size_t i = 0; i < ids.size(); ++i) at[ids[i]] = static_cast<int>(i);
  std::vector<cv::Point2d> qa, qb;
  std::vector<int> common_ids;
  std::vector<double> motion;
  for (std::size_t k = 0; k < reference_ids.size(); ++k) {
    const auto it = at.find(reference_ids[k]);
    if (it == at.end()) continue;
    qa.emplace_back(reference_px[k]);
    qb.emplace_back(px[it->second]);
    common_ids.push_back(reference_ids[k]);
    motion.push_back(cv::norm(qb.back() - qa.back()));
  }
  if (qa.size() < 50) {  // the reference's tracks died before enough motion: start again here
    start_reference(px, ids);
    return false;
  }
  if (median(motion) < options.init_motion_px) return false;
  std::vector<std::uint8_t> mask;
  const cv::Mat E = cv::findEssentialMat(qa, qb, K, cv::RANSAC, 0.999, 1.0, 1000, mask);
  if (E.rows != 3 || E.cols != 3) return false;
  cv::Mat R, tv;
  if (cv::recoverPose(E, qa, qb, K, R, tv, mask) < 30) return false;
  CamPose A, B;
  cv::cv2eigen(R, B.R);
  cv::cv2eigen(tv, B.t);
  std::vector<std::pair<int, Eigen::Vector3d>> made;
  std::vector<double> angles;
  for (std::size_t k = 0; k < qa.size(); ++k) {
    Eigen::Vector3d X;
    if (!mask[k] || !sfm_front_end::triangulate(A, B, cv::Point2f(qa[k]), cv::Point2f(qb[k]), intrinsics,
                                                 options.reprojection_threshold_px, 0.0, X))
      continue;
    angles.push_back(sfm_front_end::ray_angle(X - A.centre(), X - B.centre()));
    if (angles.back() >= options.min_triangulation_angle_deg * M_PI / 180) made.emplace_back(common_ids[k], X);
  }
  if (made.size() < 30 || median(angles) < options.init_min_angle_deg * M_PI / 180) return false;
  return place_initial_map(B, made, px, ids);
}

int MonoFrontEndStream::State::pose_by_pnp(const std::vector<cv::Point2f>& px, const std::vector<int>& ids,
                                           CamPose& out, int& points) const {
  sfm_front_end::PnpProblem pr;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const auto it = tracks.find(ids[i]);
    if (it != tracks.end() && it->second.has_point) pr.add(it->second.point, px[i]);
  }
  points = static_cast<int>(pr.obj.size());
  if (points < options.min_pnp_points) return 0;
  const double thr = options.reprojection_threshold_px;
  // Two candidates: the prediction refined on what it explains (15 Hz video hardly moves between frames),
  // and RANSAC (P3P) refined on its inliers, for a jolt the prediction misses.
  CamPose best;
  int best_n = -1;
  auto consider = [&](const CamPose& P) {
    const int n = explained(P, pr, intrinsics, thr);
    if (n > best_n) {
      best_n = n;
      best = P;
    }
  };
  CamPose refined;
  const CamPose guess = predicted_pose();
  if (refine_from(guess, pr, intrinsics, K, 3 * thr, refined) && refine_from(refined, pr, intrinsics, K, thr, refined))
    consider(refined);
  if (best_n < 0.8 * static_cast<double>(pr.obj.size())) {
    cv::Mat rvec, tvec;
    std::vector<int> inliers;
    if (cv::solvePnPRansac(pr.obj, pr.img, K, cv::noArray(), rvec, tvec, false, 100, static_cast<float>(thr), 0.99,
                           inliers, cv::SOLVEPNP_AP3P) &&
        sfm_front_end::pose_from_cv(rvec, tvec, refined) && refine_from(refined, pr, intrinsics, K, thr, refined))
      consider(refined);
  }
  out = best;
  return std::max(0, best_n);
}

void MonoFrontEndStream::State::handover(const std::vector<cv::Point2f>& px, const std::vector<int>& ids,
                                         frontend::StreamFrame& out) {
  out.pose = world_placed ? camera_to_world(pose) : frontend::initial_pose(height);
  std::vector<int> order(ids.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return ids[a] < ids[b]; });
  out.live_tracks.reserve(ids.size());
  for (int i : order) {
    out.live_tracks.push_back(ids[i]);
    TrackState& t = tracks[ids[i]];
    if (!mapped || !t.has_point) continue;
    const Eigen::Vector3d xc = pose.R * t.point + pose.t;
    const double error = sfm_front_end::reprojection_error(pose, t.point, px[i], intrinsics);
    if (!(xc.z() > 0) || error > options.reprojection_threshold_px) continue;
    ++counts.observations;
    counts.reprojection_sq += error * error;
    frontend::StreamObservation o;
    o.track = ids[i];
    o.pixel = px[i];
    o.disparity = static_cast<float>(1 / xc.z());  // mono: inverse depth, as the SfM's tracks
    o.point = xc;
    o.seen = ++t.seen;
    out.observations.push_back(o);
  }
}

void MonoFrontEndStream::State::forget_dead_tracks(const std::vector<int>& ids) {
  std::unordered_map<int, TrackState> live;
  live.reserve(ids.size());
  for (int id : ids) {
    auto it = tracks.find(id);
    if (it != tracks.end()) live.emplace(id, std::move(it->second));
  }
  tracks.swap(live);
}

}  // namespace smseg::sfm
