#include "smseg/eval/boundary.hpp"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "smseg/common/error.hpp"

namespace smseg::eval {

namespace {

// Boundary mask (255 at boundary pixels) of `labels`, counting only pixels where `valid` is non-zero.
cv::Mat boundaries(const cv::Mat& labels, const cv::Mat& valid) {
  cv::Mat b = cv::Mat::zeros(labels.size(), CV_8UC1);
  for (int y = 0; y < labels.rows; ++y) {
    const std::uint8_t* l = labels.ptr<std::uint8_t>(y);
    const std::uint8_t* v = valid.ptr<std::uint8_t>(y);
    const std::uint8_t* ln = y + 1 < labels.rows ? labels.ptr<std::uint8_t>(y + 1) : nullptr;
    const std::uint8_t* vn = y + 1 < labels.rows ? valid.ptr<std::uint8_t>(y + 1) : nullptr;
    std::uint8_t* out = b.ptr<std::uint8_t>(y);
    for (int x = 0; x < labels.cols; ++x) {
      if (!v[x]) continue;
      const bool right = x + 1 < labels.cols && v[x + 1] && l[x + 1] != l[x];
      const bool down = ln && vn[x] && ln[x] != l[x];
      if (right || down) out[x] = 255;
    }
  }
  return b;
}

// Pixels of `from` within T of a pixel of `to`.
std::int64_t matched(const cv::Mat& from, const cv::Mat& to, int T) {
  if (cv::countNonZero(to) == 0) return 0;
  cv::Mat dist;
  cv::distanceTransform(~to, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);  // distance to the nearest `to` pixel
  std::int64_t n = 0;
  for (int y = 0; y < from.rows; ++y) {
    const std::uint8_t* f = from.ptr<std::uint8_t>(y);
    const float* d = dist.ptr<float>(y);
    for (int x = 0; x < from.cols; ++x) n += f[x] && d[x] <= float(T) + 1e-3f;
  }
  return n;
}

}  // namespace

double BoundaryCounts::precision() const { return output ? double(output_matched) / double(output) : std::nan(""); }
double BoundaryCounts::recall() const { return truth ? double(truth_matched) / double(truth) : std::nan(""); }
double BoundaryCounts::f1() const {
  const double p = precision(), r = recall();
  if (std::isnan(p) || std::isnan(r)) return std::nan("");
  return p + r > 0 ? 2 * p * r / (p + r) : 0.0;
}

BoundaryCounts boundary_counts(const cv::Mat& truth, const cv::Mat& predicted, int tolerance) {
  CV_Assert(truth.type() == CV_8UC1 && predicted.type() == CV_8UC1 && truth.size() == predicted.size());
  if (tolerance < 0) throw Error("", "--tolerance", "must be >= 0");
  const cv::Mat valid = truth != 255;
  const cv::Mat bt = boundaries(truth, valid), bp = boundaries(predicted, valid);
  BoundaryCounts c;
  c.truth = cv::countNonZero(bt);
  c.output = cv::countNonZero(bp);
  c.truth_matched = matched(bt, bp, tolerance);
  c.output_matched = matched(bp, bt, tolerance);
  return c;
}

}  // namespace smseg::eval
