#pragma once
// People-detector channels (`add-people`): the detector potentials of Ladicky et al. 2010, one of the
// CamVid anchors, as channels a forest's windows read. Two pretrained HOG + linear SVM people detectors
// of OpenCV (Dalal & Triggs 2005) run over the colour image enlarged twice (CamVid's pedestrians are
// 20-60 pixels tall at 480x360, the detectors' windows 96 and 128), at every scale of a 1.05 pyramid,
// every window with a positive SVM score kept (no grouping):
//   fHogD   the Daimler detector (48x96 window, trained on pedestrians seen from a car)
//   fHogI   OpenCV's default detector (64x128 window, trained on INRIA's people)
// A channel's value at a pixel is the highest score of the windows whose person region (the middle half
// of the window's width, its middle three quarters of height, where the person stands in the training
// windows) covers the pixel, 0 where none does. The same image gives the same values whatever the thread
// count (a maximum over the windows, in any order).
// HOG divides each block's gradient histogram by its norm, so a frame made k times brighter (every
// channel's gradients scaled alike, exposure.hpp's model) gives the same windows: --lightness and
// --exposures keep these channels as they are.

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/common/io.hpp"
#include "smseg/stacks/stack.hpp"

namespace smseg::stacks {

/// {"fHogD", "fHogI"}, in raster order.
const std::vector<std::string>& people_feature_names();

/// Whether `name` is one of people_feature_names().
bool is_people_feature(const std::string& name);

/// The people channels of a BGR image (CV_8UC3, not empty; Error otherwise): people_feature_names().size()
/// CV_64FC1 rasters of its size.
std::vector<cv::Mat> people_rasters(const cv::Mat& bgr);

/// Writes, for each works[i], the work folder outs[i] that extends it (all its features, read from it as
/// its base) with fHogD and fHogI of each frame inside `frames`; stacks.json records options.people.
/// Errors as add_colour_channels (extension.hpp). Returns the frames written.
int add_people_channels(const std::vector<fs::path>& works, const std::vector<fs::path>& outs, const FrameRange& frames,
                        bool progress);

}  // namespace smseg::stacks
