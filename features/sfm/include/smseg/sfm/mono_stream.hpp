#pragma once
// Monocular visual odometry one frame at a time, for live video (label-stream on a mono sequence, and the
// "vo" front end of extract-features): what is known of frame t is computed from frames 0..t alone and
// never revised afterwards, so the whole-sequence run (run_mono_stream_front_end) and a live stream give
// the same poses and points, frame for frame (tests/eval/test_label_stream_mono.cpp).
//
// Per frame:
//   1. Keypoints (prepare, any thread): Shi-Tomasi corners unless another detector is chosen; KLT follows
//      the previous frame's points forward-backward checked and the new corners fill the gaps (klt_step,
//      as the stereo stream). Track ids count up in order of first appearance.
//   2. Initialisation: the first frame that has moved init_motion_px (median) from the reference frame is
//      posed against it by the essential matrix (RANSAC, recoverPose); the common tracks are triangulated
//      and the pair is accepted when the median ray angle reaches init_min_angle_deg. The map is scaled
//      so that the reference camera stands camera_height above the ground: a level plane fitted to the
//      triangulated points in the lower part of the image (ground_min_row_share below the centre), its
//      height the median of the densest band of their depths below the camera (a band 2 ground_threshold
//      of their median depth wide). The first initialisation also places the world: the
//      reference camera level (the stereo front end's assumption and convention: Y up, the origin on the
//      ground under it); a later one keeps the world of the path. Frames before the first
//      initialisation keep the first pose (initial_pose) and give no points.
//   3. Pose by PnP against the map (RANSAC, then Levenberg-Marquardt on its inliers; the refinement from
//      the constant-velocity prediction competes, and the pose explaining more points wins). Fewer than
//      min_pnp_points inliers: the frame is bridged by constant velocity and the map is started again
//      from it (step 2, keeping the world).
//   4. Every posed frame triangulates the tracks without a point between their oldest observation in the
//      last 20 key frames and itself (angle at least min_triangulation_angle_deg, reprojection within
//      reprojection_threshold_px in both views). Key frames, when the median track motion since the last
//      one exceeds keyframe_motion_px or half of its tracks are lost: a local bundle adjustment (Ceres,
//      bundle_adjust) refines the last ba_window key frames (the two oldest fixed) and their points; then
//      the camera's height above the ground is measured again as in step 2 (along world Y, at least
//      ground_min_inliers points in the band) and the map is scaled about the current camera a damped
//      step (0.3 of the way in log, at most 5 %) towards camera_height above it, so that one band on a
//      kerb or a car does not jump the path.
//   5. The frame's observations: its tracks with a map point that the pose explains, each point in the
//      camera frame (metres) as known now, with the number of such observations its track has had.
//
// Deterministic: OpenCV's RANSACs draw from fixed seeds, Ceres runs on one thread.

#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "smseg/frontend/stream.hpp"
#include "smseg/sequence/sequence.hpp"
#include "smseg/sfm/sfm.hpp"

namespace smseg::sfm {

/// What the stream has done so far (the summary of a whole-sequence run).
struct MonoStreamCounts {
  int frames = 0, posed = 0, bridged = 0, unposed = 0, initialisations = 0, keyframes = 0;
  long keypoints = 0;
  long observations = 0;          ///< handed on
  double reprojection_sq = 0;     ///< their squared reprojection errors (pixels^2), summed
  double scale = 0;             ///< metres per unit of the last initialisation
  int ground_inliers = 0;       ///< of the last initialisation's plane
  double seconds_motion = 0;    ///< PnP, triangulation, adjustment and scale, all frames
  double seconds_ba = 0;        ///< bundle adjustment alone (included in seconds_motion)
};

class MonoFrontEndStream {
 public:
  /// `options` as SfmOptions take them (focal, camera height, KLT, key frames, window, thresholds, seed;
  /// the tracker is always KLT). The focal length is the options', else the calibration's fx (Error
  /// naming `source` without either: a stream cannot self-calibrate); the camera height the options',
  /// else `camera_height`. `size`: the frames' size (the principal point defaults to its centre).
  MonoFrontEndStream(const sequence::Calibration& calibration, std::optional<double> camera_height, cv::Size size,
                     const SfmOptions& options, const std::string& source);
  ~MonoFrontEndStream();
  MonoFrontEndStream(MonoFrontEndStream&&) noexcept;

  /// Keypoints of one 8-bit grey image: callable from any thread, for several frames at once.
  frontend::StereoFrontEndStream::Prepared prepare(const cv::Mat& gray) const;
  /// The next frame, in order (Error when its size differs from the stream's).
  frontend::StreamFrame advance(frontend::StereoFrontEndStream::Prepared&& frame);
  frontend::StreamFrame push(const cv::Mat& gray) { return advance(prepare(gray)); }

  double focal() const;
  const MonoStreamCounts& counts() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

/// The stream run over the sequence's left images ([first_frame, last_frame) of the options): tracks of
/// the valid observations (those shorter than filters.min_frames dropped), the poses as each frame knew
/// them, pair motions derived from them, and the summary (summary.sfm: focal, key frames, frames posed
/// and bridged, scale). Errors as MonoFrontEndStream's, naming the manifest.
frontend::FrontEndResult run_mono_stream_front_end(const sequence::Sequence& seq, const SfmOptions& options);

}  // namespace smseg::sfm
