// What GrabCutSFM reads off a work folder and a sequence besides the cloud: the up direction, the
// intrinsics, and the truth of the tabletop scene's instance images.
#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "smseg/cloud/grabcut_sfm.hpp"
#include "smseg/common/error.hpp"
#include "smseg/sfm/sfm_summary.hpp"

namespace smseg::cloud {

Eigen::Vector3d scene_up(const frontend::FrontEndResult& fe, bool* planar_path) {
  frontend::GravityOptions g;
  g.method = frontend::GravityMethod::Estimate;
  const double camera_height = fe.poses.empty() ? 1.0 : std::max(0.1, std::abs(fe.poses.front().t[1]));
  const frontend::GravityEstimate e = frontend::estimate_gravity(fe.poses, fe.first_frame, fe.tracks, camera_height, g);
  if (planar_path) *planar_path = e.source == "camera-path";
  return e.up;
}

PinholeIntrinsics frame_intrinsics(const sequence::Sequence& seq, const frontend::FrontEndResult& fe, std::string* source) {
  PinholeIntrinsics k;
  k.cx = seq.calibration.cx;
  k.cy = seq.calibration.cy;
  const sfm::SfmSummary* sfm = sfm::sfm_summary_of(fe.summary);
  if (sfm && sfm->focal > 0) {
    k.fx = k.fy = sfm->focal;
    if (source) *source = "tracks.json summary.sfm.focal_px (" + sfm->focal_source + ")";
  } else if (seq.calibration.fx && seq.calibration.fy) {
    k.fx = *seq.calibration.fx;
    k.fy = *seq.calibration.fy;
    if (source) *source = "sequence calibration";
  } else {
    throw Error(seq.manifest.string(), "calibration", "no focal length (neither fx/fy nor an SfM focal in tracks.json)");
  }
  return k;
}

int nearest_instance(const cv::Mat& inst, const cv::Mat& depth) {
  if (inst.type() != CV_8UC1 || depth.type() != CV_32FC1 || inst.size() != depth.size())
    throw Error("", "instances", "expected an 8-bit instance image and a float depth map of one size");
  std::vector<std::vector<float>> d(256);
  for (int y = 0; y < inst.rows; ++y)
    for (int x = 0; x < inst.cols; ++x) {
      const std::uint8_t v = inst.at<std::uint8_t>(y, x);
      const float z = depth.at<float>(y, x);
      if (v && z > 0) d[v].push_back(z);
    }
  int id = 0;
  float best = std::numeric_limits<float>::infinity();
  for (int v = 1; v < 256; ++v) {
    auto& dv = d[std::size_t(v)];
    if (dv.empty()) continue;
    std::nth_element(dv.begin(), dv.begin() + std::ptrdiff_t(dv.size() / 2), dv.end());
    if (dv[dv.size() / 2] < best) {
      best = dv[dv.size() / 2];
      id = v;
    }
  }
  return id;
}

cv::Mat largest_region(const cv::Mat& mask) {
  cv::Mat comp, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, comp, stats, centroids, 8, CV_32S);
  if (n < 2) return cv::Mat::zeros(mask.size(), CV_8UC1);
  int best = 1;
  for (int c = 2; c < n; ++c)
    if (stats.at<int>(c, cv::CC_STAT_AREA) > stats.at<int>(best, cv::CC_STAT_AREA)) best = c;
  return comp == best;
}

}  // namespace smseg::cloud
