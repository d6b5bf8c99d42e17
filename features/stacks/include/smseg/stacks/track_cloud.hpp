#pragma once
// The tracked points as a labelled point cloud, for PCL viewers and CloudCompare (docs/design.md 3.2), and a
// top-down picture of the camera path and the cloud, for people. Writing it as a PCD/PLY file needs PCL
// and lives in the point-cloud module (smseg/cloud/cloud_io.hpp).
//
// Each track becomes one point: the mean of its world positions over the frames it is seen in (world
// Y up). Its label is the track's consistent class from the labelled frames it passes, or none.

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "smseg/frontend/motion.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/sequence/sequence.hpp"

namespace smseg::stacks {

struct CloudPoint {
  Eigen::Vector3f position{0, 0, 0};  ///< world, metres
  int label = -1;                     ///< class position, -1 when the track has no label
  int track = -1;
};

/// One point per track of the front end, placed with its observations' world positions.
std::vector<CloudPoint> track_cloud(const frontend::FrontEndResult& front_end, const PointCloudVideo& video,
                                    const PointAttributes& attrs);

/// Top-down (world X right, world Z up the picture) plot: the cloud's points in their class colours
/// (grey: unlabelled), the estimated camera path in black with its start marked, and the ground-truth
/// path in red when given. Includes a 1 m scale bar.
cv::Mat plot_top_down(const std::vector<sequence::Pose>& path, const std::vector<sequence::Pose>* ground_truth,
                      const std::vector<CloudPoint>& cloud, const sequence::Sequence& seq, int size = 800);

}  // namespace smseg::stacks
