#include "smseg/stacks/mirror.hpp"

#include <algorithm>

#include "smseg/common/error.hpp"
#include "smseg/stacks/appearance.hpp"
#include "smseg/stacks/dense.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/stacks/stack.hpp"
#include "smseg/stacks/textons.hpp"
#include "name_lists.hpp"

namespace smseg::stacks {
namespace {

using names::in;
using names::starts_with;

/// Channels whose value does not depend on left and right: mirrored as they are.
bool mirrors_as_is(const std::string& name) {
  if (name == "fOx" || name == "fG1" || name == "fG3" || name == "fCol") return false;
  return in(structure_feature_names(), name) || in(appearance_feature_names(), name) ||
         in(dense_feature_names(), name) || starts_with(name, kContextChannelPrefix);
}

}  // namespace

std::vector<ChannelMirror> mirror_plan(const std::vector<std::string>& features, const std::string& source) {
  const auto index_of = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(features.begin(), features.end(), name) - features.begin());
  };
  std::vector<ChannelMirror> plan;
  for (std::size_t k = 0; k < features.size(); ++k) {
    const std::string& name = features[k];
    ChannelMirror c{k, true, false};
    if (name == "fOx") {
      c.negate = true;
    } else if (name == "fCol") {
      c.flip = false;
    } else if (name == "fG1" || name == "fG3") {
      const std::string partner = name == "fG1" ? "fG3" : "fG1";
      c.source = index_of(partner);
      if (c.source == features.size())
        throw Error(source, "features", "--mirror needs " + partner + " beside " + name +
                                            " (a mirror turns one orientation bin into the other)");
    } else if (starts_with(name, kTextonPrefix)) {
      throw Error(source, "features", "--mirror cannot mirror the texton channel " + name +
                                          " (the filter bank's odd filters change sign: the mirrored frame's textons "
                                          "are not the mirror of its own)");
    } else if (!mirrors_as_is(name)) {
      throw Error(source, "features", "--mirror does not know how the channel " + name + " changes under a mirror");
    }
    plan.push_back(c);
  }
  return plan;
}

void mirror_table(const double* table, int width, int height, bool negate, double* out) {
  const std::size_t stride = static_cast<std::size_t>(width) + 1;
  const double sign = negate ? -1.0 : 1.0;
  for (std::size_t y = 0; y <= static_cast<std::size_t>(height); ++y) {
    const double* row = table + y * stride;
    double* dst = out + y * stride;
    // The columns < x of the mirror are the columns >= W - x of the frame.
    for (std::size_t x = 0; x < stride; ++x) dst[x] = sign * (row[width] - row[static_cast<std::size_t>(width) - x]);
  }
}

void mirror_image(const std::uint8_t* image, int width, int height, std::uint8_t* out) {
  const std::size_t w = static_cast<std::size_t>(width);
  for (std::size_t y = 0; y < static_cast<std::size_t>(height); ++y)
    std::reverse_copy(image + y * w, image + (y + 1) * w, out + y * w);
}

}  // namespace smseg::stacks
