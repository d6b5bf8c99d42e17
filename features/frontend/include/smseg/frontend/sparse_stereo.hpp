#pragma once
// Block matching at chosen pixels only (StereoMethod::Sparse), and what a frame's observations read
// their disparities from.
//
// The stereo front end reads the disparity of a frame only at its keypoints (observe_points, the nearest
// pixel). A dense BM pass costs ~20 ms on a KITTI pair, two with the mirrored left-right check, for
// the ~800 pixels that are read. SparseBlockMatcher prefilters the padded pair once (the cheap part,
// OpenCV's x-Sobel prefilter on the same padded images compute_disparity matches) and then matches a
// pixel when it is asked for: the same sum of absolute differences over the same window, the same
// texture threshold, uniqueness test, tie order and sub-pixel interpolation as OpenCV's StereoBM, and
// the mirrored left-right check as compute_disparity makes it (the right-image disparity at x - d from
// the same matcher on the mirrored pair). Without a speckle filter (speckle_window = 0) its disparity
// at every pixel equals compute_disparity's bit for bit (Stereo.SparseMatcherEqualsBlockMatching...);
// the speckle filter needs the connected regions of the whole map, so the sparse matcher has none and
// keeps the pixels of small isolated regions that BM's filter removes (docs/stereo.md "Matchers").

#include <memory>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/frontend/stereo.hpp"
#include "smseg/frontend/tracking.hpp"

namespace smseg::frontend {

class SparseBlockMatcher {
 public:
  /// Prefilters the pair (8-bit grey, one size; Error otherwise) for options' BM parameters
  /// (validated; the method is not looked at, speckle_window and speckle_range are not used).
  SparseBlockMatcher(const cv::Mat& left, const cv::Mat& right, const StereoOptions& options);

  /// The disparity of left pixel (x, y) in pixels, kInvalidDisparity where BM gives none (outside the
  /// matched band, too little texture, not unique, not confirmed by the right image).
  float at(int x, int y) const;
  /// at() at each pixel's nearest pixel (clamped to the image), as observe_points reads a map.
  std::vector<float> sample(const std::vector<cv::Point2f>& pixels) const;
  /// at() at every pixel (CV_32FC1): what compute_disparity returns for method Sparse.
  cv::Mat dense() const;
  cv::Size size() const { return size_; }

 private:
  // One matching direction: the prefiltered left and right images, padded on the left by pad_.
  struct Pass {
    cv::Mat left, right;
  };
  // BM's fixed-point (x16) disparity of padded pixel (x, y) in one pass; <= 0 when it has none.
  int match(const Pass& pass, int x, int y) const;

  StereoOptions o_;
  cv::Size size_;
  int pad_ = 0;
  Pass forward_;   // left against right
  Pass mirrored_;  // right mirrored against left mirrored (the right image's disparity)
};

/// A frame's disparity as the front end reads it: a dense map (bm, sgbm, given) or the sparse
/// matcher's prefiltered pair, matched at the pixels sampled.
class FrameDisparity {
 public:
  FrameDisparity() = default;
  explicit FrameDisparity(cv::Mat map) : map_(std::move(map)) {}
  explicit FrameDisparity(std::shared_ptr<const SparseBlockMatcher> sparse) : sparse_(std::move(sparse)) {}
  /// The disparity at each pixel's nearest pixel (clamped), kInvalidDisparity where there is none.
  std::vector<float> sample(const std::vector<cv::Point2f>& pixels) const;
  bool empty() const { return map_.empty() && !sparse_; }
  const cv::Mat& map() const { return map_; }  ///< empty for the sparse matcher

 private:
  cv::Mat map_;
  std::shared_ptr<const SparseBlockMatcher> sparse_;
};

/// What the front end needs of a pair: compute_disparity's map, or for method Sparse the prefiltered
/// pair (no pixel matched yet). Method Given is refused, as by compute_disparity.
FrameDisparity prepare_disparity(const cv::Mat& left, const cv::Mat& right, const StereoOptions& options);

/// observe_points / observe_keypoints with the disparities sampled from `disparity`.
FrameObservations observe_points(const std::vector<cv::Point2f>& pixels, const FrameDisparity& disparity,
                                 const cv::Mat& labels, const sequence::Calibration& calib);
FrameObservations observe_keypoints(const std::vector<cv::KeyPoint>& keypoints, const FrameDisparity& disparity,
                                    const cv::Mat& labels, const sequence::Calibration& calib);

}  // namespace smseg::frontend
