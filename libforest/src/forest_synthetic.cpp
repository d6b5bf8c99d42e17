// Synthetic frames for tests and benchmarks (see synthetic.hpp).
#include <algorithm>
#include <cmath>
#include <numbers>

#include <oneapi/tbb/parallel_for.h>

#include "smseg/common/error.hpp"
#include "smseg/forest/rng.hpp"
#include "smseg/forest/synthetic.hpp"

namespace smseg::forest {

void summed_area_table(const double* image, int width, int height, double* sat) {
  const std::size_t stride = static_cast<std::size_t>(width) + 1;
  std::fill(sat, sat + stride, 0.0);
  for (int y = 0; y < height; ++y) {
    double row = 0.0;
    double* out = sat + (static_cast<std::size_t>(y) + 1) * stride;
    const double* above = out - stride;
    out[0] = 0.0;
    for (int x = 0; x < width; ++x) {
      row += image[static_cast<std::size_t>(y) * width + x];
      out[x + 1] = above[x + 1] + row;
    }
  }
}

namespace {

/// One frame's labels: ceiling above a wavy line, floor below another, a box of class 3 (classes past
/// o.classes merged into the last), or i.i.d. labels; void within o.void_border of the border.
void frame_labels(const SyntheticOptions& o, Rng& rng, std::vector<std::uint8_t>& lab) {
  const int W = o.width, H = o.height;
  lab.resize(static_cast<std::size_t>(W) * H);
  const double a1 = 0.25 + 0.1 * rng.uniform(), a2 = 0.7 + 0.1 * rng.uniform();
  const double ph = rng.uniform() * 6.283, amp = 0.05 * rng.uniform();
  const int bx0 = static_cast<int>(rng.uniform() * W * 0.7), by0 = static_cast<int>((0.45 + 0.3 * rng.uniform()) * H);
  const int bx1 = bx0 + W / 5, by1 = std::min(H, by0 + H / 5);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double u = static_cast<double>(x) / W, v = static_cast<double>(y) / H;
      const double wave = amp * std::sin(6.283 * u + ph);
      int c = v < a1 + wave ? 0 : (v > a2 - wave ? 2 : 1);
      if (x >= bx0 && x < bx1 && y >= by0 && y < by1) c = 3;
      c = std::min(c, o.classes - 1);
      if (o.random_labels) c = static_cast<int>(rng.below(static_cast<std::uint64_t>(o.classes)));
      const bool border = x < o.void_border || y < o.void_border || x >= W - o.void_border || y >= H - o.void_border;
      lab[static_cast<std::size_t>(y) * W + x] = border ? kVoidLabel : static_cast<std::uint8_t>(c);
    }
}

/// Feature f of one frame: a smooth random field (three plane waves) plus the class's level of the
/// feature (the signal), optionally rounded to quarter units.
void feature_image(const SyntheticOptions& o, Rng& rng, const std::vector<std::uint8_t>& lab,
                   const std::vector<double>& level, int f, std::vector<double>& img) {
  const int W = o.width, H = o.height, F = o.features;
  img.resize(static_cast<std::size_t>(W) * H);
  double kx[3], ky[3], p[3];
  for (int k = 0; k < 3; ++k) {
    kx[k] = (rng.uniform() * 2 - 1) * 0.08;
    ky[k] = (rng.uniform() * 2 - 1) * 0.08;
    p[k] = rng.uniform() * 6.283;
  }
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * W + x;
      double val = 0.0;
      for (int k = 0; k < 3; ++k) val += std::sin(kx[k] * x + ky[k] * y + p[k]);
      val *= o.noise / 3.0;
      const std::uint8_t c = lab[i];
      if (c != kVoidLabel && !o.random_labels) val += o.signal * level[static_cast<std::size_t>(c) * F + f] * 2.0;
      if (o.integer_features) val = std::round(val * 4.0);
      img[i] = val;
    }
}

/// One frame: labels, the feature images and their summed-area tables, and a greyscale image (class
/// brightness plus noise), from the frame's own random stream.
void make_frame(const SyntheticOptions& o, const std::vector<double>& level, int fi, SyntheticData& s) {
  const int W = o.width, H = o.height, F = o.features;
  Rng rng(mix64(o.seed * 1000003ULL + static_cast<std::uint64_t>(fi)));
  auto& lab = s.labels[static_cast<std::size_t>(fi)];
  frame_labels(o, rng, lab);
  for (int f = 0; f < F; ++f) {
    auto& img = s.images[static_cast<std::size_t>(fi) * F + f];
    feature_image(o, rng, lab, level, f, img);
    auto& sat = s.sats[static_cast<std::size_t>(fi) * F + f];
    sat.resize(static_cast<std::size_t>(W + 1) * (H + 1));
    summed_area_table(img.data(), W, H, sat.data());
  }
  auto& g = s.gray[static_cast<std::size_t>(fi)];
  g.resize(lab.size());
  for (std::size_t i = 0; i < lab.size(); ++i) {
    const int c = lab[i] == kVoidLabel ? 1 : lab[i];
    g[i] = static_cast<std::uint8_t>(std::clamp(60 * c + 40 + static_cast<int>(rng.below(40)), 0, 255));
  }
}

/// The dataset's views of the frames (pointers into s's buffers).
void make_views(const SyntheticOptions& o, SyntheticData& s) {
  const int F = o.features;
  s.data.width = o.width;
  s.data.height = o.height;
  for (int fi = 0; fi < o.frames; ++fi) {
    FrameData fd;
    fd.width = o.width;
    fd.height = o.height;
    for (int f = 0; f < F; ++f) fd.sats.push_back(s.sats[static_cast<std::size_t>(fi) * F + f].data());
    fd.gray = s.gray[static_cast<std::size_t>(fi)].data();
    fd.labels = s.labels[static_cast<std::size_t>(fi)].data();
    s.data.frames.push_back(fd);
  }
}

}  // namespace

SyntheticData make_synthetic(const SyntheticOptions& o) {
  if (o.width < 1 || o.height < 1 || o.frames < 1 || o.features < 0 || o.classes < 1 || o.classes > 4)
    throw Error("", "SyntheticOptions", "bad size, frame, feature or class count");
  SyntheticData s;
  const int F = o.features;
  s.images.resize(static_cast<std::size_t>(o.frames) * F);
  s.sats.resize(s.images.size());
  s.gray.resize(static_cast<std::size_t>(o.frames));
  s.labels.resize(static_cast<std::size_t>(o.frames));
  static const char* const kNames[] = {"ceiling", "wall", "floor", "box"};
  for (int c = 0; c < o.classes; ++c) s.data.classes.push_back(kNames[c]);
  for (int f = 0; f < F; ++f) {
    std::string name = "f";
    name += std::to_string(f);
    s.data.features.push_back(name);
  }
  // Class levels per feature, shared by all frames.
  Rng global(mix64(o.world_seed));
  std::vector<double> level(static_cast<std::size_t>(4 * std::max(F, 1)));
  for (auto& l : level) l = global.uniform() * 2.0 - 1.0;
  tbb::parallel_for(0, o.frames, [&](int fi) { make_frame(o, level, fi, s); });
  make_views(o, s);
  return s;
}

}  // namespace smseg::forest
