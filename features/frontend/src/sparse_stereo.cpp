// Block matching at chosen pixels (sparse_stereo.hpp). Every step is OpenCV StereoBM's (calib3d
// stereobm.cpp, x-Sobel prefilter, 16-bit sums) for one pixel, so that a pixel matched here has the
// disparity the dense matcher gives it.

#include "smseg/frontend/sparse_stereo.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <string>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

namespace smseg::frontend {

namespace {

constexpr int kMaxDisparities = 1024;  // StereoOptions' num_disparities limit (options table)

// StereoBM's x-Sobel prefilter: clamp(d/dx, -cap, cap) + cap, rows reflected at the top and bottom,
// the first and last columns (and an odd height's last row) set to cap, as prefilterXSobel does.
cv::Mat prefilter_xsobel(const cv::Mat& src, int cap) {
  const int h = src.rows, w = src.cols;
  cv::Mat dst(h, w, CV_8UC1, cv::Scalar(cap));
  auto clamp_cap = [cap](int v) { return static_cast<std::uint8_t>(std::clamp(v, -cap, cap) + cap); };
  for (int y = 0; y + 1 < h; y += 2) {
    const std::uint8_t* r1 = src.ptr<std::uint8_t>(y);
    const std::uint8_t* r0 = y > 0 ? src.ptr<std::uint8_t>(y - 1) : src.ptr<std::uint8_t>(y + 1);
    const std::uint8_t* r2 = src.ptr<std::uint8_t>(y + 1);
    const std::uint8_t* r3 = y < h - 2 ? src.ptr<std::uint8_t>(y + 2) : r1;
    std::uint8_t* d0 = dst.ptr<std::uint8_t>(y);
    std::uint8_t* d1 = dst.ptr<std::uint8_t>(y + 1);
    for (int x = 1; x < w - 1; ++x) {
      const int g0 = r0[x + 1] - r0[x - 1], g1 = r1[x + 1] - r1[x - 1];
      const int g2 = r2[x + 1] - r2[x - 1], g3 = r3[x + 1] - r3[x - 1];
      d0[x] = clamp_cap(g0 + 2 * g1 + g2);
      d1[x] = clamp_cap(g1 + 2 * g2 + g3);
    }
  }
  return dst;
}

// compute_disparity's input to the matcher: the image padded on the left by `pad` (edge replicated),
// prefiltered.
cv::Mat padded_prefiltered(const cv::Mat& gray, int pad, int cap) {
  cv::Mat padded;
  cv::copyMakeBorder(gray, padded, 0, 0, pad, 0, cv::BORDER_REPLICATE);
  return prefilter_xsobel(padded, cap);
}

// BM's fixed-point (x16) disparity of the padded pixel (x, y), inside the valid rectangle; <= 0 for none.
// cost[k] is BM's index k = nd - 1 - (disparity - min_disparity): the right window starts
// nd - 1 + min_disparity - k columns left of the left window, so k ascending reads the right row ascending.
template <class Sum>
int match_pixel(const cv::Mat& left, const cv::Mat& right, int x, int y, const StereoOptions& o) {
  const int half = o.block_size / 2, nd = o.num_disparities, mind = o.min_disparity, cap = o.prefilter_cap;
  std::array<Sum, kMaxDisparities> cost;
  std::fill_n(cost.begin(), nd, Sum{0});
  int texture = 0;
  for (int j = -half; j <= half; ++j) {
    const std::uint8_t* l = left.ptr<std::uint8_t>(y + j) + x;
    const std::uint8_t* r = right.ptr<std::uint8_t>(y + j) + x - (nd - 1 + mind);
    for (int i = -half; i <= half; ++i) {
      const int lv = l[i];
      texture += std::abs(lv - cap);
      const std::uint8_t* ri = r + i;
      for (int k = 0; k < nd; ++k) cost[k] = static_cast<Sum>(cost[k] + static_cast<Sum>(std::abs(lv - ri[k])));
    }
  }
  if (texture < o.texture_threshold) return 0;
  int best = 0, best_cost = std::numeric_limits<int>::max();
  for (int k = 0; k < nd; ++k)
    if (static_cast<int>(cost[k]) < best_cost) best_cost = static_cast<int>(cost[k]), best = k;  // first: largest disparity
  if (o.uniqueness_ratio > 0) {
    const int thresh = best_cost + best_cost * o.uniqueness_ratio / 100;
    for (int k = 0; k < nd; ++k)
      if (static_cast<int>(cost[k]) <= thresh && (k < best - 1 || k > best + 1)) return 0;
  }
  int p = 0, n = 0, den = 0;
  if (best > 0 && best < nd - 1) {
    p = static_cast<int>(cost[best + 1]), n = static_cast<int>(cost[best - 1]);
    den = p + n - 2 * best_cost + std::abs(p - n);
  }
  return ((nd - best - 1 + mind) * 256 + (den != 0 ? (p - n) * 256 / den : 0) + 15) >> 4;
}

}  // namespace

SparseBlockMatcher::SparseBlockMatcher(const cv::Mat& left, const cv::Mat& right, const StereoOptions& options)
    : o_(options) {
  StereoOptions checked = o_;
  checked.method = StereoMethod::BM;
  checked.lr_check = LeftRightCheck::Mirrored;
  checked.validate();
  if (o_.num_disparities > kMaxDisparities)
    throw Error("", "stereo.num_disparities", "the sparse matcher searches at most " + std::to_string(kMaxDisparities));
  if (left.empty() || left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size())
    throw Error("", "stereo pair", "the sparse matcher needs two 8-bit grey images of one size");
  size_ = left.size();
  pad_ = o_.min_disparity + o_.num_disparities;
  forward_ = {padded_prefiltered(left, pad_, o_.prefilter_cap), padded_prefiltered(right, pad_, o_.prefilter_cap)};
  if (o_.lr_max_diff >= 0) {
    cv::Mat lf, rf;
    cv::flip(right, lf, 1);
    cv::flip(left, rf, 1);
    mirrored_ = {padded_prefiltered(lf, pad_, o_.prefilter_cap), padded_prefiltered(rf, pad_, o_.prefilter_cap)};
  }
}

int SparseBlockMatcher::match(const Pass& pass, int x, int y) const {
  const int half = o_.block_size / 2, nd = o_.num_disparities, mind = o_.min_disparity;
  const int width = pass.left.cols, height = pass.left.rows;
  // StereoBM's valid rectangle (getValidDisparityROI): whole windows, the whole search inside the image.
  if (y < half || y >= height - half || x < mind + nd - 1 + half || x >= width - half) return 0;
  // BM sums in 16 bits where they cannot overflow (its useShorts), which also halves the work here.
  if (o_.block_size <= 21 && o_.prefilter_cap <= 31) return match_pixel<std::uint16_t>(pass.left, pass.right, x, y, o_);
  return match_pixel<std::uint32_t>(pass.left, pass.right, x, y, o_);
}

float SparseBlockMatcher::at(int x, int y) const {
  if (x < 0 || y < 0 || x >= size_.width || y >= size_.height) return kInvalidDisparity;
  const int raw = match(forward_, x + pad_, y);
  if (raw <= 0) return kInvalidDisparity;
  const float d = static_cast<float>(raw) / 16.0f;
  if (o_.lr_max_diff < 0) return d;
  // left_right_check's test, with the right image's disparity at x - d from the mirrored pass.
  const int xr = static_cast<int>(std::lround(x - d));
  if (xr < 0) return kInvalidDisparity;
  const int raw_right = match(mirrored_, size_.width - 1 - xr + pad_, y);
  const float dr = raw_right > 0 ? static_cast<float>(raw_right) / 16.0f : kInvalidDisparity;
  return dr > 0 && std::abs(dr - d) <= o_.lr_max_diff ? d : kInvalidDisparity;
}

std::vector<float> SparseBlockMatcher::sample(const std::vector<cv::Point2f>& pixels) const {
  std::vector<float> out;
  out.reserve(pixels.size());
  for (const cv::Point2f& p : pixels)
    out.push_back(at(std::clamp(static_cast<int>(std::lround(p.x)), 0, size_.width - 1),
                     std::clamp(static_cast<int>(std::lround(p.y)), 0, size_.height - 1)));
  return out;
}

cv::Mat SparseBlockMatcher::dense() const {
  cv::Mat out(size_, CV_32FC1);
  cv::parallel_for_(cv::Range(0, size_.height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      auto* row = out.ptr<float>(y);
      for (int x = 0; x < size_.width; ++x) row[x] = at(x, y);
    }
  });
  return out;
}

std::vector<float> FrameDisparity::sample(const std::vector<cv::Point2f>& pixels) const {
  if (sparse_) return sparse_->sample(pixels);
  if (map_.type() != CV_32FC1) throw Error("", "disparity", "expected CV_32FC1");
  std::vector<float> out;
  out.reserve(pixels.size());
  for (const cv::Point2f& p : pixels) {
    const int x = std::clamp(static_cast<int>(std::lround(p.x)), 0, map_.cols - 1);
    const int y = std::clamp(static_cast<int>(std::lround(p.y)), 0, map_.rows - 1);
    out.push_back(map_.at<float>(y, x));
  }
  return out;
}

FrameDisparity prepare_disparity(const cv::Mat& left, const cv::Mat& right, const StereoOptions& options) {
  if (options.method == StereoMethod::Sparse)
    return FrameDisparity(std::make_shared<const SparseBlockMatcher>(left, right, options));
  return FrameDisparity(compute_disparity(left, right, options));
}

FrameObservations observe_points(const std::vector<cv::Point2f>& pixels, const FrameDisparity& disparity,
                                 const cv::Mat& labels, const sequence::Calibration& calib) {
  return observe_sampled(pixels, disparity.sample(pixels), labels, calib);
}

FrameObservations observe_keypoints(const std::vector<cv::KeyPoint>& keypoints, const FrameDisparity& disparity,
                                    const cv::Mat& labels, const sequence::Calibration& calib) {
  std::vector<cv::Point2f> pixels;
  pixels.reserve(keypoints.size());
  for (const auto& k : keypoints) pixels.push_back(k.pt);
  return observe_points(pixels, disparity, labels, calib);
}

}  // namespace smseg::frontend
