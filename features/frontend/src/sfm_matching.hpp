#pragma once
// Matching and two-view verification of consecutive frames for the monocular SfM (sfm.cpp, step 1).
// Private to the frontend module.
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "smseg/frontend/sfm.hpp"

namespace smseg::features::sfm_matching {

/// The median of v (the upper one for an even count); 0 for none.
double median(std::vector<double> v);

/// Symmetric matches that also pass Lowe's ratio test in both directions.
std::vector<cv::DMatch> match_ratio(const cv::Mat& a, const cv::Mat& b, int norm, double ratio);

/// Symmetric nearest-neighbour matching restricted to candidates within `radius` pixels (see
/// sfm_matching.cpp).
std::vector<cv::DMatch> match_gated(const cv::Mat& da, const std::vector<cv::Point2f>& pa, const cv::Mat& db,
                                    const std::vector<cv::Point2f>& pb, int norm, double radius, double ratio);

struct PairInfo {
  double median_motion = 0;  ///< of the verified matches, pixels
  bool still = false;
  bool has_f = false;
  cv::Matx33d F;
};

/// Geometric verification of one consecutive pair's matches (in place).
PairInfo verify_pair(std::vector<cv::DMatch>& m, const std::vector<cv::Point2f>& pa, const std::vector<cv::Point2f>& pb,
                     const SfmOptions& o);

}  // namespace smseg::features::sfm_matching
