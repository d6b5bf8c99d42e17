#pragma once
// A blurred random texture (CV_32FC1): uniform noise, blurred by `sigma`, stretched to [lo, hi]. The
// stereo and tracking tests sample it at shifts, so it is made wider than the images they cut from it.
#include <cstdint>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace smseg::test {

inline cv::Mat random_texture(int w, int h, std::uint64_t seed, double sigma, double lo, double hi) {
  cv::RNG rng(seed);
  cv::Mat t(h, w, CV_32FC1);
  rng.fill(t, cv::RNG::UNIFORM, 0.0, 255.0);
  cv::GaussianBlur(t, t, cv::Size(0, 0), sigma);
  cv::normalize(t, t, lo, hi, cv::NORM_MINMAX);
  return t;
}

}  // namespace smseg::test
