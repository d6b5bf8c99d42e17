#pragma once
// Dense geometry channels (extract-features --dense).
//
// The six structure-and-motion features live at the tracked points only (100-300 per frame); a window
// that holds none says nothing about the surface under it. A stereo pair gives depth almost everywhere:
// semi-global matching (StereoSGBM, 7x7 blocks, all eight paths, its left-right check, speckle filter) over the
// front end's disparity range, depth Z = fx * baseline / d, the validity mask where the matcher
// answered. From the depth and the frame's pose, per pixel:
//   fZV   1 where the depth is valid, else 0: a window's mean is its valid share, and the other
//         channels' window sums divided by this one's are means over the valid pixels
//   fZI   inverse depth 1 / Z (1/m), 0 where invalid: near things stand out, far ones fade smoothly
//   fZH   height of the pixel's 3D point above the ground (world Y, metres; the world of the camera path,
//         levelled by --gravity estimate or by the level-first-camera assumption; with
//         --height-reference camera, above the ground under the frame's camera), 0 where invalid
//   fZU   how much the surface faces up: n . up of its normal (from the 3D points 2 pixels either side,
//         in the world), 1 floor, 0 wall, -1 ceiling; 0 where the normal is unknown
//   fZE   depth discontinuity: |log Z(x+1) - log Z(x-1)| + |log Z(y+1) - log Z(y-1)|, clamped to 1, 0
//         where a neighbour is invalid (object outlines)
//   fZC   distance (metres) from the pixel's 3D point to the camera path: the polyline through the camera
//         centres of the frame and the next `future_frames` frames (fC's path; with --causal the frame
//         and the ones before it), 0 where invalid. Road under the path is about the camera height away,
//         pavement and parked cars a few metres, facades further (thesis 2.3.2's fC, for every pixel)
// All of them come from the stereo geometry and the camera path, none from image appearance: they
// count as structure and motion. Monocular runs get their depth from a plane sweep over
// the SfM's posed neighbour frames instead (plane_sweep.hpp); the channels are the same.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "smseg/frontend/stereo.hpp"
#include "smseg/sequence/sequence.hpp"

namespace smseg::stacks {

/// {"fZV", "fZI", "fZH", "fZU", "fZE", "fZC"}, in raster order.
const std::vector<std::string>& dense_feature_names();

/// The matcher of the dense depth: SGBM, 7x7 blocks, eight paths, `num_disparities` and `min_disparity` of the front
/// end's options (its range fits the sequence), its left-right check and speckle filter.
frontend::StereoOptions dense_stereo_options(const frontend::StereoOptions& front_end);

/// Depth (CV_32FC1, metres, 0 where invalid) of one frame of a stereo sequence from its dense
/// disparity. Error for a sequence without a focal length or baseline.
cv::Mat dense_depth(const sequence::Sequence& seq, int frame, const frontend::StereoOptions& dense_options);

/// The camera path fZC measures against: an ordered list of world camera centres (at least one).
using CameraPath = std::vector<Eigen::Vector3d>;

/// The centres of frames `frame`..`frame` + future_frames (causal: `frame` - future_frames..`frame`) of
/// `poses`, clipped to the video.
CameraPath camera_path_near(const std::vector<sequence::Pose>& poses, int frame, int future_frames, bool causal);

/// Distance from `p` to the polyline through `path` (to its one point when it has one).
double distance_to_path(const Eigen::Vector3d& p, const CameraPath& path);

/// Appends the dense rasters of a depth map (dense_depth) seen from `pose` (camera-to-world) to `out`,
/// in dense_feature_names() order, each CV_64FC1 of the depth's size. height_shift is added to every
/// fZH (world Y): HeightReference::Camera's reference height minus the camera's own, else 0. fZC
/// measures to `path` (camera_path_near); an empty path means the camera's own centre.
void append_dense_rasters(const cv::Mat& depth, const sequence::Calibration& calibration, const sequence::Pose& pose,
                          std::vector<cv::Mat>& out, double height_shift = 0, const CameraPath& path = {});

}  // namespace smseg::stacks
