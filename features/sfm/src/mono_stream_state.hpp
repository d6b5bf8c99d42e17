#pragma once
// The state of MonoFrontEndStream (mono_stream.hpp): the tracks of the current frame, the map (a point per
// track that has one) and the window of key frames. mono_stream.cpp holds the per-frame flow
// (tracking, initialisation, PnP, the frame's observations), mono_stream_map.cpp what a key frame does
// (triangulation, local bundle adjustment, the ground plane's scale). Private to the sfm module.
#include <chrono>
#include <deque>
#include <optional>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "sfm_front_end.hpp"
#include "smseg/sfm/mono_stream.hpp"

namespace smseg::sfm::mono_stream {

using sfm_front_end::CamPose;
using sfm_front_end::Intrinsics;
using Clock = std::chrono::steady_clock;
inline double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// What the stream knows of one live track.
struct TrackState {
  bool has_point = false;
  Eigen::Vector3d point{0, 0, 0};  ///< world, metres
  int seen = 0;                    ///< valid observations handed on so far
  /// Its observations in key frames: (key frame number, pixel), oldest first.
  std::vector<std::pair<int, cv::Point2f>> keyframe_pixels;
};

struct Keyframe {
  int number = 0;  ///< key frames counted from 0
  int frame = 0;
  CamPose pose;    ///< world to camera
};

}  // namespace smseg::sfm::mono_stream

namespace smseg::sfm {

struct MonoFrontEndStream::State {
  using CamPose = mono_stream::CamPose;
  using Intrinsics = mono_stream::Intrinsics;
  SfmOptions options;
  Intrinsics intrinsics;
  cv::Mat K;
  cv::Size size;
  double height = 0;  ///< camera height, metres
  std::string source;
  MonoStreamCounts counts;

  int index = 0, next_track = 0;
  cv::Mat prev_img;
  std::vector<cv::Point2f> prev_px;
  std::vector<int> prev_ids;
  std::unordered_map<int, mono_stream::TrackState> tracks;

  // Initialisation: whether the world has been placed (the first initialisation), whether a map is live,
  // and the reference frame a new map starts from.
  bool world_placed = false, mapped = false;
  int reference_frame = -1;
  CamPose reference_pose;  ///< world to camera of the reference frame (after the world is placed)
  std::vector<int> reference_ids;
  std::vector<cv::Point2f> reference_px;

  // Poses (world to camera): the last two, for the constant-velocity prediction.
  CamPose pose, previous_pose;
  bool have_previous = false;
  std::deque<mono_stream::Keyframe> keyframes;
  int keyframe_count = 0;
  std::vector<cv::Point2f> keyframe_px;  ///< the last key frame's pixels of the current ids (for its motion)
  std::vector<int> keyframe_ids;

  // Per frame (mono_stream.cpp).
  void follow(const frontend::StereoFrontEndStream::Prepared& in, std::vector<cv::Point2f>& px, std::vector<int>& ids);
  bool try_initialise(const std::vector<cv::Point2f>& px, const std::vector<int>& ids);
  void start_reference(const std::vector<cv::Point2f>& px, const std::vector<int>& ids);
  bool place_initial_map(const CamPose& B, const std::vector<std::pair<int, Eigen::Vector3d>>& made,
                         const std::vector<cv::Point2f>& px, const std::vector<int>& ids);
  int pose_by_pnp(const std::vector<cv::Point2f>& px, const std::vector<int>& ids, CamPose& out, int& points) const;
  CamPose predicted_pose() const;
  void handover(const std::vector<cv::Point2f>& px, const std::vector<int>& ids, frontend::StreamFrame& out);

  // Key frames (mono_stream_map.cpp).
  bool is_keyframe(const std::vector<cv::Point2f>& px, const std::vector<int>& ids) const;
  void add_keyframe(const std::vector<cv::Point2f>& px, const std::vector<int>& ids);
  void triangulate_new(const std::vector<cv::Point2f>& px, const std::vector<int>& ids);
  const mono_stream::Keyframe* keyframe(int number) const;
  void adjust_window(const std::vector<cv::Point2f>& px, const std::vector<int>& ids);
  void correct_scale(const std::vector<int>& ids);
  /// The height of camera `at` (world to camera) above the ground along `up` (world), from those of
  /// `points` it sees in the lower part of the image and below itself; nullopt with fewer than
  /// min_inliers of them in the ground's band (`inliers`: how many are).
  std::optional<double> height_above_ground(const CamPose& at, const Eigen::Vector3d& up,
                                            const std::vector<Eigen::Vector3d>& points, int min_inliers,
                                            int* inliers) const;
  void scale_about(const Eigen::Vector3d& centre, double factor);
  void forget_dead_tracks(const std::vector<int>& ids);
};

}  // namespace smseg::sfm
