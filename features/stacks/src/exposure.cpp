#include "smseg/stacks/exposure.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/core.hpp>

#include "smseg/common/error.hpp"
#include "smseg/stacks/dense.hpp"
#include "smseg/stacks/hog_classes.hpp"
#include "smseg/stacks/people.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/stacks/stack.hpp"
#include "smseg/stacks/textons.hpp"
#include "name_lists.hpp"

namespace smseg::stacks {
namespace {

using names::in;
using names::starts_with;

/// Channels that do not see the light: the geometry's, the pixel's position, the people detectors' and the
/// HOG classes' (HOG divides each block's gradients by their norm, and the model scales every gradient
/// alike).
bool blind_to_light(const std::string& name) {
  return in(structure_feature_names(), name) || in(dense_feature_names(), name) || name == "fRow" || name == "fCol" ||
         is_people_feature(name) || is_hog_class_feature(name);
}

std::string number_text(double k) {
  std::ostringstream text;
  text << k;
  return text.str();
}

constexpr double kSrgbOffset = 0.055 * 255.0;  // V + this scales by k^(1/2.4) on sRGB's power segment

}  // namespace

void check_exposure(double k, const std::string& option) {
  if (!(k >= 0.01 && k <= 0.99))
    throw Error("", option,
                "exposure " + number_text(k) + " is not in [0.01, 0.99] (darker copies only: a brighter image "
                "saturates at 255, which the tables cannot know)");
}

void check_exposures(const std::vector<double>& exposures, const std::string& option) {
  for (auto k = exposures.begin(); k != exposures.end(); ++k) {
    check_exposure(*k, option);
    if (std::find(exposures.begin(), k, *k) != k) throw Error("", option, "exposure " + number_text(*k) + " is given twice");
  }
}

namespace {

/// The map of each channel when Lab's cube roots scale by c (the light by c^3).
std::vector<ChannelExposure> plan_for_root_scale(const std::vector<std::string>& features, double c,
                                                 const std::string& source) {
  const double g = std::pow(c, 3.0 / 2.4);
  std::vector<ChannelExposure> plan;
  for (const std::string& name : features) {
    if (name == "fL") {
      plan.push_back({c, 0.16 * (c - 1.0)});  // c (fL + 0.16) - 0.16
    } else if (name == "fA" || name == "fB") {
      plan.push_back({c, 128.0 / 255.0 * (1.0 - c)});  // c (fA - 128/255) + 128/255
    } else if (name == "fG0" || name == "fG1" || name == "fG2" || name == "fG3") {
      plan.push_back({g, 0.0});
    } else if (blind_to_light(name)) {
      plan.push_back({});
    } else if (starts_with(name, kTextonPrefix) || starts_with(name, kContextChannelPrefix)) {
      throw Error(source, "features", "--exposures and --lightness cannot map the channel " + name +
                                          " (a texton or another forest's posterior is no affine function of the "
                                          "light; train without it)");
    } else {
      throw Error(source, "features", "--exposures and --lightness do not know how the channel " + name + " changes with the light");
    }
  }
  return plan;
}

}  // namespace

std::vector<ChannelExposure> exposure_plan(const std::vector<std::string>& features, double k,
                                           const std::string& source) {
  check_exposure(k, "--exposures");
  return plan_for_root_scale(features, std::cbrt(k), source);
}

std::vector<ChannelExposure> lightness_plan(const std::vector<std::string>& features, double mean_l, double target,
                                            const std::string& source) {
  if (std::find(features.begin(), features.end(), "fL") == features.end())
    throw Error(source, "features", "lightness normalisation needs the channel fL (extract-features --appearance)");
  return plan_for_root_scale(features, (target + 0.16) / (mean_l + 0.16), source);
}

double lightness_exposure(double mean_l, double target) {
  const double c = (target + 0.16) / (mean_l + 0.16);
  return c * c * c;
}

void exposed_table(const double* table, int width, int height, ChannelExposure e, double* out) {
  const std::size_t stride = static_cast<std::size_t>(width) + 1;
  for (std::size_t y = 0; y <= static_cast<std::size_t>(height); ++y) {
    const double* row = table + y * stride;
    double* dst = out + y * stride;
    // The cell (x, y) sums x * y pixels: the offset of each of them.
    for (std::size_t x = 0; x < stride; ++x) dst[x] = e.scale * row[x] + e.offset * double(x * y);
  }
}

void exposed_gray(const std::uint8_t* image, int width, int height, double k, std::uint8_t* out) {
  CV_Assert(k > 0 && std::isfinite(k));
  const double g = std::pow(k, 1.0 / 2.4);
  std::uint8_t map[256];
  for (int v = 0; v < 256; ++v)
    map[v] = static_cast<std::uint8_t>(std::clamp(std::lround(g * (v + kSrgbOffset) - kSrgbOffset), 0L, 255L));
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  for (std::size_t i = 0; i < n; ++i) out[i] = map[image[i]];
}

}  // namespace smseg::stacks
