#pragma once
// Helpers shared by the libforest tests: plain reference implementations written straight from the
// specification (thesis sections 2.3.3-2.3.4, docs/design.md section 4), to check the fast paths against.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "smseg/forest/classify.hpp"
#include "smseg/forest/synthetic.hpp"
#include "smseg/forest/train.hpp"
#include "temp_dir.hpp"

namespace forest_test {

using namespace smseg::forest;
namespace fs = std::filesystem;

inline fs::path temp_dir(const std::string& name) { return smseg::test::temp_dir("forest_" + name); }

/// Puts an environment variable back as it was (set or not) when the scope ends, a failed ASSERT's
/// early return included: a test that forces SMSEG_SIMD does not force it on the tests after it.
class RestoreEnv {
 public:
  explicit RestoreEnv(const char* name) : name_(name) {
    if (const char* v = std::getenv(name)) saved_ = v;
  }
  ~RestoreEnv() {
    if (saved_) ::setenv(name_, saved_->c_str(), 1);
    else ::unsetenv(name_);
  }
  RestoreEnv(const RestoreEnv&) = delete;
  RestoreEnv& operator=(const RestoreEnv&) = delete;

 private:
  const char* name_;
  std::optional<std::string> saved_;
};

/// Sum of image over the window rectangle clipped to the image, by brute force.
inline double brute_window_sum(const std::vector<double>& img, int W, int H, int x, int y, const Window& win) {
  const int x0 = x + win.dx - win.w / 2, y0 = y + win.dy - win.h / 2;
  double s = 0.0;
  for (int yy = y0; yy < y0 + win.h; ++yy)
    for (int xx = x0; xx < x0 + win.w; ++xx)
      if (xx >= 0 && xx < W && yy >= 0 && yy < H) s += img[static_cast<std::size_t>(yy) * W + xx];
  return s;
}

/// Texton tests by their definition.
inline float brute_texton(const std::vector<std::uint8_t>& gray, int W, int H, int x, int y, int dx, int dy, int test) {
  const int pt = gray[static_cast<std::size_t>(y) * W + x];
  const int sx = x + dx, sy = y + dy;
  const int ps = (sx >= 0 && sx < W && sy >= 0 && sy < H) ? gray[static_cast<std::size_t>(sy) * W + sx] : 0;
  const int v = test == 0 ? ps : test == 1 ? pt + ps : test == 2 ? pt - ps : std::abs(pt - ps);
  return static_cast<float>(v);
}

/// Attribute value of (feature f, window) at a pixel of frame fi, from the raw images.
inline float brute_value(const SyntheticData& s, int fi, int f, const Window& win, int x, int y) {
  const int F = static_cast<int>(s.data.features.size());
  const int W = s.data.width, H = s.data.height;
  if (f < F) return static_cast<float>(brute_window_sum(s.images[static_cast<std::size_t>(fi) * F + f], W, H, x, y, win));
  return brute_texton(s.gray[static_cast<std::size_t>(fi)], W, H, x, y, win.dx, win.dy, f - F);
}

/// Per-pixel reference classifier: walks the model's nodes with double thresholds
/// (float(value) < t goes left), sums float(count / total) over trees in order, MAP with ties to the
/// lowest class. Values from the raw images (exact when features are integers).
inline int reference_classify(const Forest& forest, const SyntheticData& s, int fi, int x, int y, std::vector<float>& acc) {
  const std::size_t C = forest.classes.size();
  acc.assign(C, 0.0f);
  for (const Tree& tree : forest.trees) {
    std::size_t i = 0;
    while (!tree.nodes[i].is_leaf()) {
      const Node& n = tree.nodes[i];
      const float v = brute_value(s, fi, n.feature, n.win, x, y);
      i = static_cast<std::size_t>(static_cast<double>(v) < n.threshold ? n.left : n.right);
    }
    const Node& leaf = tree.nodes[i];
    double total = 0.0;
    for (auto c : leaf.counts) total += c;
    for (std::size_t c = 0; c < C; ++c) acc[c] += static_cast<float>(leaf.counts[c] / total);
  }
  int best = 0;
  for (std::size_t c = 1; c < C; ++c)
    if (acc[c] > acc[static_cast<std::size_t>(best)]) best = static_cast<int>(c);
  return best;
}

/// Fraction of non-void pixels of frame fi whose label equals the classifier's.
inline double frame_accuracy(const Classifier& clf, const SyntheticData& s, int fi) {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(s.data.width) * s.data.height);
  clf.classify_frame(s.data.frames[static_cast<std::size_t>(fi)], out);
  const auto& lab = s.labels[static_cast<std::size_t>(fi)];
  std::size_t right = 0, n = 0;
  for (std::size_t i = 0; i < out.size(); ++i)
    if (lab[i] != kVoidLabel) {
      ++n;
      right += out[i] == lab[i];
    }
  return n ? static_cast<double>(right) / static_cast<double>(n) : 0.0;
}

/// Serialised forest without timings (which differ from run to run).
inline std::string model_bytes(Forest f) {
  f.stats.seconds = 0.0;
  for (auto& t : f.stats.trees) t.seconds = 0.0;
  return forest_to_json(f).dump();
}

}  // namespace forest_test
