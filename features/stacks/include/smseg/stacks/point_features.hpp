#pragma once
// The structure-and-motion features of thesis 2.3.2 / 3.2.3 (docs/design.md section 4, "Features"), rasters of
// the image size that are then turned into summed-area tables:
//   fH  height of the point above the ground (world Y), at the point's pixel; with
//       HeightReference::Camera above the ground under the frame's camera (see HeightReference)
//   fC  closest approach of the point to the camera path: over the frames it is seen in plus the next
//       `future_frames` frames of camera motion applied to its last position (causal: only frames up to
//       the current one)
//   fOx, fOy  Delaunay triangulation of the frame's points in image coordinates; each triangle's world
//       unit normal n = (v3-v1)x(v2-v1)/|...|, oriented towards the camera; n.x and n.y on every pixel
//       inside the triangle
//   fD  1 at each tracked point's pixel
//   fR  back-projection residual: distance between the point's world position from the previous frame
//       and its world position from the current observation and the current pose (0 in a track's first
//       frame)
// Point features are added at the point's (rounded) pixel, so two points on one pixel add up.

#include <optional>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "smseg/sequence/sequence.hpp"

namespace smseg::options {
template <class S>
class Table;  // smseg/common/options.hpp
}

namespace smseg::stacks {

/// One tracked point seen in one frame.
struct Observation {
  int track = -1;              ///< track id, unique within the sequence
  float x = 0, y = 0;          ///< pixel position
  Eigen::Vector3d cam{0, 0, 0};  ///< 3D point in the camera frame, metres (x right, y down, z forward)
};

/// What the features are computed from: the camera path and the points seen in each frame.
struct PointCloudVideo {
  std::vector<sequence::Pose> poses;                             ///< camera-to-world, one per frame
  std::vector<std::vector<Observation>> observations;  ///< per frame
  int frame_count() const { return static_cast<int>(poses.size()); }
};

/// The feature names in stack order.
const std::vector<std::string>& structure_feature_names();  // {"fH","fC","fOx","fOy","fD","fR"}

/// What fH (and the dense fZH) measure heights from.
enum class HeightReference {
  Auto,    ///< extract-features: Camera for monocular SfM runs, Plane for stereo; elsewhere Plane
  Plane,   ///< the run's ground plane: world Y (the thesis)
  Camera,  ///< the ground under each frame's camera: the point's height relative to the camera plus the
           ///< cameras' median height over the run (causal features: the first camera's height), so a
           ///< camera path that drifts up or down (a long monocular drive) does not shift every height
           ///< of its frames
};
std::string to_string(HeightReference h);
HeightReference height_reference_from_string(const std::string& s, const std::string& option);

struct FeatureOptions {
  bool causal = false;      ///< fC from the camera path up to the current frame only (on-line use)
  HeightReference height_reference = HeightReference::Auto;
  int future_frames = 100;  ///< frames of camera motion applied to a point's last position (thesis: 100)
  bool appearance = false;  ///< also the image's own channels (appearance.hpp: colour, oriented gradients, position)
  bool dense = false;       ///< stereo: also the dense geometry channels (dense.hpp: depth, height, facing, edges)
  /// Monocular dense channels (a plane sweep): the neighbour frames each side are the nearest at least
  /// sweep_baseline metres from the frame's camera, looked for within sweep_reach frames
  /// (SweepNeighbourOptions, plane_sweep.hpp). A video far denser than the training runs can take its
  /// neighbours at their baseline, so that its depth is measured as theirs is (docs/camvid.md).
  double sweep_baseline = 0.5;
  int sweep_reach = 4;
  /// Resolution of the plane sweep against the frame's (PlaneSweepOptions::scale).
  double sweep_scale = 1.0;
  void validate() const;    ///< Error naming the option when out of range
};

/// FeatureOptions' fields, declared once (options.hpp): extract-features' options, stacks.json's
/// "features", run-experiment's keys, the Python keywords.
const options::Table<FeatureOptions>& feature_options_table();

/// Per-observation values that need the whole video (world position, fH, fC, fR), aligned with
/// PointCloudVideo::observations.
struct PointAttributes {
  std::vector<std::vector<Eigen::Vector3d>> world;
  std::vector<std::vector<double>> fH, fC, fR;
};

PointAttributes compute_point_attributes(const PointCloudVideo& video, const FeatureOptions& opt);

std::optional<double> reference_camera_height(const FeatureOptions& opt, const std::vector<sequence::Pose>& poses);
/// What heights seen from `pose` gain over world Y: camera_height minus the camera's own world Y (the
/// ground under the camera), 0 without a reference height (the ground plane). fH and fZH both add it.
double height_shift(std::optional<double> camera_height, const sequence::Pose& pose);

/// One frame's share of PointAttributes.
struct FrameAttributes {
  std::vector<Eigen::Vector3d> world;
  std::vector<double> fH, fC, fR;
};

/// The causal attributes one frame at a time (what compute_point_attributes computes with
/// FeatureOptions::causal, and the first pass of the default): world position and fH, fR from the
/// track's previous observation, fC as the closest approach to the camera path so far.
class CausalPointAttributes {
 public:
  CausalPointAttributes() = default;
  /// camera_height: fH is the point's height relative to the frame's camera plus camera_height
  /// (HeightReference::Camera) instead of world Y.
  explicit CausalPointAttributes(std::optional<double> camera_height) : camera_height_(camera_height) {}
  /// The next frame's attributes (frames are counted from 0 in the order they are added).
  void add_frame(const sequence::Pose& pose, const std::vector<Observation>& observations, FrameAttributes& out);
  /// Forgets the tracks not in `live_tracks` (ascending ids): a stream's tracks that have ended.
  void keep_only(const std::vector<int>& live_tracks);

  struct TrackState {
    int last_frame = -1;
    Eigen::Vector3d last_world{0, 0, 0};
    double running_min = std::numeric_limits<double>::infinity();
  };
  const TrackState* track(int id) const;  ///< nullptr when the track was never seen (or forgotten)

 private:
  std::unordered_map<int, TrackState> tracks_;
  int frame_ = 0;
  std::optional<double> camera_height_;
};

/// The six rasters (CV_64FC1, `size`) of one frame, in structure_feature_names() order.
std::vector<cv::Mat> rasterise_features(const PointCloudVideo& video, const PointAttributes& attrs, int frame,
                                        cv::Size size);
/// The same into `rasters`, reusing its buffers (the hot path: no allocation per frame).
void rasterise_features(const PointCloudVideo& video, const PointAttributes& attrs, int frame, cv::Size size,
                        std::vector<cv::Mat>& rasters);

/// Summed-area table in cv::integral's layout: (H+1) x (W+1) CV_64FC1, sat(y, x) = sum over rows < y and
/// columns < x. The sum over a rectangle is four reads, whatever its size.
cv::Mat summed_area_table(const cv::Mat& raster);
void summed_area_table(const cv::Mat& raster, cv::Mat& sat);  ///< into sat, reusing its buffer

/// Sum of the raster over the rectangle [x0, x1) x [y0, y1), clipped to the image, from its SAT.
double rect_sum(const cv::Mat& sat, int x0, int y0, int x1, int y1);

}  // namespace smseg::stacks
