// Window sampling laws and window histograms (thesis sections 2.3.3 and 4.5.3).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "smseg/common/error.hpp"
#include "smseg/common/names.hpp"
#include "smseg/forest/window.hpp"

namespace smseg::forest {

constexpr std::array<EnumName<WindowSampling>, 3> kWindowSamplingNames{
    {{WindowSampling::Uniform, "uniform"}, {WindowSampling::Thesis, "thesis-biased"}, {WindowSampling::Learned, "learned"}}};

std::string to_string(WindowSampling mode) { return name_of(kWindowSamplingNames, mode); }
WindowSampling window_sampling_from_string(const std::string& s, const std::string& field) {
  return value_named(kWindowSamplingNames, s, field);
}

WindowHistograms WindowHistograms::zeros(const WindowBounds& b) {
  WindowHistograms h;
  h.bounds = b;
  h.dx.assign(2 * static_cast<std::size_t>(b.max_dx) + 1, 0.0);
  h.dy.assign(2 * static_cast<std::size_t>(b.max_dy) + 1, 0.0);
  h.w.assign(static_cast<std::size_t>(b.max_w), 0.0);
  h.h.assign(static_cast<std::size_t>(b.max_h), 0.0);
  return h;
}

void WindowHistograms::add(const Window& win, double weight) {
  if (!bounds.contains(win)) throw Error("", "window", "outside the window bounds of the histogram");
  dx[static_cast<std::size_t>(win.dx + bounds.max_dx)] += weight;
  dy[static_cast<std::size_t>(win.dy + bounds.max_dy)] += weight;
  w[static_cast<std::size_t>(win.w - 1)] += weight;
  h[static_cast<std::size_t>(win.h - 1)] += weight;
}

void WindowHistograms::add(const WindowHistograms& other) {
  if (!(other.bounds == bounds))
    throw Error("", "windows.bounds", "window histograms of different image sizes cannot be added");
  for (std::size_t i = 0; i < dx.size(); ++i) dx[i] += other.dx[i];
  for (std::size_t i = 0; i < dy.size(); ++i) dy[i] += other.dy[i];
  for (std::size_t i = 0; i < w.size(); ++i) w[i] += other.w[i];
  for (std::size_t i = 0; i < h.size(); ++i) h[i] += other.h[i];
}

double WindowHistograms::total() const { return std::accumulate(dx.begin(), dx.end(), 0.0); }

void WindowParams::validate() const {
  if (!(thesis_dy_share >= 0.0 && thesis_dy_share <= 1.0))
    throw Error("", "windows.thesis_dy_share", "must be in [0, 1]");
  if (!(thesis_size_share >= 0.0 && thesis_size_share <= 1.0))
    throw Error("", "windows.thesis_size_share", "must be in [0, 1]");
  if (mode == WindowSampling::Learned) {
    const WindowBounds& b = learned.bounds;
    if (learned.empty() || b.max_dx < 0 || b.max_dy < 0 || b.max_w < 1 || b.max_h < 1 ||
        learned.dx.size() != 2 * static_cast<std::size_t>(b.max_dx) + 1 ||
        learned.dy.size() != 2 * static_cast<std::size_t>(b.max_dy) + 1 ||
        learned.w.size() != static_cast<std::size_t>(b.max_w) ||
        learned.h.size() != static_cast<std::size_t>(b.max_h))
      throw Error("", "windows.learned", "learned window sampling needs histograms matching their bounds");
    for (const auto* v : {&learned.dx, &learned.dy, &learned.w, &learned.h})
      for (double c : *v)
        if (!(c >= 0.0) || !std::isfinite(c))
          throw Error("", "windows.learned", "histogram counts must be finite and >= 0");
  }
}

namespace {
std::vector<double> smoothed_cdf(const std::vector<double>& hist) {
  std::vector<double> cdf(hist.size());
  double acc = 0.0;
  for (std::size_t i = 0; i < hist.size(); ++i) cdf[i] = acc += hist[i] + 1.0;  // +1: Laplace
  return cdf;
}
int sample_cdf(const std::vector<double>& cdf, Rng& rng) {
  const double u = rng.uniform() * cdf.back();
  const auto it = std::upper_bound(cdf.begin(), cdf.end(), u);
  return static_cast<int>(std::min<std::ptrdiff_t>(it - cdf.begin(), static_cast<std::ptrdiff_t>(cdf.size()) - 1));
}
// Maps v in [-src, src] (or [1, src]) to the target range by scaling.
int rescale(int v, int src, int dst) {
  if (src == dst) return v;
  if (src == 0) return 0;
  return static_cast<int>(std::lround(static_cast<double>(v) * dst / src));
}
}  // namespace

WindowSampler::WindowSampler(const WindowParams& params, const WindowBounds& bounds)
    : p_(params), b_(bounds) {
  p_.validate();
  if (p_.mode == WindowSampling::Learned) {
    cdf_dx_ = smoothed_cdf(p_.learned.dx);
    cdf_dy_ = smoothed_cdf(p_.learned.dy);
    cdf_w_ = smoothed_cdf(p_.learned.w);
    cdf_h_ = smoothed_cdf(p_.learned.h);
  }
}

int WindowSampler::draw_dx(Rng& rng) const {
  if (p_.mode == WindowSampling::Learned) {
    const int v = sample_cdf(cdf_dx_, rng) - p_.learned.bounds.max_dx;
    return std::clamp(rescale(v, p_.learned.bounds.max_dx, b_.max_dx), -b_.max_dx, b_.max_dx);
  }
  return rng.uniform_int(-b_.max_dx, b_.max_dx);
}

int WindowSampler::draw_dy(Rng& rng) const {
  switch (p_.mode) {
    case WindowSampling::Learned: {
      const int v = sample_cdf(cdf_dy_, rng) - p_.learned.bounds.max_dy;
      return std::clamp(rescale(v, p_.learned.bounds.max_dy, b_.max_dy), -b_.max_dy, b_.max_dy);
    }
    case WindowSampling::Thesis:
      if (rng.uniform() < p_.thesis_dy_share) {
        // V-shaped (piecewise triangular) law on [-max_dy, max_dy]: density grows with |dy|.
        const double a = std::floor((b_.max_dy + 1) * std::sqrt(rng.uniform()));
        const int mag = std::min(b_.max_dy, static_cast<int>(a));
        return rng.below(2) ? -mag : mag;
      }
      [[fallthrough]];
    case WindowSampling::Uniform: break;
  }
  return rng.uniform_int(-b_.max_dy, b_.max_dy);
}

int WindowSampler::draw_size(Rng& rng, int max, double share, const std::vector<double>& cdf,
                             int learned_max) const {
  switch (p_.mode) {
    case WindowSampling::Learned: {
      const int v = sample_cdf(cdf, rng) + 1;
      return std::clamp(rescale(v, learned_max, max), 1, max);
    }
    case WindowSampling::Thesis:
      if (rng.uniform() < share) {
        // Rising triangular law on [1, max]: density grows with the size.
        const double a = std::floor(max * std::sqrt(rng.uniform()));
        return 1 + std::min(max - 1, static_cast<int>(a));
      }
      [[fallthrough]];
    case WindowSampling::Uniform: break;
  }
  return rng.uniform_int(1, max);
}

Window WindowSampler::draw(Rng& rng) const {
  Window win;
  win.dx = draw_dx(rng);
  win.dy = draw_dy(rng);
  win.w = draw_size(rng, b_.max_w, p_.thesis_size_share, cdf_w_, p_.learned.bounds.max_w);
  win.h = draw_size(rng, b_.max_h, p_.thesis_size_share, cdf_h_, p_.learned.bounds.max_h);
  return win;
}

void WindowSampler::draw_offset(Rng& rng, int& dx, int& dy) const {
  dx = draw_dx(rng);
  dy = draw_dy(rng);
}

}  // namespace smseg::forest
