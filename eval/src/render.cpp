#include "smseg/eval/render.hpp"

#include <opencv2/imgproc.hpp>

namespace smseg::eval {

cv::Mat overlay(const cv::Mat& input_bgr, const cv::Mat& colour_labels, double alpha) {
  CV_Assert(input_bgr.type() == CV_8UC3 && colour_labels.type() == CV_8UC3 && input_bgr.size() == colour_labels.size());
  cv::Mat out;
  cv::addWeighted(input_bgr, 1.0 - alpha, colour_labels, alpha, 0.0, out);
  return out;
}

cv::Mat error_map(const cv::Mat& input_bgr, const cv::Mat& truth, const cv::Mat& predicted) {
  CV_Assert(truth.type() == CV_8UC1 && predicted.type() == CV_8UC1 && truth.size() == predicted.size());
  cv::Mat grey, out;
  cv::cvtColor(input_bgr, grey, cv::COLOR_BGR2GRAY);
  grey.convertTo(grey, CV_8U, 0.5, 40);
  cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);
  for (int y = 0; y < out.rows; ++y) {
    const std::uint8_t* t = truth.ptr<std::uint8_t>(y);
    const std::uint8_t* p = predicted.ptr<std::uint8_t>(y);
    cv::Vec3b* o = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < out.cols; ++x) {
      if (t[x] == 255) {
        o[x] = cv::Vec3b(0, 0, 0);
      } else if (t[x] != p[x]) {
        o[x] = cv::Vec3b(0, 0, 230);
      }
    }
  }
  return out;
}

cv::Mat side_by_side(const std::vector<cv::Mat>& images) {
  CV_Assert(!images.empty());
  const int gutter = 4;
  int width = 0;
  for (const auto& m : images) width += m.cols;
  width += gutter * (static_cast<int>(images.size()) - 1);
  cv::Mat out(images[0].rows, width, CV_8UC3, cv::Scalar::all(255));
  int x = 0;
  for (const auto& m : images) {
    CV_Assert(m.type() == CV_8UC3 && m.rows == images[0].rows);
    m.copyTo(out(cv::Rect(x, 0, m.cols, m.rows)));
    x += m.cols + gutter;
  }
  return out;
}

}  // namespace smseg::eval
