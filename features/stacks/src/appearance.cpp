#include "smseg/stacks/appearance.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <opencv2/imgproc.hpp>

#include "smseg/common/error.hpp"

namespace smseg::features {

const std::vector<std::string>& appearance_feature_names() {
  static const std::vector<std::string> names{"fL", "fA", "fB", "fG0", "fG1", "fG2", "fG3", "fRow", "fCol"};
  return names;
}

bool is_appearance_feature(const std::string& name) {
  const auto& n = appearance_feature_names();
  return std::find(n.begin(), n.end(), name) != n.end();
}

namespace {

void append_lab(const cv::Mat& bgr, std::vector<cv::Mat>& out) {
  cv::Mat lab;
  cv::cvtColor(bgr, lab, cv::COLOR_BGR2Lab);
  std::vector<cv::Mat> channels;
  cv::split(lab, channels);
  for (const cv::Mat& c : channels) {
    cv::Mat r;
    c.convertTo(r, CV_64F, 1.0 / 255.0);
    out.push_back(r);
  }
}

// Gradient magnitude split between the two orientation bins (of four, 45 degrees apart) nearest to the
// gradient's direction modulo 180 degrees, in proportion to closeness: a smooth function of the image.
void append_oriented_gradients(const cv::Mat& bgr, std::vector<cv::Mat>& out) {
  cv::Mat gray, gx, gy;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  cv::Sobel(gray, gx, CV_64F, 1, 0, 3, 1.0, 0.0, cv::BORDER_REPLICATE);
  cv::Sobel(gray, gy, CV_64F, 0, 1, 3, 1.0, 0.0, cv::BORDER_REPLICATE);
  constexpr int kBins = 4;
  const double scale = 1.0 / (4.0 * 255.0 * std::numbers::sqrt2);  // the largest 3x3 Sobel magnitude
  const double bin_width = std::numbers::pi / kBins;
  std::vector<cv::Mat> bins(kBins);
  for (cv::Mat& b : bins) b = cv::Mat::zeros(bgr.size(), CV_64F);
  for (int y = 0; y < bgr.rows; ++y) {
    const double* dx = gx.ptr<double>(y);
    const double* dy = gy.ptr<double>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      const double m = std::hypot(dx[x], dy[x]) * scale;
      if (m == 0) continue;
      double a = std::atan2(dy[x], dx[x]);  // (-pi, pi]
      if (a < 0) a += std::numbers::pi;     // [0, pi]: a gradient and its opposite are one orientation
      const double t = std::min(a / bin_width, double(kBins) - 1e-12);  // [0, kBins)
      const int b0 = static_cast<int>(t);
      const double w1 = t - b0;
      bins[b0].ptr<double>(y)[x] = m * (1.0 - w1);
      bins[(b0 + 1) % kBins].ptr<double>(y)[x] += m * w1;
    }
  }
  for (cv::Mat& b : bins) out.push_back(b);
}

void append_position(cv::Size size, std::vector<cv::Mat>& out) {
  cv::Mat row(size, CV_64F), col(size, CV_64F);
  for (int y = 0; y < size.height; ++y) {
    double* r = row.ptr<double>(y);
    double* c = col.ptr<double>(y);
    for (int x = 0; x < size.width; ++x) {
      r[x] = (y + 0.5) / size.height;
      c[x] = (x + 0.5) / size.width;
    }
  }
  out.push_back(row);
  out.push_back(col);
}

}  // namespace

void append_appearance_rasters(const cv::Mat& bgr, std::vector<cv::Mat>& out) {
  if (bgr.empty() || bgr.type() != CV_8UC3)
    throw Error("", "appearance", "needs a colour (8-bit, 3-channel) image");
  append_lab(bgr, out);
  append_oriented_gradients(bgr, out);
  append_position(bgr.size(), out);
}

}  // namespace smseg::features
