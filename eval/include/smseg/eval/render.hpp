#pragma once
// Pictures of a labelling, for people: coloured labels, an overlay on the input, an error map, and an
// input | ground truth | output montage like thesis Fig 4.1. All BGR CV_8UC3.

#include <opencv2/core.hpp>

namespace smseg::eval {

/// The input with the coloured labels blended over it (alpha = weight of the labels).
cv::Mat overlay(const cv::Mat& input_bgr, const cv::Mat& colour_labels, double alpha = 0.45);

/// Error map: correct pixels as a dimmed grey input, wrong ones red, void (truth 255) black.
cv::Mat error_map(const cv::Mat& input_bgr, const cv::Mat& truth, const cv::Mat& predicted);

/// Images side by side (same height), separated by a 4-pixel white gutter.
cv::Mat side_by_side(const std::vector<cv::Mat>& images);

}  // namespace smseg::eval
