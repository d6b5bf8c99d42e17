// Classification over flattened trees (see classify.hpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include "smseg/common/error.hpp"
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
      textons_(forest.textons),
      padded_classes_((num_classes_ + 3) / 4 * 4) {
  if (num_classes_ < 1 || num_classes_ > 255) throw Error("", "classes", "expected 1..255 classes");
  if (width_ < 1 || height_ < 1 || width_ > 32767 || height_ > 32767)
    throw Error("", "image", "expected a width and height of 1..32767 pixels");
  if (forest.trees.empty()) throw Error("", "trees", "the forest has no tree");
  const int num_attr = forest.num_attributes();
  inner_x0_ = 0;
  inner_x1_ = width_ - 1;
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
        p.left = static_cast<std::int32_t>(leaf_probs_.size() / static_cast<std::size_t>(padded_classes_));
        for (auto c : nd.counts) leaf_probs_.push_back(static_cast<float>(c / total));
        leaf_probs_.resize(leaf_probs_.size() + static_cast<std::size_t>(padded_classes_ - num_classes_), 0.0f);
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
          inner_x0_ = std::max(inner_x0_, -r.x0);
          inner_x1_ = std::min(inner_x1_, width_ - r.x1);
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
        const float* p = leaf_probs_.data() + static_cast<std::ptrdiff_t>(nd.left) * padded_classes_;
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
    Scratch s;
    for (std::size_t blk = r.begin(); blk != r.end(); ++blk) {
      const std::size_t b = blk * kChunk, e = std::min(pixels.size(), b + kChunk);
      s.xs.resize(e - b);
      s.ys.resize(e - b);
      for (std::size_t i = b; i < e; ++i) {
        s.xs[i - b] = pixels[i].x;
        s.ys[i - b] = pixels[i].y;
      }
      classify_set(frame, s, e - b, labels.data() + b, dists.empty() ? nullptr : dists.data() + b * C);
    }
  });
}

namespace {
// A pixel of the set being routed: bits 0..31 its own table cell y * (width + 1) + x, bits 32..47 its
// column x, bits 48..63 its index in the set.
inline std::uint64_t make_key(std::int32_t x, std::int32_t y, std::int32_t stride, std::size_t id) {
  return static_cast<std::uint64_t>(static_cast<std::uint32_t>(y * stride + x)) |
         static_cast<std::uint64_t>(static_cast<std::uint32_t>(x)) << 32 | static_cast<std::uint64_t>(id) << 48;
}
inline std::int32_t key_cell(std::uint64_t k) { return static_cast<std::int32_t>(k & 0xffffffffu); }
inline std::int32_t key_x(std::uint64_t k) { return static_cast<std::int32_t>((k >> 32) & 0xffffu); }
inline std::uint32_t key_id(std::uint64_t k) { return static_cast<std::uint32_t>(k >> 48); }

// One window test (feature table, rectangle relative to the pixel) with its clamping bounds.
struct WindowTest {
  const double* sat;
  std::int32_t x0, x1, r0, r1;  // columns; rows as table offsets (row * S)
  std::int32_t W, HS;           // clamp bounds: columns [0, W], row offsets [0, H * S]
};

// window_sum() for a keyed pixel, corners clamped branch-free: the same four reads, in its order.
inline double clamped_sum(const WindowTest& w, std::uint64_t k) {
  const std::int32_t x = key_x(k), row = key_cell(k) - x;
  const std::int32_t xa = std::min(std::max(x + w.x0, 0), w.W), xb = std::min(std::max(x + w.x1, 0), w.W);
  const std::int32_t ta = std::min(std::max(row + w.r0, 0), w.HS), tb = std::min(std::max(row + w.r1, 0), w.HS);
  const double* top = w.sat + ta;
  const double* bot = w.sat + tb;
  return (bot[xb] - top[xb]) - (bot[xa] - top[xa]);
}

// Address of sat[off] as an integer (off may point before the table; it is only read after adding
// a pixel's cell that brings it back inside).
inline std::uintptr_t at(const double* sat, std::ptrdiff_t off) {
  return reinterpret_cast<std::uintptr_t>(sat) + static_cast<std::uintptr_t>(off) * sizeof(double);
}
inline double read(std::uintptr_t base, std::int32_t cell) {
  return *reinterpret_cast<const double*>(base + static_cast<std::uintptr_t>(static_cast<std::intptr_t>(cell)) * sizeof(double));
}

// Routes keys [b, e) of src by float(window sum) < thr: left-goers compacted to p + b (src may be
// p: in place), right-goers to tmp; returns the number of left-goers. Keys [b, m) are pixels whose columns keep
// every window of the forest inside the image; when the set's rows do too (rows_inside), they take
// four reads at fixed offsets from their own cell, no clipping. The others clamp their corners.
std::uint32_t route_window(const WindowTest& w, bool rows_inside, float thr, const std::uint64_t* src,
                           std::uint64_t* p, std::uint32_t b, std::uint32_t m, std::uint32_t e, std::uint64_t* tmp) {
  std::uint64_t* pl = p + b;
  std::uint64_t* pr = tmp;
  const std::uint64_t* q = src + b;
  if (rows_inside) {
    const std::uintptr_t tl = at(w.sat, w.r0 + w.x0), tr = at(w.sat, w.r0 + w.x1);
    const std::uintptr_t bl = at(w.sat, w.r1 + w.x0), br = at(w.sat, w.r1 + w.x1);
    for (const std::uint64_t* const mid = src + m; q != mid; ++q) {
      const std::uint64_t k = *q;
      const std::int32_t c = key_cell(k);
      const double v = (read(br, c) - read(tr, c)) - (read(bl, c) - read(tl, c));
      const std::size_t go_left = static_cast<float>(v) < thr ? 1u : 0u;
      *pl = k;
      *pr = k;
      pl += go_left;
      pr += go_left ^ 1u;
    }
  }
  const std::uint64_t* const end = src + e;
  if (rows_inside) {  // the other pixels: only the columns need clamping
    const std::uintptr_t top = at(w.sat, w.r0), bot = at(w.sat, w.r1);
    for (; q != end; ++q) {
      const std::uint64_t k = *q;
      const std::int32_t x = key_x(k), row = key_cell(k) - x;
      const std::int32_t xa = row + std::min(std::max(x + w.x0, 0), w.W), xb = row + std::min(std::max(x + w.x1, 0), w.W);
      const double v = (read(bot, xb) - read(top, xb)) - (read(bot, xa) - read(top, xa));
      const std::size_t go_left = static_cast<float>(v) < thr ? 1u : 0u;
      *pl = k;
      *pr = k;
      pl += go_left;
      pr += go_left ^ 1u;
    }
  }
  for (; q != end; ++q) {
    const std::uint64_t k = *q;
    const std::size_t go_left = static_cast<float>(clamped_sum(w, k)) < thr ? 1u : 0u;
    *pl = k;
    *pr = k;
    pl += go_left;
    pr += go_left ^ 1u;
  }
  return static_cast<std::uint32_t>(pl - (p + b));
}
}  // namespace

void Classifier::classify_set(const FrameData& frame, Scratch& s, std::size_t n, std::uint8_t* labels,
                              float* dists) const {
  const std::size_t C = static_cast<std::size_t>(num_classes_), Cp = static_cast<std::size_t>(padded_classes_);
  const std::size_t M = roots_.size();
  const std::int32_t W = width_, H = height_, F = num_features_;
  const std::int32_t S = W + 1, HS = H * S;
  s.init.resize(n);
  s.keys.resize(n);
  s.tmp.resize(n);
  s.leaf.resize(n * M);
  // Pixels whose columns keep every window inside the image first, the others after them, each
  // group in the given order; stable partitions keep the two groups apart at every node.
  std::int32_t ymin = H, ymax = -1;
  std::size_t mid = 0;
  const std::uint32_t span = static_cast<std::uint32_t>(inner_x1_ - inner_x0_);
  const auto inner = [&](std::uint64_t k) { return static_cast<std::uint32_t>(key_x(k) - inner_x0_) <= span; };
  for (std::size_t i = 0; i < n; ++i) {
    ymin = std::min(ymin, s.ys[i]);
    ymax = std::max(ymax, s.ys[i]);
    mid += inner_x1_ >= inner_x0_ && static_cast<std::uint32_t>(s.xs[i] - inner_x0_) <= span;
  }
  for (std::size_t i = 0, a = 0, b = mid; i < n; ++i) {
    const std::uint64_t k = make_key(s.xs[i], s.ys[i], S, i);
    s.init[inner_x1_ >= inner_x0_ && inner(k) ? a++ : b++] = k;
  }
  const double* const* sats = frame.sats.data();
  for (std::size_t t = 0; t < M; ++t) {
    std::uint64_t* p = s.keys.data();
    std::uint64_t* tmp = s.tmp.data();
    std::int32_t* leaf = s.leaf.data() + t * n;
    s.stack.assign(1, Item{roots_[t], 0, static_cast<std::uint32_t>(n)});
    while (!s.stack.empty()) {
      const Item it = s.stack.back();
      s.stack.pop_back();
      const PackedNode& nd = nodes_[static_cast<std::size_t>(it.node)];
      const std::uint64_t* src = it.node == roots_[t] ? s.init.data() : p;  // the root reads the set as given
      if (nd.feature < 0) {
        for (std::uint32_t i = it.begin; i < it.end; ++i) leaf[key_id(src[i])] = nd.left;
        continue;
      }
      std::uint32_t l = it.begin, r = 0;
      const float thr = nd.threshold;
      // Stable partition: left-goers compacted to p (l <= i), right-goers to tmp, then appended.
      const auto route = [&](std::uint64_t k, float v) {
        const std::uint32_t go_left = v < thr ? 1u : 0u;
        p[l] = k;
        tmp[r] = k;
        l += go_left;
        r += 1u - go_left;
      };
      if (nd.feature < F) {
        const WindowTest w{sats[nd.feature], nd.x0, nd.x1, nd.y0 * S, nd.y1 * S, W, HS};
        // The inner group's end in this range: the first key outside it (binary search).
        const std::uint32_t m = inner_x1_ < inner_x0_ ? it.begin
                                : static_cast<std::uint32_t>(std::partition_point(src + it.begin, src + it.end, inner) - src);
        const std::uint32_t left = route_window(w, ymin + nd.y0 >= 0 && ymax + nd.y1 <= H, thr, src, p, it.begin, m, it.end, tmp);
        l = it.begin + left;
        r = (it.end - it.begin) - left;
      } else {
        const int test = nd.feature - F;
        for (std::uint32_t i = it.begin; i < it.end; ++i) {
          const std::uint64_t k = src[i];
          const std::uint32_t id = key_id(k);
          route(k, texton_value(frame.gray, W, H, s.xs[id], s.ys[id], nd.x0, nd.y0, test));
        }
      }
      std::copy(tmp, tmp + r, p + l);
      if (l < it.end) s.stack.push_back({nd.right, l, it.end});
      if (l > it.begin) s.stack.push_back({nd.left, it.begin, l});
    }
  }
  // Summed distributions, trees in order (the same float sums as posterior()), then the MAP class.
  float acc[kMaxClasses + 4];
  const float* probs = leaf_probs_.data();
  for (std::size_t i = 0; i < n; ++i) {
    const float* q0 = probs + static_cast<std::size_t>(s.leaf[i]) * Cp;
    for (std::size_t c = 0; c < Cp; ++c) acc[c] = q0[c];  // = 0.0f + q0[c]
    for (std::size_t t = 1; t < M; ++t) {
      const float* q = probs + static_cast<std::size_t>(s.leaf[t * n + i]) * Cp;
      for (std::size_t c = 0; c < Cp; ++c) acc[c] += q[c];
    }
    std::size_t best = 0;
    for (std::size_t c = 1; c < C; ++c)
      if (acc[c] > acc[best]) best = c;
    labels[i] = static_cast<std::uint8_t>(best);
    if (dists) std::copy(acc, acc + C, dists + i * C);
  }
}

void Classifier::classify_frame(const FrameData& frame, std::span<std::uint8_t> labels, std::span<float> dists) const {
  check_frame(frame);
  const std::size_t n = static_cast<std::size_t>(width_) * height_;
  const std::size_t C = static_cast<std::size_t>(num_classes_);
  if (labels.size() != n) throw Error("", "labels", "needs width x height entries");
  if (!dists.empty() && dists.size() != n * C) throw Error("", "dists", "needs width x height x classes entries (or none)");
  const int rows = std::clamp(kSetPixels / width_, 1, kBlockRows);  // rows per task
  tbb::parallel_for(tbb::blocked_range<int>(0, (height_ + rows - 1) / rows), [&](const tbb::blocked_range<int>& r) {
    Scratch s;
    for (int blk = r.begin(); blk != r.end(); ++blk) {
      const int y0 = blk * rows, y1 = std::min(height_, y0 + rows);
      const std::size_t m = static_cast<std::size_t>(y1 - y0) * width_;
      s.xs.resize(m);
      s.ys.resize(m);
      for (std::size_t i = 0; i < m; ++i) {
        s.xs[i] = static_cast<std::int32_t>(i % static_cast<std::size_t>(width_));
        s.ys[i] = y0 + static_cast<std::int32_t>(i / static_cast<std::size_t>(width_));
      }
      const std::size_t off = static_cast<std::size_t>(y0) * width_;
      classify_set(frame, s, m, labels.data() + off, dists.empty() ? nullptr : dists.data() + off * C);
    }
  });
}

}  // namespace smseg::forest
