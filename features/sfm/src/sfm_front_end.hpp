#pragma once
// The monocular SfM front end as a class (run_mono_front_end, sfm.cpp; the pipeline and its decisions are
// in sfm.hpp). sfm.cpp holds its steps 1, 2 and 7 and the result, sfm_reconstruction.cpp the incremental
// reconstruction (steps 3-6) and its geometry. Private to the sfm module.
#include <chrono>
#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "smseg/common/progress.hpp"
#include "smseg/sfm/sfm.hpp"
#include "sfm_map.hpp"
#include "sfm_matching.hpp"

namespace smseg::sfm::sfm_front_end {

using sfm_map::MapCandidate;
using sfm_map::TrackTable;
using sfm_matching::PairInfo;
using Clock = std::chrono::steady_clock;
inline double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// World-to-camera pose in the reconstruction frame: X_c = R X + t.
struct CamPose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre() const { return -R.transpose() * t; }
};

/// How a frame got its pose: not at all, as one of the initial pair, by PnP, from a still neighbour, or
/// bridged (essential matrix to the previous frame, or the neighbour's pose).
enum class FrameStatus : std::uint8_t { None, Init, Pnp, Still, Bridged };

struct Intrinsics {
  double f = 1, cx = 0, cy = 0;
  cv::Mat K() const { return (cv::Mat_<double>(3, 3) << f, 0, cx, 0, f, cy, 0, 0, 1); }
};

/// Distance in pixels between px and the projection of X; infinite behind the camera.
double reprojection_error(const CamPose& P, const Eigen::Vector3d& X, const cv::Point2f& px, const Intrinsics& in);

/// The angle between two rays, radians.
double ray_angle(const Eigen::Vector3d& ra, const Eigen::Vector3d& rb);

/// Linear two-view triangulation (DLT on normalised coordinates), then the checks: positive depth,
/// reprojection error below thr in both views, angle between the rays at least min_angle (radians).
bool triangulate(const CamPose& A, const CamPose& B, const cv::Point2f& pa, const cv::Point2f& pb,
                 const Intrinsics& in, double thr, double min_angle, Eigen::Vector3d& X);

/// The pose of OpenCV's rotation vector and translation; false when not finite.
bool pose_from_cv(const cv::Mat& rvec, const cv::Mat& tvec, CamPose& P);

/// 2D-3D correspondences for PnP.
struct PnpProblem {
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  void add(const Eigen::Vector3d& X, const cv::Point2f& px) {
    obj.emplace_back(X.x(), X.y(), X.z());
    img.emplace_back(px.x, px.y);
  }
};

/// The best PnP pose so far and how many RANSAC inliers it explains (-1: none yet).
struct PoseChoice {
  int confirmed = -1;
  CamPose pose;
};

/// The points of the initial pair's triangulated common tracks (track, point) and their ray angles.
struct InitialPoints {
  std::vector<double> angles;
  std::vector<std::pair<int, Eigen::Vector3d>> made;
};

/// A bundle adjustment problem over key frames: its points are the tracks pt_track.
struct BaProblem {
  std::vector<BaCamera> cams;
  std::vector<Eigen::Vector3d> pts;
  std::vector<int> pt_track;
  std::vector<BaObservation> obs;
};

/// The monocular front end of run_mono_front_end, shaped as COLMAP's incremental mapper: a method per
/// step of the pipeline (numbered as in sfm.hpp), the state the steps share in members, and run()
/// going through the steps once:
///   1. track_klt or match_descriptors (keypoints, matches, their verification), chain_tracks;
///   2. choose_focal_length;
///   3-5. reconstruct: find_initial_pair, then register_frames: each later frame keeps a still
///      camera's pose or register_next_frame poses it (PnP, else bridge_by_essential), and
///      add_keyframe triangulates its new tracks and adjusts the local window;
///   6. complete (global adjustment, the other frames posed again, the remaining tracks
///      triangulated), then filter_observations;
///   7. place_in_world (ground plane, metric scale, world axes);
///   and assemble_result.
class MonoFrontEnd {
 public:
  /// `options` validated and their tracker resolved; wall0: when the run began (for the summary).
  MonoFrontEnd(const sequence::Sequence& seq, const SfmOptions& options, Clock::time_point wall0);
  frontend::FrontEndResult run();
  const SfmReport& report() const { return report_; }

 private:
  // 1. keypoints, matches, geometric verification (parallel per frame / pair), tracks
  void track_klt();
  std::vector<std::vector<cv::Point2f>> detect_positions();
  void match_descriptors();
  void detect_with_descriptors(int c0, int c1, Progress& progress);
  frontend::FrameKeypoints detect_frame(int i, std::vector<cv::Point2f>& positions);
  void match_pair(int t);
  void chain_tracks();
  // 2. focal length
  void choose_focal_length();
  void self_calibrate();
  std::vector<cv::Matx33d> focal_fundamentals() const;
  void moving_pair_from(int a, std::vector<cv::Point2f>& best_a, std::vector<cv::Point2f>& best_b) const;
  // 3-5. incremental reconstruction
  void reconstruct();
  std::vector<std::pair<int, int>> common(int a, int b) const;
  std::pair<double, int> median_motion(int a, int b) const;
  double observation_error(int t, int i, int tr) const;
  int relative_pose(const std::vector<cv::Point2d>& qa, const std::vector<cv::Point2d>& qb,
                    std::vector<std::uint8_t>& mask, cv::Mat& R, cv::Mat& tv) const;
  void find_initial_pair();
  void try_initial_pair(int a, int b);
  InitialPoints triangulate_initial(int a, int b, const CamPose& A, const CamPose& B,
                                    const std::vector<std::pair<int, int>>& cm,
                                    const std::vector<std::uint8_t>& mask) const;
  void accept_initial_pair(int a, int b, const CamPose& A, const CamPose& B, const InitialPoints& points);
  void register_frames(Progress& progress);
  void pose_by_pnp(int t, int neighbour, bool still_pair);
  void register_next_frame(int t);
  void bridge_by_essential(int t);
  double last_step_length(int t) const;
  bool is_new_keyframe(int t, int last_kf) const;
  void add_keyframe(int t);
  bool pnp(int t, const CamPose& guess, CamPose& out, const std::vector<MapCandidate>& candidates = {});
  PnpProblem pnp_correspondences(int t, const std::vector<MapCandidate>& candidates) const;
  int best_pnp_pose(const PnpProblem& problem, const std::vector<int>& inl, const cv::Mat& Rg, const CamPose& guess,
                    const cv::Mat& rvec, const cv::Mat& tvec, CamPose& out) const;
  void consider(const cv::Mat& rv, const cv::Mat& tv, const PnpProblem& problem, const std::vector<int>& inl,
                PoseChoice& best) const;
  int explained(const CamPose& P, const PnpProblem& problem, const std::vector<int>& inl) const;
  std::vector<MapCandidate> local_map_candidates(int t) const;
  void join_confirmed(int t, const std::vector<MapCandidate>& candidates);
  void triangulate_new(int t);
  bool triangulate_track(int tr, int fa, int ka, int fb, int kb);
  void adjust(const std::vector<int>& frames, int n_fixed, int iterations);
  BaProblem ba_problem(const std::vector<int>& frames, int n_fixed);
  // 6. final adjustment, re-posing, remaining points
  void complete();
  void repose_other_frames(const std::vector<char>& is_kf);
  void copy_still_poses(const std::vector<char>& is_kf);
  void triangulate_remaining();
  // Final observation filter
  void filter_observations();
  void keep_reprojected(double& sq, long& kept);
  void drop_lone_points(double& sq, long& kept);
  void count_frames_and_points();
  // 7. ground plane, metric scale, world frame
  void place_in_world();
  void level_on_ground();
  Eigen::Vector3d mean_up() const;
  bool well_triangulated(int tr) const;
  void collect_ground_candidates(std::vector<Eigen::Vector3d>& cand, std::vector<double>& below) const;
  void set_world_axes(const Eigen::Vector3d& n_up, double d);
  void stand_at_first_pose();
  // Output
  frontend::FrontEndResult assemble_result();
  Eigen::Matrix3d world_rotation(int t) const;
  Eigen::Vector3d world_centre(int t) const;
  std::vector<frontend::FrameObservations> frame_observations() const;
  void fill_pair_motions(frontend::FrontEndResult& res) const;
  void summarise(frontend::FrontEndResult& res, const frontend::FilterCounts& fc, double t_sfm);

  const sequence::Sequence& seq_;
  const SfmOptions options_;
  const Clock::time_point wall_start_;
  Clock::time_point sfm_start_;
  double height_ = 0;  ///< camera height, metres
  int first_frame_ = 0;
  int n_ = 0;  ///< frames
  int descriptor_norm_ = 0;
  SfmReport report_;

  // Step 1: per frame its keypoints (and their descriptors: empty with KLT), per consecutive pair its
  // matches and their verification; then the tracks.
  std::vector<std::vector<cv::Point2f>> pixels_;
  std::vector<std::vector<cv::DMatch>> matches_;
  std::vector<PairInfo> pairs_;
  std::vector<double> seconds_keypoints_, seconds_matching_;
  // Descriptors of every frame (empty with KLT), kept for the local-map matching of step 5: 1500 SIFT
  // keypoints take 0.77 MB per frame.
  std::vector<cv::Mat> descriptors_;
  long total_keypoints_ = 0;
  std::vector<int> n_keypoints_;  ///< keypoints per frame
  int ntracks_ = 0;
  // Observations of each track: (frame, keypoint), frames ascending. Step 5 merges tracks.
  TrackTable tracks_;
  const std::vector<std::vector<int>>& track_of_ = tracks_.tid;
  const std::vector<std::vector<std::pair<int, int>>>& track_obs_ = tracks_.tobs;

  // Step 2
  Intrinsics intrinsics_;
  cv::Mat K_;
  double inlier_px_ = 0;      ///< reprojection threshold of PnP, triangulation and the filter, pixels
  double min_angle_rad_ = 0;  ///< minimum triangulation angle, radians

  // Steps 3-6: per frame its pose and how it was found, per track its 3D point.
  std::vector<CamPose> pose_;
  std::vector<FrameStatus> status_;
  std::vector<int> pnp_points_, pnp_inliers_;
  std::vector<Eigen::Vector3d> point_;
  std::vector<char> has_point_;
  std::vector<int> keyframes_;
  std::vector<int> point_index_;  ///< track -> point of the bundle adjustment being set up, else -1
  int init_a_ = -1, init_b_ = -1;  ///< the initial pair (-1: none found)
  double seconds_ba_ = 0;
  // The final filter: which observations ([frame][keypoint]) the points keep.
  std::vector<std::vector<char>> keep_;

  // Step 7: world = scale_ * world_axes_ * (reconstruction - origin_); the rows of world_axes_ are
  // world X, Y, Z in reconstruction coordinates.
  double scale_ = 1;
  Eigen::Matrix3d world_axes_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
};

}  // namespace smseg::sfm::sfm_front_end
