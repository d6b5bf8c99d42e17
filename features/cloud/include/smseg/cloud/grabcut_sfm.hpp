#pragma once
// GrabCutSFM (paper 001, He & Upcroft): unsupervised segmentation of the object nearest the camera in one
// frame of a video, from the structure-and-motion cloud and the frame's camera pose.
//
// The defaults (SupportChoice::Table, not in 001) give no distance in metres: the supporting plane is the
// table find_table() finds (the highest wide horizontal patch with points standing on it), its slab a
// share of the points' distance from the camera; only the points standing on it, up to the camera's height
// above it, are clustered, Euclidean at the cloud's own spacing (cloud_spacing); the nearest cluster by the
// median depth of its points; then 001's 2D RANSAC, box and GrabCut, the next nearest
// cluster instead when GrabCut keeps none of its projections (TableParams::min_image_support), and of
// GrabCut's foreground only the nearest object's regions (TableParams::nearest_region; docs/graphcuts.md).
//
// SupportChoice::Plane (GrabCutSfmParams::paper()) is 001's recipe:
//   0. (options, not in 001) only the points within max_distance of the camera and / or projecting into the
//      frame (frustum_only) are used: a street-long SfM cloud has far and stray points that k-means would
//      spend clusters on;
//   1. RANSAC plane removal: the dominant plane (the ground or the table the object stands on) and its
//      inliers within plane_distance are removed from the cloud (001 III-B, Fig. 3);
//      (options, not in 001: several planes in turn; the first plane as the supporting plane facing the
//      camera's up, and only the points in a height band above it, standing on it: see height_band)
//   2. 3D k-means (k = 6, k-means++ seeding, the best of `attempts` runs) on the remaining points (option,
//      not in 001: Euclidean clustering);
//   3. the cluster whose centre (option: median distance or depth of its points) is nearest the camera centre, among the clusters with at least
//      min_cluster_points points projecting into the frame in front of the camera, is projected into the
//      frame (x = P X, 001 eq. 2);
//   4. 2D RANSAC outlier removal (001 III-C; the paper does not give the model, ours): a hypothesis is a
//      centre, the mean of 2 projections drawn at random; the inliers are the projections within
//      outlier_threshold robust standard deviations of it on each axis (an ellipse: per axis 1.4826 x the
//      median absolute deviation from the median), the hypothesis with most inliers wins, its centre is
//      re-estimated as the inliers' mean and the inliers recounted;
//   5. the bounding box of the inliers (001: "the maximum and minimum coordinates of inliers"), grown by
//      box_margin of its width / height on each side (the paper notes that its boxes come out smaller than
//      the object: the object's outline has few tracked points) and clipped to the image keeping at least a
//      one-pixel frame outside it (GrabCut needs background pixels);
//   6. OpenCV grabCut initialised with that rectangle (GC_INIT_WITH_RECT); foreground = GC_FGD | GC_PR_FGD.
// Baselines of the paper's Fig. 9: 2D k-means (k = 2) on the pixels' colour, and GrabCut on a given box.
//
// Deterministic for a seed: every random draw comes from std::mt19937_64 seeded from `seed`, and OpenCV's
// GrabCut, whose GMM initialisation draws from cv::theRNG(), runs with that generator reseeded from the
// seed (and restored afterwards).
//
// Camera model: pinhole without distortion; poses camera-to-world (sequence.hpp's Pose: R rotates camera
// coordinates into the world, t is the camera centre); camera x right, y down, z forward.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "smseg/frontend/motion.hpp"
#include "smseg/sequence/sequence.hpp"

namespace smseg::cloud {

struct PinholeIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  void validate() const;  ///< Error when fx or fy is not positive and finite
};

/// Projects a world point with a camera-to-world pose; false when it lies behind the camera (z <= 1e-6).
bool project_point(const Eigen::Vector3f& world, const sequence::Pose& pose, const PinholeIntrinsics& k, cv::Point2f* pixel,
                   double* depth = nullptr);

/// How the supporting plane is found (not in 001's sense of "a plane": 001 removes the dominant one).
enum class SupportChoice {
  Table,  ///< default: find_table() (the highest horizontal patch with points standing on it), every
          ///< distance relative to the scene; only the points standing on it are clustered
  Plane   ///< 001: the dominant RANSAC plane (the options below in metres: planes, height_band, ...)
};

/// find_table()'s rules: every distance a share of the scene's own (the points' distance from the
/// camera, the camera's height above the plane), none in metres.
struct TableParams {
  double slab_share = 0.016;         ///< a point lies on a plane within this share of its distance from the camera
  double min_share = 0.02;           ///< a candidate plane holds at least this share of the points below the camera
  int min_points = 20;               ///< ... and at least this many
  double edge_margin = 1;            ///< slabs: the objects kept stand this far inside the table's outline (GrabCutSFM;
                                     ///< its edge and what stands beyond it, a wall, are not objects on it)
  double min_rise = 3;               ///< an object's cluster reaches this many slabs above the table (GrabCutSFM)
  double chain_rise = 3;             ///< slabs: a cluster whose points this high above the table fall apart
                                     ///< into two or more clusters (1.5 x the tolerance apart, each of the
                                     ///< smallest cluster's size) is split into those, its lower points joining
                                     ///< the nearest within the tolerance: stereo errors on the table chain
                                     ///< neighbouring objects (GrabCutSFM; 0: no split)
  bool join_through_feet = true;     ///< a candidate whose largest patch is no table is tried again with the feet of
                                     ///< the points above it joining its pieces (a table seen from low, cut into
                                     ///< pieces by the objects on it and the table they hide)
  double min_image_support = 0;      ///< GrabCutSFM: the nearest cluster is taken when GrabCut's foreground in its box
                                     ///< holds more than this share of its 2D inliers, else the next nearest is
                                     ///< tried (the nearest when none is): a sheet of stereo errors over a plain
                                     ///< wall has no object under it (-1: the nearest, 001)
  bool nearest_region = true;        ///< GrabCutSFM: the chosen cluster's points inside GrabCut's foreground that fall
                                     ///< apart into two or more clusters (two objects chained by stereo errors on
                                     ///< the wall between them, which GrabCut leaves out) keep only the nearest's
                                     ///< regions of the mask
  double mask_depth_share = 0.1;     ///< GrabCutSFM: GrabCut's foreground loses the pixels whose cloud depth lies beyond
                                     ///< (1 + this) x the 90th percentile of the chosen points' depths (0: none)
  double max_refit_tilt = 5;         ///< degrees: the least-squares plane of the patch is kept within this of up
  double min_prominence = 1.5;       ///< a candidate's count is at least this x the mean count three slabs above
                                     ///< and below it, and exceeds that mean by min_share (its own points)
  double min_width_share = 0.5;      ///< a table's patch is at least this x the camera's height above it wide
  double min_standing_share = 0.05;  ///< points standing on a table: at least this share of its patch's points
  double min_depression = 0.1;       ///< the camera looks down at a table: its height above it at least this x the
                                     ///< patch's median distance (about 6 degrees)
  void validate() const;             ///< Error naming the field
};

/// A supporting plane found by find_table(): n . X + d = 0 with n the up direction.
struct TablePlane {
  Eigen::Vector4d plane{0, 0, 0, 0};
  Eigen::Vector3d e1{1, 0, 0}, e2{0, 0, 1};  ///< the plane's axes (feet are (e1 . X, e2 . X))
  std::vector<cv::Point2f> hull;     ///< the convex hull of its largest patch's feet (PCL's polygonal prism)
  double thickness = 0;              ///< metres: slab_share x the patch's median distance from the camera
  double camera_height = 0;          ///< metres: the camera above the plane
  double width = 0;                  ///< metres: the patch's smaller principal width
  int inliers = 0;                   ///< points of the largest patch
  int standing = 0;                  ///< points above the slab whose foot lies inside the hull
  int candidates = 0;                ///< candidate heights examined
  bool found = false;                ///< a table; false: the candidate with most points (or none: inliers 0)
  /// p's foot on the plane lies inside the hull, at least `inset` metres from its outline
  bool under(const Eigen::Vector3d& p, double inset = 0) const;
  double height_of(const Eigen::Vector3d& p) const;  ///< signed, along the up direction
};

/// The supporting plane chosen as a table is: the cloud's points below the camera, candidate planes
/// normal to `up` at the heights where many points lie within their slab (a share of their distance
/// from the camera, standing out of the walls' count above and below); from the highest down, the first that
/// the camera looks down at, whose largest connected patch (cells of two slabs, or of two of the cloud's
/// angular steps on the plane where a low camera samples it more coarsely) is wide (relative to the camera's height above it) and has points standing on it (above its slab, their foot inside its
/// hull). A floor lies below the table; an object's top, above it, has nothing standing on it; a wall's
/// slice is narrow. When no candidate passes, the one with most points (found = false).
TablePlane find_table(const std::vector<Eigen::Vector3f>& cloud, const Eigen::Vector3d& camera,
                      const Eigen::Vector3d& up, const TableParams& params = {});

/// The median distance from a point to its k-th nearest neighbour (0 with k or fewer points): the
/// cloud's own spacing, the scale of Euclidean clustering by default.
double cloud_spacing(const std::vector<Eigen::Vector3f>& points, int k);

struct GrabCutSfmParams {
  SupportChoice support = SupportChoice::Table;
  TableParams table;
  Eigen::Vector3d up{0, 0, 0};   ///< the world's up direction (extract-features' estimate_gravity); zero: the
                                 ///< camera's up axis (or world +Y with world_up)
  bool refine_up = false;        ///< support Table: the up direction is first taken from the dominant plane
                                 ///< within 20 degrees of it (a floor and a table top share their normal): for
                                 ///< an up not known to within a degree (a short or straight camera path)
  double plane_distance = -1;    ///< metres, the plane's slab; < 0: from the scene (table: its thickness;
                                 ///< plane: 0.05, 001); 0 (plane only): no plane removal
  int plane_iterations = 500;    ///< RANSAC hypotheses for the plane
  int k = 6;                     ///< 3D k-means clusters (001: 6)
  int attempts = 3;              ///< k-means runs (k-means++ seeds); the lowest sum of squared distances wins
  int kmeans_iterations = 100;   ///< Lloyd iterations per run at most
  int min_cluster_points = 5;    ///< projections in the frame a cluster needs to be chosen
  double outlier_threshold = 3;  ///< 2D RANSAC: robust standard deviations per axis
  int ransac_iterations = 200;   ///< 2D RANSAC hypotheses
  double box_margin = 0.1;       ///< share of the box's width / height added on each side
  int grabcut_iterations = 5;    ///< cv::grabCut iterations
  bool frustum_only = false;     ///< cluster only the points projecting into the frame (not in 001)
  double max_distance = 0;       ///< metres: cluster only points this close to the camera (0: all; not in 001)
  // Several planes and the supporting plane (not in 001, which removes one plane), support Plane:
  int planes = 1;                ///< planes removed in turn at most (001: 1)
  double plane_min_share = 0.1;  ///< a second or later plane is removed only if it holds this share of the rest
  double height_band = -1;       ///< metres: > 0: only the points between the slab and this height above the
                                 ///< supporting plane are kept. Plane: the first plane is then the supporting
                                 ///< plane, RANSAC hypotheses restricted to normals within max_tilt of the up
                                 ///< direction; < 0 or 0: no band (001). Table: < 0 = the camera's height above it
  double max_tilt = 30;          ///< degrees, see height_band (support Plane)
  bool box_to_plane = true;      ///< with a supporting plane (table, or plane with a height band): the box also
                                 ///< holds the projections of the kept points' feet on it (the object's lower part);
                                 ///< table: only when the cluster's lowest point lies within min_rise slabs of it
  bool world_up = false;         ///< the supporting plane faces world +Y (a work folder levelled by
                                 ///< extract-features --gravity estimate) instead of the camera's up axis
  double support_radius = -1;    ///< metres: > 0 keeps, of the band, only the points standing on the supporting
                                 ///< plane: the foot of the point within this of a plane inlier's foot; < 0: table:
                                 ///< inside its hull, plane: any point in the band (also 0)
  // Clustering and the choice of the nearest cluster:
  bool euclidean = true;         ///< Euclidean clustering (points within cluster_tolerance chained); false: 001's k-means
  double cluster_tolerance = -1;  ///< metres, Euclidean clustering; < 0: tolerance_share x cloud_spacing (4th neighbour)
  double tolerance_share = 1.2;  ///< see cluster_tolerance
  int min_cluster_size = -1;     ///< Euclidean clustering: smaller clusters are dropped; < 0: min_cluster_share of the
                                 ///< points clustered (at least 10)
  double min_cluster_share = 0.05;  ///< see min_cluster_size
  bool median_distance = false;  ///< nearest by the median distance of the cluster's points (else its centre's, 001)
  bool median_depth = false;     ///< with median_distance: depth (along the optical axis) instead of distance
  std::uint64_t seed = 1;
  void validate() const;         ///< Error naming the option (--plane-distance, --k, ...)
  /// 001's recipe as published: the dominant plane within 5 cm removed, k-means with k = 6, the box from the
  /// nearest cluster centre (the defaults before the scene-relative ones).
  static GrabCutSfmParams paper();
};

struct GrabCutSfmReport {
  int points = 0;                       ///< cloud points
  int considered = 0;                   ///< points offered to the plane fit (all, or those in the frustum / range)
  int plane_inliers = 0;                ///< removed as planes (all of them)
  Eigen::Vector4d plane{0, 0, 0, 0};    ///< the first plane: n . X + d = 0, |n| = 1 (zero without plane removal)
  std::vector<Eigen::Vector4d> planes;  ///< every plane removed, in order (normals towards the camera)
  std::vector<int> planes_inliers;      ///< per plane, its inliers
  int support = -1;                     ///< with a supporting plane (table, or height_band): its index in `planes` (0)
  TablePlane table;                     ///< support Table: the table found
  double plane_distance = 0;            ///< the slab used (metres)
  double height_band = 0;               ///< the band used (metres; 0: none)
  double cluster_tolerance = 0;         ///< Euclidean clustering: the tolerance used (metres)
  int min_cluster_size = 0;             ///< Euclidean clustering: the smallest cluster kept
  int in_band = 0;                      ///< with height_band: points kept in the band
  int feet_in_box = 0;                  ///< with box_to_plane: feet of the chosen points added to the box
  std::vector<int> cluster_sizes;       ///< per cluster, points
  std::vector<double> cluster_distances;  ///< per cluster, distance from the camera (metres): of its centre, or
                                          ///< the median of its points' with median_distance
  std::vector<int> cluster_in_frame;    ///< per cluster, points projecting into the frame
  int chosen = -1;                      ///< the cluster used
  int regions_dropped = 0;              ///< regions of GrabCut's foreground dropped as a farther object's (nearest_region)
  int farther_pixels = 0;               ///< foreground pixels dropped as farther than the object (mask_depth_share)
  std::vector<int> unsupported;         ///< nearer clusters passed over: GrabCut kept none of them (min_image_support)
  std::vector<cv::Point2f> projected;   ///< every clustered point projecting into the frame
  std::vector<int> projected_cluster;   ///< its cluster
  std::vector<cv::Point2f> chosen_points;  ///< the chosen cluster's projections in the frame
  std::vector<char> chosen_inlier;      ///< per chosen projection, kept by the 2D RANSAC
  int inliers_2d = 0;
  cv::Rect inlier_box;                  ///< bounding box of the 2D inliers
  cv::Rect box;                         ///< after margin and clipping: the GrabCut rectangle
  double seconds_plane = 0, seconds_kmeans = 0, seconds_projection = 0, seconds_grabcut = 0;
  double seconds_total = 0;
};

/// GrabCutSFM on one frame. `points` are world positions (the cloud), `image` the frame (CV_8UC3 BGR).
/// Returns the foreground mask (CV_8UC1, 255 object, 0 background). Errors: empty cloud, empty or
/// non-colour image, too few points left for k clusters after plane removal, no cluster with
/// min_cluster_points projections in front of the camera inside the frame.
/// `plane_cloud` (not in 001; null: `points`): the first (supporting) plane is fitted to this cloud
/// instead, within the same reach (max_distance, frustum_only; with world_up and a height band only its
/// points below the camera), each hypothesis scored by both clouds (ransac_plane's `agree`), and removes
/// its inliers from `points`; unused without plane removal (plane_distance 0).
/// A frame's dense depth sees the objects a tracked cloud misses but, seen from above a table, often
/// more floor than table top; the tracks around the frame find the table (docs/graphcuts.md).
cv::Mat grabcut_sfm(const std::vector<Eigen::Vector3f>& points, const PinholeIntrinsics& intrinsics, const sequence::Pose& pose,
                    const cv::Mat& image, const GrabCutSfmParams& params, GrabCutSfmReport* report = nullptr,
                    const std::vector<Eigen::Vector3f>* plane_cloud = nullptr);

/// A cloud local to one frame (not in 001): one point per track observed with a 3D point in frames
/// [frame - window, frame + window] (those with a pose), the mean of its world positions there (R P + t of
/// each observation's frame). Keeps the drift and the far structure of a long sequence out of the clusters.
std::vector<Eigen::Vector3f> window_cloud(const frontend::FrontEndResult& front_end, int frame, int window);

/// The world points of a frame's dense depth map (CV_32FC1 metres, 0 = none; stacks/dense.hpp's
/// dense_depth) seen from `pose` (camera-to-world), one per `step`-th pixel in x and y: a cloud with
/// points on surfaces no keypoint was tracked on (low-contrast objects). Error for step < 1.
std::vector<Eigen::Vector3f> dense_frame_cloud(const cv::Mat& depth, const sequence::Calibration& calibration, const sequence::Pose& pose,
                                               int step);

/// The up direction of a work folder's world from its camera path and tracks (estimate_gravity, as
/// extract-features --gravity estimate: the plane of a circling or turning path, else the ground under a
/// straight one). The camera height it needs for its thresholds is the first camera's.
/// `planar_path` (optional): whether it came from a planar camera path (a circle or a turn), the reliable case.
Eigen::Vector3d scene_up(const frontend::FrontEndResult& front_end, bool* planar_path = nullptr);

/// The pinhole intrinsics of a work folder's frames: the SfM focal of a monocular run (tracks.json), else
/// the sequence's fx / fy; principal point from the sequence. `source` says which. Error without a focal.
PinholeIntrinsics frame_intrinsics(const sequence::Sequence& sequence, const frontend::FrontEndResult& front_end, std::string* source);

/// The object of an instance image (ids 1..255, 0 none) nearest the camera: the smallest median of the
/// ground-truth depth (> 0) over its pixels; 0 when no object shows. The truth of --truth-instance nearest.
int nearest_instance(const cv::Mat& instances, const cv::Mat& depth);

/// The largest 8-connected region of a mask (255 / 0); an empty mask stays empty.
cv::Mat largest_region(const cv::Mat& mask);

// ---- building blocks (exposed for tests) ------------------------------------------------------------

/// RANSAC plane over `points` (3-point hypotheses, inliers within `distance`, the plane refitted by least
/// squares to the best hypothesis's inliers and the inliers recounted). Returns per point 1 = inlier.
/// Fewer than 3 points: no inliers, plane zero. With `min_cos` > 0 only hypotheses whose normal n has
/// |n . up| >= min_cos count (a plane facing `up`, unit, within acos(min_cos)). With `up_is_known` the
/// hypotheses are the planes normal to `up` through one point each (a levelled world: 3-point samples
/// of a noisy table top fall within a few degrees of `up` too rarely), and the refitted normal is kept
/// only within acos(min_cos) of `up`. With `agree` (another cloud of the same scene) the hypothesis whose
/// smaller share of the two clouds' best inlier counts is highest wins, then the refit as above.
std::vector<char> ransac_plane(const std::vector<Eigen::Vector3f>& points, double distance, int iterations,
                               std::uint64_t seed, Eigen::Vector4d* plane = nullptr,
                               const Eigen::Vector3d& up = Eigen::Vector3d::Zero(), double min_cos = -1,
                               bool up_is_known = false, const std::vector<Eigen::Vector3f>* agree = nullptr);

/// k-means of n rows of `dim` floats (row-major), k-means++ seeding, Lloyd iterations until no label
/// changes, best of `attempts` (lowest sum of squared distances). Labels 0..k-1 ordered by the first point
/// of each cluster (so the labelling does not depend on the seeding order). Error when n < k or k < 1.
std::vector<int> kmeans(const std::vector<float>& data, int dim, int k, int attempts, int max_iterations,
                        std::uint64_t seed, std::vector<float>* centres = nullptr);

/// Euclidean clustering: points joined when within `tolerance` of each other (transitively, single
/// linkage, on a voxel grid of that size); clusters of fewer than `min_size` points get -1. Labels 0..m-1
/// ordered by the first point of each cluster. Deterministic.
std::vector<int> euclidean_clusters(const std::vector<Eigen::Vector3f>& points, double tolerance, int min_size);

/// The 2D RANSAC of step 4: per point 1 = inlier. Fewer than 3 points: all inliers.
std::vector<char> compact_inliers_2d(const std::vector<cv::Point2f>& points, double threshold, int iterations,
                                     std::uint64_t seed);

/// OpenCV GrabCut initialised with `box` (clipped to the image leaving a one-pixel frame); 255 / 0 mask.
/// Deterministic for the seed. Error when the clipped box is empty.
cv::Mat grabcut_box(const cv::Mat& image, cv::Rect box, int iterations, std::uint64_t seed);

/// Baseline: k-means (k = 2) on the pixels' colour (BGR, 0..255). The foreground cluster is chosen without
/// ground truth: the one with the smaller share of the image's border pixels (the outermost row / column
/// on each side; an object of interest is framed, the background reaches the frame's edge); on a tie the
/// smaller cluster. `clusters` receives the raw 0 / 1 labels (CV_8UC1) when given, for reports that score
/// both assignments.
cv::Mat kmeans2_colour(const cv::Mat& image, std::uint64_t seed, cv::Mat* clusters = nullptr);

/// F1 of `predicted` (non-zero = foreground) against `truth` (non-zero = foreground) over the pixels where
/// `ignore` is zero (an empty `ignore`: every pixel). NaN when neither mask has a foreground pixel.
/// Error when the sizes differ.
double mask_f1(const cv::Mat& predicted, const cv::Mat& truth, const cv::Mat& ignore = cv::Mat());

/// The frame with the mask tinted, every cluster's projections in its colour (the chosen cluster's 2D
/// outliers as crosses), the inlier box thin and the GrabCut box thick in red (001 Fig. 5 and 6).
cv::Mat grabcut_sfm_overlay(const cv::Mat& image, const cv::Mat& mask, const GrabCutSfmReport& report);

}  // namespace smseg::cloud
