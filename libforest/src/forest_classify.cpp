// Classification over flattened trees (see classify.hpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include "smseg/error.hpp"
#include "smseg/forest/classify.hpp"

namespace smseg::forest {

namespace {
float float_ceil(double t) {
  if (t > static_cast<double>(std::numeric_limits<float>::max())) return std::numeric_limits<float>::infinity();
  if (t < -static_cast<double>(std::numeric_limits<float>::max())) return -std::numeric_limits<float>::max();
  float f = static_cast<float>(t);
  if (static_cast<double>(f) < t) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}
constexpr int kMaxClasses = 256;
}  // namespace

Classifier::Classifier(const Forest& forest)
    : width_(forest.width),
      height_(forest.height),
      num_classes_(static_cast<int>(forest.classes.size())),
      num_features_(static_cast<int>(forest.features.size())),
      textons_(forest.textons) {
  if (num_classes_ < 1 || num_classes_ > 255) throw Error("", "classes", "expected 1..255 classes");
  if (forest.trees.empty()) throw Error("", "trees", "the forest has no tree");
  const int num_attr = forest.num_attributes();
  for (const Tree& tree : forest.trees) {
    const auto base = static_cast<std::int32_t>(nodes_.size());
    roots_.push_back(base);
    const auto n = static_cast<std::int32_t>(tree.nodes.size());
    for (std::int32_t i = 0; i < n; ++i) {
      const Node& nd = tree.nodes[static_cast<std::size_t>(i)];
      PackedNode p{};
      if (nd.is_leaf()) {
        if (nd.counts.size() != static_cast<std::size_t>(num_classes_))
          throw Error("", "trees.nodes.counts", "leaf with the wrong number of classes");
        double total = 0.0;
        for (auto c : nd.counts) total += c;
        if (!(total > 0.0)) throw Error("", "trees.nodes.counts", "empty leaf");
        p.feature = -1;
        p.left = static_cast<std::int32_t>(leaf_probs_.size() / static_cast<std::size_t>(num_classes_));
        for (auto c : nd.counts) leaf_probs_.push_back(static_cast<float>(c / total));
      } else {
        if (nd.feature >= num_attr || nd.left <= i || nd.right <= i || nd.left >= n || nd.right >= n)
          throw Error("", "trees.nodes", "malformed split node");
        p.feature = nd.feature;
        if (nd.feature < num_features_) {
          const RelRect r = rel_rect(nd.win);
          p.x0 = static_cast<std::int16_t>(r.x0);
          p.x1 = static_cast<std::int16_t>(r.x1);
          p.y0 = static_cast<std::int16_t>(r.y0);
          p.y1 = static_cast<std::int16_t>(r.y1);
        } else {
          p.x0 = static_cast<std::int16_t>(nd.win.dx);
          p.y0 = static_cast<std::int16_t>(nd.win.dy);
        }
        p.threshold = float_ceil(nd.threshold);
        p.left = base + nd.left;
        p.right = base + nd.right;
      }
      nodes_.push_back(p);
    }
  }
}

void Classifier::check_frame(const FrameData& frame) const {
  validate_frame(frame, width_, height_, static_cast<std::size_t>(num_features_), textons_, "frame", "frame");
}

template <bool kTextons>
int Classifier::run(const FrameData& frame, int x, int y, float* acc) const {
  const int C = num_classes_;
  for (int c = 0; c < C; ++c) acc[c] = 0.0f;
  const PackedNode* nodes = nodes_.data();
  const double* const* sats = frame.sats.data();
  for (const std::int32_t root : roots_) {
    std::int32_t i = root;
    for (;;) {
      const PackedNode& nd = nodes[i];
      if (nd.feature < 0) {
        const float* p = leaf_probs_.data() + static_cast<std::ptrdiff_t>(nd.left) * C;
        for (int c = 0; c < C; ++c) acc[c] += p[c];
        break;
      }
      float v;
      if (!kTextons || nd.feature < num_features_) {
        v = static_cast<float>(window_sum(sats[nd.feature], width_, height_, x, y, RelRect{nd.x0, nd.x1, nd.y0, nd.y1}));
      } else {
        v = texton_value(frame.gray, width_, height_, x, y, nd.x0, nd.y0, nd.feature - num_features_);
      }
      i = v < nd.threshold ? nd.left : nd.right;
    }
  }
  int best = 0;
  for (int c = 1; c < C; ++c)
    if (acc[c] > acc[best]) best = c;
  return best;
}

int Classifier::posterior(const FrameData& frame, int x, int y, float* out) const {
  check_frame(frame);
  if (x < 0 || y < 0 || x >= width_ || y >= height_)
    throw Error("frame", "pixel", "(" + std::to_string(x) + ", " + std::to_string(y) + ") outside the image");
  return textons_ ? run<true>(frame, x, y, out) : run<false>(frame, x, y, out);
}

int Classifier::classify(const FrameData& frame, int x, int y) const {
  float acc[kMaxClasses];
  return posterior(frame, x, y, acc);
}

void Classifier::classify_pixels(const FrameData& frame, std::span<const Pixel> pixels,
                                 std::span<std::uint8_t> labels, std::span<float> dists) const {
  check_frame(frame);
  if (labels.size() != pixels.size()) throw Error("", "labels", "needs one entry per pixel");
  const std::size_t C = static_cast<std::size_t>(num_classes_);
  if (!dists.empty() && dists.size() != pixels.size() * C)
    throw Error("", "dists", "needs pixels x classes entries (or none)");
  for (std::size_t i = 0; i < pixels.size(); ++i)
    if (pixels[i].x < 0 || pixels[i].y < 0 || pixels[i].x >= width_ || pixels[i].y >= height_)
      throw Error("", "pixels[" + std::to_string(i) + "]", "outside the image");
  constexpr std::size_t kChunk = 2048;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (pixels.size() + kChunk - 1) / kChunk), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<std::int32_t> xs, ys;
    for (std::size_t blk = r.begin(); blk != r.end(); ++blk) {
      const std::size_t b = blk * kChunk, e = std::min(pixels.size(), b + kChunk);
      xs.resize(e - b);
      ys.resize(e - b);
      for (std::size_t i = b; i < e; ++i) {
        xs[i - b] = pixels[i].x;
        ys[i - b] = pixels[i].y;
      }
      classify_set(frame, xs.data(), ys.data(), e - b, labels.data() + b, dists.empty() ? nullptr : dists.data() + b * C);
    }
  });
}

void Classifier::classify_set(const FrameData& frame, const std::int32_t* xs, const std::int32_t* ys,
                              std::size_t n, std::uint8_t* labels, float* dists) const {
  const std::size_t C = static_cast<std::size_t>(num_classes_);
  std::vector<float> acc(n * C, 0.0f);
  std::vector<std::uint32_t> pix(n), tmp(n);
  struct Item {
    std::int32_t node;
    std::uint32_t begin, end;
  };
  std::vector<Item> stack;
  const double* const* sats = frame.sats.data();
  const int W = width_, H = height_, F = num_features_;
  for (const std::int32_t root : roots_) {  // trees in order: the same float sums as posterior()
    for (std::size_t i = 0; i < n; ++i) pix[i] = static_cast<std::uint32_t>(i);
    stack.assign(1, Item{root, 0, static_cast<std::uint32_t>(n)});
    while (!stack.empty()) {
      const Item it = stack.back();
      stack.pop_back();
      const PackedNode& nd = nodes_[static_cast<std::size_t>(it.node)];
      std::uint32_t* p = pix.data();
      if (nd.feature < 0) {
        const float* prob = leaf_probs_.data() + static_cast<std::ptrdiff_t>(nd.left) * num_classes_;
        for (std::uint32_t i = it.begin; i < it.end; ++i) {
          float* a = acc.data() + static_cast<std::size_t>(p[i]) * C;
          for (std::size_t c = 0; c < C; ++c) a[c] += prob[c];
        }
        continue;
      }
      std::uint32_t l = it.begin, r = 0;
      const float thr = nd.threshold;
      if (nd.feature < F) {
        const double* sat = sats[nd.feature];
        const RelRect rect{nd.x0, nd.x1, nd.y0, nd.y1};
        // Pixels whose window lies inside the image need no clipping: four reads at fixed offsets
        // from the pixel's own table cell, the same operands in the same order as window_sum().
        const std::ptrdiff_t stride = W + 1;
        const std::ptrdiff_t o_tl = rect.y0 * stride + rect.x0, o_tr = rect.y0 * stride + rect.x1;
        const std::ptrdiff_t o_bl = rect.y1 * stride + rect.x0, o_br = rect.y1 * stride + rect.x1;
        const std::uint32_t xlo = static_cast<std::uint32_t>(-rect.x0), xspan = static_cast<std::uint32_t>(W - rect.x1 + rect.x0);
        const std::uint32_t ylo = static_cast<std::uint32_t>(-rect.y0), yspan = static_cast<std::uint32_t>(H - rect.y1 + rect.y0);
        const bool any_interior = W - rect.x1 >= -rect.x0 && H - rect.y1 >= -rect.y0;
        for (std::uint32_t i = it.begin; i < it.end; ++i) {
          const std::uint32_t id = p[i];
          const int x = xs[id], y = ys[id];
          double s;
          if (any_interior && static_cast<std::uint32_t>(x) - xlo <= xspan && static_cast<std::uint32_t>(y) - ylo <= yspan) {
            const double* c = sat + (static_cast<std::ptrdiff_t>(y) * stride + x);
            s = (c[o_br] - c[o_tr]) - (c[o_bl] - c[o_tl]);
          } else {
            s = window_sum(sat, W, H, x, y, rect);
          }
          const float v = static_cast<float>(s);
          const std::uint32_t go_left = v < thr ? 1u : 0u;
          p[l] = id;  // l <= i
          tmp[r] = id;
          l += go_left;
          r += 1u - go_left;
        }
      } else {
        const int test = nd.feature - F;
        for (std::uint32_t i = it.begin; i < it.end; ++i) {
          const std::uint32_t id = p[i];
          const float v = texton_value(frame.gray, W, H, xs[id], ys[id], nd.x0, nd.y0, test);
          const std::uint32_t go_left = v < thr ? 1u : 0u;
          p[l] = id;
          tmp[r] = id;
          l += go_left;
          r += 1u - go_left;
        }
      }
      std::copy(tmp.data(), tmp.data() + r, p + l);
      if (l < it.end) stack.push_back({nd.right, l, it.end});
      if (l > it.begin) stack.push_back({nd.left, it.begin, l});
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const float* a = acc.data() + i * C;
    std::size_t best = 0;
    for (std::size_t c = 1; c < C; ++c)
      if (a[c] > a[best]) best = c;
    labels[i] = static_cast<std::uint8_t>(best);
  }
  if (dists) std::copy(acc.begin(), acc.end(), dists);
}

void Classifier::classify_frame(const FrameData& frame, std::span<std::uint8_t> labels, std::span<float> dists) const {
  check_frame(frame);
  const std::size_t n = static_cast<std::size_t>(width_) * height_;
  const std::size_t C = static_cast<std::size_t>(num_classes_);
  if (labels.size() != n) throw Error("", "labels", "needs width x height entries");
  if (!dists.empty() && dists.size() != n * C) throw Error("", "dists", "needs width x height x classes entries (or none)");
  constexpr int kRows = 8;  // rows per task
  tbb::parallel_for(tbb::blocked_range<int>(0, (height_ + kRows - 1) / kRows), [&](const tbb::blocked_range<int>& r) {
    std::vector<std::int32_t> xs, ys;
    for (int blk = r.begin(); blk != r.end(); ++blk) {
      const int y0 = blk * kRows, y1 = std::min(height_, y0 + kRows);
      const std::size_t m = static_cast<std::size_t>(y1 - y0) * width_;
      xs.resize(m);
      ys.resize(m);
      for (std::size_t i = 0; i < m; ++i) {
        xs[i] = static_cast<std::int32_t>(i % static_cast<std::size_t>(width_));
        ys[i] = y0 + static_cast<std::int32_t>(i / static_cast<std::size_t>(width_));
      }
      const std::size_t off = static_cast<std::size_t>(y0) * width_;
      classify_set(frame, xs.data(), ys.data(), m, labels.data() + off, dists.empty() ? nullptr : dists.data() + off * C);
    }
  });
}

}  // namespace smseg::forest
