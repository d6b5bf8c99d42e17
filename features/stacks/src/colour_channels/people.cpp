// People-detector channels (people.hpp).
#include "smseg/stacks/people.hpp"

#include <algorithm>

#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>

#include "smseg/common/error.hpp"
#include "smseg/stacks/extension.hpp"

namespace smseg::stacks {

namespace {

constexpr double kEnlarge = 2.0;        // the image is searched at twice its size
constexpr double kPyramidStep = 1.05;   // OpenCV's default scale step

cv::HOGDescriptor daimler_detector() {
  cv::HOGDescriptor hog(cv::Size(48, 96), cv::Size(16, 16), cv::Size(8, 8), cv::Size(8, 8), 9);
  hog.setSVMDetector(cv::HOGDescriptor::getDaimlerPeopleDetector());
  return hog;
}

cv::HOGDescriptor inria_detector() {
  cv::HOGDescriptor hog;  // 64x128, OpenCV's defaults
  hog.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());
  return hog;
}

/// Each window with a positive score over `enlarged`, its person region written into `out` (the image's
/// size, CV_64FC1) where its score is higher than what is there.
void paint_detections(const cv::HOGDescriptor& hog, const cv::Mat& enlarged, cv::Mat& out) {
  std::vector<cv::Rect> windows;
  std::vector<double> scores;
  // hit threshold 0, stride of one cell, no padding, no grouping (threshold 0 keeps every window)
  hog.detectMultiScale(enlarged, windows, scores, 0.0, cv::Size(8, 8), cv::Size(0, 0), kPyramidStep, 0.0);
  const cv::Rect image(0, 0, out.cols, out.rows);
  for (std::size_t i = 0; i < windows.size(); ++i) {
    const cv::Rect& w = windows[i];
    const double x0 = (w.x + 0.25 * w.width) / kEnlarge, x1 = (w.x + 0.75 * w.width) / kEnlarge;
    const double y0 = (w.y + 0.125 * w.height) / kEnlarge, y1 = (w.y + 0.875 * w.height) / kEnlarge;
    const cv::Rect person = cv::Rect(cv::Point(int(std::lround(x0)), int(std::lround(y0))),
                                     cv::Point(int(std::lround(x1)), int(std::lround(y1)))) & image;
    if (person.empty()) continue;
    cv::Mat region = out(person);
    cv::max(region, scores[i], region);
  }
}

}  // namespace

const std::vector<std::string>& people_feature_names() {
  static const std::vector<std::string> names = {"fHogD", "fHogI"};
  return names;
}

bool is_people_feature(const std::string& name) {
  const auto& names = people_feature_names();
  return std::find(names.begin(), names.end(), name) != names.end();
}

std::vector<cv::Mat> people_rasters(const cv::Mat& bgr) {
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("", "image", "people detectors need a non-empty 8-bit BGR image");
  cv::Mat enlarged;
  cv::resize(bgr, enlarged, cv::Size(), kEnlarge, kEnlarge, cv::INTER_LINEAR);
  std::vector<cv::Mat> out;
  for (const cv::HOGDescriptor& hog : {daimler_detector(), inria_detector()}) {
    out.push_back(cv::Mat::zeros(bgr.size(), CV_64FC1));
    paint_detections(hog, enlarged, out.back());
  }
  return out;
}

int add_people_channels(const std::vector<fs::path>& works, const std::vector<fs::path>& outs, const FrameRange& frames,
                        bool progress) {
  ColourChannels people;
  people.tool = "add-people";
  people.names = people_feature_names();
  people.is_own = is_people_feature;
  people.options_key = "people";
  people.options = {{"detectors", {"daimler-48x96", "inria-64x128"}}, {"enlarge", kEnlarge}, {"pyramid_step", kPyramidStep}};
  people.rasters = people_rasters;
  return add_colour_channels(people, works, outs, frames, progress);
}

}  // namespace smseg::stacks
