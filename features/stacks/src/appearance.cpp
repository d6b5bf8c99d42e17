#include "smseg/stacks/appearance.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <opencv2/imgproc.hpp>

#include "smseg/common/error.hpp"

namespace smseg::stacks {

const std::vector<std::string>& appearance_feature_names() {
  static const std::vector<std::string> names{"fL", "fA", "fB", "fG0", "fG1", "fG2", "fG3", "fRow", "fCol"};
  return names;
}

bool is_appearance_feature(const std::string& name) {
  const auto& n = appearance_feature_names();
  return std::find(n.begin(), n.end(), name) != n.end();
}

namespace {

// CIE L*a*b* of an sRGB image (D65 white), with OpenCV's constants (its cvtColor documentation), computed
// here rather than by cv::cvtColor: OpenCV's 8-bit Lab path builds lookup tables on first use that it never
// frees, which LeakSanitizer reports as a leak in every program that extracts appearance channels.
// Output: L* / 100, (a* + 128) / 255, (b* + 128) / 255 (OpenCV's 8-bit scaling, without its rounding).
void append_lab(const cv::Mat& bgr, std::vector<cv::Mat>& out) {
  static const std::array<double, 256> linear = [] {
    std::array<double, 256> t{};
    for (int v = 0; v < 256; ++v) {
      const double c = v / 255.0;
      t[v] = c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
    }
    return t;
  }();
  const auto f = [](double t) { return t > 0.008856 ? std::cbrt(t) : 7.787 * t + 16.0 / 116.0; };
  cv::Mat L(bgr.size(), CV_64F), A(bgr.size(), CV_64F), B(bgr.size(), CV_64F);
  for (int y = 0; y < bgr.rows; ++y) {
    const cv::Vec3b* px = bgr.ptr<cv::Vec3b>(y);
    double *l = L.ptr<double>(y), *a = A.ptr<double>(y), *b = B.ptr<double>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      const double bl = linear[px[x][0]], g = linear[px[x][1]], r = linear[px[x][2]];
      const double X = (0.412453 * r + 0.357580 * g + 0.180423 * bl) / 0.950456;
      const double Y = 0.212671 * r + 0.715160 * g + 0.072169 * bl;
      const double Z = (0.019334 * r + 0.119193 * g + 0.950227 * bl) / 1.088754;
      const double fy = f(Y);
      l[x] = (Y > 0.008856 ? 116.0 * fy - 16.0 : 903.3 * Y) / 100.0;
      a[x] = (500.0 * (f(X) - fy) + 128.0) / 255.0;
      b[x] = (200.0 * (fy - f(Z)) + 128.0) / 255.0;
    }
  }
  out.push_back(L);
  out.push_back(A);
  out.push_back(B);
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
  append_lab_rasters(bgr, out);
  append_oriented_gradients(bgr, out);
  append_position(bgr.size(), out);
}

void append_lab_rasters(const cv::Mat& bgr, std::vector<cv::Mat>& out) {
  if (bgr.empty() || bgr.type() != CV_8UC3)
    throw Error("", "appearance", "needs a colour (8-bit, 3-channel) image");
  append_lab(bgr, out);
}

}  // namespace smseg::stacks
