#pragma once
// Matching and two-view verification of consecutive frames for the monocular SfM (sfm.cpp, step 1).
// Private to the frontend module.
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "smseg/sfm/sfm.hpp"

namespace smseg::sfm::sfm_matching {

/// The median of v (the upper one for an even count); 0 for none.
double median(std::vector<double> v);

/// Symmetric matches that also pass Lowe's ratio test in both directions.
std::vector<cv::DMatch> match_ratio(const cv::Mat& a, const cv::Mat& b, int norm, double ratio);

/// Symmetric nearest-neighbour matching restricted to candidates within `radius` pixels (see
/// sfm_matching.cpp).
std::vector<cv::DMatch> match_gated(const cv::Mat& da, const std::vector<cv::Point2f>& pa, const cv::Mat& db,
                                    const std::vector<cv::Point2f>& pb, int norm, double radius, double ratio);

/// Guided matching of a pair whose fundamental matrix F (b^T F a = 0) is known: the candidates of a
/// keypoint are the other frame's keypoints within band_px of its epipolar line (both ways), and (i, j)
/// is kept when each is the other's nearest descriptor among its candidates, and the nearest beats the
/// second by `ratio`. A whole-image ratio test rejects most keypoints of repetitive texture (road,
/// facades), whose near twins lie elsewhere in the image but seldom on the same epipolar line.
std::vector<cv::DMatch> match_epipolar(const cv::Mat& da, const std::vector<cv::Point2f>& pa, const cv::Mat& db,
                                       const std::vector<cv::Point2f>& pb, const cv::Matx33d& F, int norm,
                                       double band_px, double ratio);

struct PairInfo {
  double median_motion = 0;  ///< of the verified matches, pixels
  bool still = false;
  bool has_f = false;
  cv::Matx33d F;
};

/// Geometric verification of one consecutive pair's matches (in place).
PairInfo verify_pair(std::vector<cv::DMatch>& m, const std::vector<cv::Point2f>& pa, const std::vector<cv::Point2f>& pb,
                     const SfmOptions& o);

}  // namespace smseg::sfm::sfm_matching
