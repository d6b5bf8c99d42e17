#pragma once
// A raster of a channel list by its name: the stack tests read one pixel of a named channel among the
// rasters an append_*_rasters function wrote, in its names' order.
#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace smseg::test {

/// rasters[k] (CV_64FC1) at (y, x), k the position of `name` in `names`; a test failure when absent.
inline double raster_at(const std::vector<cv::Mat>& rasters, const std::vector<std::string>& names,
                        const std::string& name, int y, int x) {
  const auto it = std::find(names.begin(), names.end(), name);
  const auto k = static_cast<std::size_t>(it - names.begin());
  if (it == names.end() || k >= rasters.size()) {
    ADD_FAILURE() << "no raster named " << name;
    return 0;
  }
  return rasters[k].at<double>(y, x);
}

}  // namespace smseg::test
