#pragma once
// Sampling windows (thesis section 2.3.3, Fig 2.1) and texton tests (section 3.2.7, Fig 3.3).
//
// A window (dx, dy, w, h) is placed relative to the pixel (x, y) being classified: it is CENTRED on
// (x + dx, y + dy) and covers columns [x + dx - w/2, x + dx - w/2 + w) and rows
// [y + dy - h/2, y + dy - h/2 + h) (integer division), so a 1 x 1 window is exactly the pixel at the
// offset. Its value for a feature is the sum of the feature over the part of the window inside the
// image (zero when the window lies wholly outside), read from the summed-area table in four reads,
// then rounded to float: the attribute value is float(sum), in training and classification alike.
// Bounds for a W x H image: |dx| <= W/16, |dy| <= H/16, 1 <= w <= max(1, W/8), 1 <= h <= max(1, H/8).
//
// Texton tests use the greyscale image at the test pixel pt and at the sample pixel ps = (x+dx, y+dy)
// (ps = 0 when the sample pixel falls outside the image, like a clipped 1 x 1 window):
// fP = ps, fPs = pt + ps, fPd = pt - ps, fPda = |pt - ps|.

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "smseg/forest/rng.hpp"

namespace smseg::forest {

struct Window {
  int dx = 0, dy = 0, w = 1, h = 1;
  bool operator==(const Window&) const = default;
};

/// The limits of windows for one image size.
struct WindowBounds {
  int max_dx = 0, max_dy = 0, max_w = 1, max_h = 1;
  static WindowBounds for_image(int width, int height) {
    return {width / 16, height / 16, std::max(1, width / 8), std::max(1, height / 8)};
  }
  bool contains(const Window& win) const {
    return win.dx >= -max_dx && win.dx <= max_dx && win.dy >= -max_dy && win.dy <= max_dy &&
           win.w >= 1 && win.w <= max_w && win.h >= 1 && win.h <= max_h;
  }
  bool operator==(const WindowBounds&) const = default;
};

/// The window as a rectangle relative to the pixel: columns [x0, x1), rows [y0, y1).
struct RelRect {
  int x0 = 0, x1 = 1, y0 = 0, y1 = 1;
};
inline RelRect rel_rect(const Window& win) {
  const int x0 = win.dx - win.w / 2, y0 = win.dy - win.h / 2;
  return {x0, x0 + win.w, y0, y0 + win.h};
}

/// Sum over the rectangle [x+r.x0, x+r.x1) x [y+r.y0, y+r.y1) clipped to the width x height image,
/// from a summed-area table with row stride width+1. The one definition used by training and by
/// the classifier, so both see bit-identical values.
inline double window_sum(const double* sat, int width, int height, int x, int y, const RelRect& r) {
  const int stride = width + 1;
  const int xa = std::clamp(x + r.x0, 0, width), xb = std::clamp(x + r.x1, 0, width);
  const int ya = std::clamp(y + r.y0, 0, height), yb = std::clamp(y + r.y1, 0, height);
  const double* top = sat + static_cast<std::ptrdiff_t>(ya) * stride;
  const double* bot = sat + static_cast<std::ptrdiff_t>(yb) * stride;
  return (bot[xb] - top[xb]) - (bot[xa] - top[xa]);
}

/// Texton tests, in the order of their attribute indices after the window features.
inline constexpr int kNumTextonTests = 4;
inline const std::array<std::string, kNumTextonTests>& texton_names() {
  static const std::array<std::string, kNumTextonTests> names{"fP", "fPs", "fPd", "fPda"};
  return names;
}

/// Texton test `test` (0..3: fP, fPs, fPd, fPda) at pixel (x, y) with sample offset (dx, dy).
inline float texton_value(const std::uint8_t* gray, int width, int height, int x, int y, int dx,
                          int dy, int test) {
  const int pt = gray[static_cast<std::ptrdiff_t>(y) * width + x];
  const int sx = x + dx, sy = y + dy;
  const int ps = (sx >= 0 && sx < width && sy >= 0 && sy < height)
                     ? gray[static_cast<std::ptrdiff_t>(sy) * width + sx]
                     : 0;
  switch (test) {
    case 0: return static_cast<float>(ps);
    case 1: return static_cast<float>(pt + ps);
    case 2: return static_cast<float>(pt - ps);
    default: return static_cast<float>(pt > ps ? pt - ps : ps - pt);
  }
}

/// How the pool of windows is drawn (thesis section 4.5.3 and beyond).
enum class WindowSampling {
  Uniform,  ///< every (dx, dy, w, h) uniform within the bounds (thesis default)
  Thesis,   ///< thesis-biased: dy from a V-shaped triangular law favouring large |dy| a share of the
            ///< time (default 10%), w and h from triangular laws favouring large sizes a share of
            ///< the time (default 25%); uniform otherwise
  Learned   ///< dx, dy, w, h drawn independently from histograms of the windows earlier forests chose
};

std::string to_string(WindowSampling mode);
/// "uniform" | "thesis-biased" | "learned"; Error naming `field` otherwise.
WindowSampling window_sampling_from_string(const std::string& s, const std::string& field);

/// Histograms of window attributes over integer values: dx[i] counts dx = i - bounds.max_dx,
/// dy likewise, w[i] counts w = i + 1, h likewise (thesis Fig 4.19).
struct WindowHistograms {
  WindowBounds bounds;
  std::vector<double> dx, dy, w, h;
  /// Empty histograms of the right sizes for these bounds.
  static WindowHistograms zeros(const WindowBounds& b);
  void add(const Window& win, double weight = 1.0);
  void add(const WindowHistograms& other);  ///< same bounds required (Error otherwise)
  double total() const;
  bool empty() const { return dx.empty(); }
};

struct WindowParams {
  WindowSampling mode = WindowSampling::Uniform;
  double thesis_dy_share = 0.10;    ///< Thesis: share of dy drawn from the V-shaped law
  double thesis_size_share = 0.25;  ///< Thesis: share of w and of h drawn from the rising law
  /// Learned: the histograms to sample from (each bin gets +1 before sampling so no value is
  /// impossible); bounds may differ from the image's: values are then rescaled and rounded.
  WindowHistograms learned;
  void validate() const;  ///< Error naming the parameter
};

/// Draws windows for one image size from WindowParams.
class WindowSampler {
 public:
  WindowSampler(const WindowParams& params, const WindowBounds& bounds);
  Window draw(Rng& rng) const;
  /// Only the offset (for texton sample pixels): same law as the windows' dx, dy.
  void draw_offset(Rng& rng, int& dx, int& dy) const;

 private:
  int draw_dx(Rng& rng) const;
  int draw_dy(Rng& rng) const;
  int draw_size(Rng& rng, int max, double share, const std::vector<double>& cdf, int learned_max) const;
  WindowParams p_;
  WindowBounds b_;
  std::vector<double> cdf_dx_, cdf_dy_, cdf_w_, cdf_h_;  // Learned: cumulative smoothed histograms
};

}  // namespace smseg::forest
