#pragma once
// Keypoint tracks for the stereo front end (thesis 3.2.2, docs/design.md section 4 "Point tracking").
//
// The thesis's tracker (FrameTracker::Descriptors): keypoints (SIFT, the stand-in for the thesis's SURF;
// ORB and AKAZE selectable) are matched from each frame to the next by nearest descriptor in both
// directions, keeping only symmetric matches. The stereo front end's default is
// FrameTracker::Klt (klt_step: Shi-Tomasi corners followed by pyramidal Lucas-Kanade), which drifts
// less (docs/stereo.md). Chains of matches are tracks. Then the filters, in this order, each counting
// what it removed:
//   1. no valid disparity: observations (keypoint in a frame) whose pixel has no valid disparity are
//      dropped (the track keeps its other observations, so its frames may have gaps);
//   2. too short: tracks seen in fewer than `min_frames` frames (default 2) are dropped;
//   3. unlabelled (training only, `require_label`): tracks that never pass through a labelled frame
//      at a non-void pixel are dropped; without `require_label` they are only counted;
//   4. inconsistent labels (training only, `require_label`): tracks whose non-void labels disagree
//      between labelled frames are dropped; without `require_label` they are only counted (and have no
//      class). Filters 3 and 4 read the ground-truth labels: applied to frames that are then scored,
//      they would leak the answer into the features, so by default they only count.
// Disparity and label are read at the keypoint's nearest pixel.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "smseg/sequence/sequence.hpp"

namespace smseg::frontend {

/// Gftt: Shi-Tomasi corners (OpenCV's GFTTDetector), positions only, no descriptors: for KLT tracking.
enum class KeypointMethod { Sift, Orb, Akaze, Gftt };

/// "sift" | "orb" | "akaze" | "gftt"; anything else is an Error naming `field`.
KeypointMethod parse_keypoint_method(const std::string& name, const std::string& field = "tracking.detector");
const char* keypoint_method_name(KeypointMethod m);

struct TrackingOptions {
  KeypointMethod detector = KeypointMethod::Sift;
  int max_keypoints = 800;                ///< strongest keypoints kept per frame (>= 1)
  double sift_contrast_threshold = 0.02;  ///< SIFT: lower than OpenCV's 0.04 for more points, as the thesis did for SURF
  double akaze_threshold = 0.0005;        ///< AKAZE detector response threshold
  double gftt_quality = 0.001;            ///< GFTT: corners weaker than this share of the strongest are dropped (OpenCV suggests 0.01; 0.001 keeps the corners of weakly textured walls)
  double max_descriptor_distance = 0;     ///< matches farther apart in descriptor space are dropped (0 = off)
  double max_pixel_motion = 0;            ///< matches moving farther in the image (pixels) are dropped (0 = off)
  void validate() const;                  ///< Error("", "tracking.<field>", reason)
};

/// How keypoints are followed from one frame to the next.
enum class FrameTracker {
  Descriptors,  ///< keypoints detected in every frame, symmetric nearest-neighbour descriptor matches (the thesis)
  Klt           ///< pyramidal Lucas-Kanade from each point, forward-backward checked; new keypoints fill gaps
};
FrameTracker parse_frame_tracker(const std::string& name, const std::string& field);  ///< descriptors | klt
/// The stereo front end's tracker from a tool's option: "auto" (klt, the default) or parse_frame_tracker's.
FrameTracker parse_stereo_tracker(const std::string& name, const std::string& field);
const char* frame_tracker_name(FrameTracker t);

/// The keypoints a tracker is best served by: Shi-Tomasi corners for KLT (positions are all it needs),
/// SIFT for descriptor matching. The tools' `--keypoints auto`.
KeypointMethod default_keypoints(FrameTracker t);
/// `name` as parse_keypoint_method, or "auto": default_keypoints(tracker).
KeypointMethod parse_keypoint_method(const std::string& name, FrameTracker tracker, const std::string& field);

struct KltOptions {
  int window = 21;               ///< KLT window side, pixels (5..101)
  double max_backward_px = 0.5;  ///< forward-backward disagreement that drops a KLT match
  double min_distance_px = 6;    ///< a new keypoint this close to a tracked one is not added
  void validate(const std::string& prefix) const;  ///< Error("", prefix + ".klt_<field>", reason)
};

/// One KLT step: follows prev_px from prev_img into img (3-level pyramidal Lucas-Kanade), keeps the
/// points that come back within max_backward_px when tracked from img to prev_img and that stay inside
/// the image, then adds the `detected` points (in their order, strongest first) that lie at least
/// min_distance_px from every point kept so far, up to max_points in all. Returns the frame's points,
/// tracked ones first; `matches` receives (queryIdx in prev_px, trainIdx in the result) per tracked point.
/// An empty prev_px (first frame) gives the detected points alone.
std::vector<cv::Point2f> klt_step(const cv::Mat& prev_img, const std::vector<cv::Point2f>& prev_px, const cv::Mat& img,
                                  const std::vector<cv::Point2f>& detected, int max_points, const KltOptions& options,
                                  std::vector<cv::DMatch>& matches);

struct TrackFilterOptions {
  int min_frames = 2;          ///< a track must live in at least this many frames
  bool require_label = false;  ///< training only: drop tracks never labelled and tracks with inconsistent labels
  void validate() const;
};

/// Keypoints and descriptors of one image (CV_8UC1); at most max_keypoints, strongest first
/// (ties broken by position so the result is deterministic).
struct FrameKeypoints {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;  ///< one row per keypoint (CV_32F for SIFT, CV_8U for ORB/AKAZE)
};
FrameKeypoints detect_keypoints(const cv::Mat& gray, const TrackingOptions& options);

/// The descriptor norm for a detector (L2 for SIFT, Hamming for ORB/AKAZE).
int descriptor_norm(KeypointMethod m);

/// Symmetric nearest-neighbour matches between descriptor sets a and b: (i, j) is kept when j is the
/// nearest of i in b and i is the nearest of j in a (ties go to the lower index). queryIdx indexes a,
/// trainIdx indexes b; sorted by queryIdx. Empty sets give no matches.
std::vector<cv::DMatch> match_symmetric(const cv::Mat& a, const cv::Mat& b, int norm);

/// Drops the matches (queryIdx into pa, trainIdx into pb) farther apart than the options allow: in
/// descriptor space (max_descriptor_distance) or in the image (max_pixel_motion); 0 switches a test off.
void drop_far_matches(std::vector<cv::DMatch>& matches, const std::vector<cv::Point2f>& pa,
                      const std::vector<cv::Point2f>& pb, const TrackingOptions& options);

/// One track: a point seen in several frames. Parallel arrays, one entry per observation, frames
/// ascending.
struct Track {
  std::vector<int> frames;
  std::vector<cv::Point2f> pixels;
  std::vector<float> disparities;
  std::vector<Eigen::Vector3d> points;  ///< camera frame, metres (x right, y down, z forward)
  std::vector<int> labels;              ///< class position in labelled frames, -1 elsewhere or void
  int label = -1;                       ///< the track's (consistent) class, -1 when none
  std::size_t size() const { return frames.size(); }
};

/// Per frame, what the tracker needs of each keypoint.
struct FrameObservations {
  std::vector<cv::Point2f> pixels;
  std::vector<float> disparities;       ///< <= 0: no valid disparity
  std::vector<Eigen::Vector3d> points;  ///< camera frame; meaningful only where disparity > 0
  std::vector<int> labels;              ///< -1 when the frame is unlabelled or the pixel void
};

/// Back-projection of a pixel with disparity d: Z = fx*B/d, X = (x-cx)Z/fx, Y = (y-cy)Z/fy.
Eigen::Vector3d backproject(double x, double y, double d, double fx, double fy, double cx, double cy, double baseline);

/// Fills disparities/points (and labels when `labels` is not empty) for keypoints of one frame.
FrameObservations observe_keypoints(const std::vector<cv::KeyPoint>& keypoints, const cv::Mat& disparity,
                                    const cv::Mat& labels, const sequence::Calibration& calib);
FrameObservations observe_points(const std::vector<cv::Point2f>& pixels, const cv::Mat& disparity, const cv::Mat& labels,
                                 const sequence::Calibration& calib);
/// The same with each pixel's disparity given (disparities[i] for pixels[i], <= 0 or not finite: none).
FrameObservations observe_sampled(const std::vector<cv::Point2f>& pixels, const std::vector<float>& disparities,
                                  const cv::Mat& labels, const sequence::Calibration& calib);

/// What each filter removed, in observations ("points") and tracks.
struct FilterCounts {
  long observations = 0;  ///< keypoint observations before any filter
  long tracks = 0;        ///< tracks (chains) before any filter
  long removed_no_disparity_obs = 0, removed_no_disparity_tracks = 0;  ///< tracks left with no observation
  long removed_short_obs = 0, removed_short_tracks = 0;
  long unlabelled_obs = 0, unlabelled_tracks = 0;  ///< counted always; removed only with require_label
  bool unlabelled_removed = false;
  bool inconsistent_removed = false;  ///< filter 4 dropped what it counted (require_label)
  long removed_inconsistent_obs = 0, removed_inconsistent_tracks = 0;
  long kept_obs = 0, kept_tracks = 0;
};

/// Chains symmetric matches into tracks: matches[t] links frame t (queryIdx) to t+1 (trainIdx).
/// Every observation starts or continues exactly one track; track ids in order of first appearance.
/// Returns, per frame and keypoint, its track index.
std::vector<std::vector<int>> chain_matches(const std::vector<int>& keypoints_per_frame,
                                            const std::vector<std::vector<cv::DMatch>>& matches, int* track_count);

/// Builds the tracks from the chains and the per-frame observations, then applies the filters.
/// `after_disparity_filter` (optional) receives the tracks after filter 1 only (what motion uses).
std::vector<Track> build_tracks(const std::vector<FrameObservations>& frames,
                                const std::vector<std::vector<cv::DMatch>>& matches, const TrackFilterOptions& options,
                                FilterCounts& counts, std::vector<Track>* after_disparity_filter = nullptr);

}  // namespace smseg::frontend
