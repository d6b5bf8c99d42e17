// Classification over flattened trees (see classify.hpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include "smseg/common/error.hpp"
#include "smseg/forest/classify.hpp"
#include "forest_simd.hpp"

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

// classify_pixels' sets: pieces of about kSetPixels pixels, and at least kPiecesPerThread pieces per
// thread of the arena, so that every thread gets an even share (a thread slowed by a neighbour leaves
// its last piece to the others), but not below kMinPixels (a vector walk needs pixels for its lanes).
// A set's pixels go through every tree together and read the tables around them: a few hundred
// neighbouring voters keep those reads in the caches (bench_eval, CamVid grid B = 20, V = 6, one
// thread: sets of 64-650 voters 2.2-2.4 ms, all 2 592 in one set 3.0 ms).
std::size_t pixel_chunk(std::size_t n) {
  constexpr std::size_t kSetPixels = 256, kPiecesPerThread = 2, kMinPixels = 64;
  const auto threads = static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  const std::size_t wanted = std::max((n + kSetPixels - 1) / kSetPixels, kPiecesPerThread * threads);
  const std::size_t pieces = std::clamp<std::size_t>(n / kMinPixels, 1, wanted);
  return std::max<std::size_t>(1, (n + pieces - 1) / pieces);
}
}  // namespace

Classifier::Classifier(const Forest& forest)
    : width_(forest.width),
      height_(forest.height),
      num_classes_(static_cast<int>(forest.classes.size())),
      num_features_(static_cast<int>(forest.features.size())),
      textons_(forest.textons),
      padded_classes_((num_classes_ + 15) / 16 * 16) {
  if (num_classes_ < 1 || num_classes_ > 255) throw Error("", "classes", "expected 1..255 classes");
  if (width_ < 1 || height_ < 1 || width_ > 32767 || height_ > 32767)
    throw Error("", "image", "expected a width and height of 1..32767 pixels");
  if (forest.trees.empty()) throw Error("", "trees", "the forest has no tree");
  const int num_attr = forest.num_attributes();
  inner_x0_ = 0;
  inner_x1_ = width_ - 1;
  inner_y0_ = 0;
  inner_y1_ = height_ - 1;
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
          inner_y0_ = std::max(inner_y0_, -r.y0);
          inner_y1_ = std::min(inner_y1_, height_ - r.y1);
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
  build_compact(forest);
  simd_ = detail::default_simd_kernels();
}

Classifier::Classifier(const Forest& forest, const std::vector<double>& class_weights) : Classifier(forest) {
  if (class_weights.size() != static_cast<std::size_t>(num_classes_))
    throw Error("", "class_weights", "expected one weight per class (" + std::to_string(num_classes_) + ")");
  for (double w : class_weights)
    if (!(w >= 0.0) || !std::isfinite(w)) throw Error("", "class_weights", "expected finite weights >= 0");
  // Each leaf row scaled: the trees' sum is then the weighted sum, on every path (scalar, tiles, SIMD).
  for (std::size_t row = 0; row < leaf_probs_.size(); row += static_cast<std::size_t>(padded_classes_))
    for (int c = 0; c < num_classes_; ++c)
      leaf_probs_[row + static_cast<std::size_t>(c)] =
          static_cast<float>(leaf_probs_[row + static_cast<std::size_t>(c)] * class_weights[static_cast<std::size_t>(c)]);
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
  const std::size_t chunk = pixel_chunk(pixels.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (pixels.size() + chunk - 1) / chunk, 1), [&](const tbb::blocked_range<std::size_t>& r) {
    Scratch s;
    for (std::size_t blk = r.begin(); blk != r.end(); ++blk) {
      const std::size_t b = blk * chunk, m = std::min(pixels.size(), b + chunk) - b;
      s.xs.resize(m);
      s.ys.resize(m);
      for (std::size_t i = 0; i < m; ++i) {
        s.xs[i] = pixels[b + i].x;
        s.ys[i] = pixels[b + i].y;
      }
      classify_set(frame, {frame.sats.data(), width_ + 1}, s, m, order_inside_first(s, m), !dists.empty(),
                   nullptr);
      for (std::size_t i = 0; i < m; ++i) {  // back to the caller's order
        const std::size_t to = b + s.index[i];
        labels[to] = s.labels[i];
        if (!dists.empty()) std::copy_n(s.dists.data() + i * C, C, dists.data() + to * C);
      }
    }
  });
}

void Classifier::classify_frame(const FrameData& frame, std::span<std::uint8_t> labels, std::span<float> dists) const {
  check_frame(frame);
  const std::size_t n = static_cast<std::size_t>(width_) * height_;
  const std::size_t C = static_cast<std::size_t>(num_classes_);
  if (labels.size() != n) throw Error("", "labels", "needs width x height entries");
  if (!dists.empty() && dists.size() != n * C) throw Error("", "dists", "needs width x height x classes entries (or none)");
  // The copy is this thread's: isolated, so that while this thread waits for the tiles TBB cannot
  // hand it another frame's classify_frame (from a caller's parallel loop), which would refill it.
  // Every pixel reads the copy without clipping. The copy costs a pass over the tables; a few pixels
  // (classify_pixels) read the frame's own tables instead.
  thread_local PaddedTables this_threads_copy;
  tbb::this_task_arena::isolate([&] {
    const int pad_x = std::max(inner_x0_, width_ - inner_x1_), pad_y = std::max(inner_y0_, height_ - inner_y1_);
    classify_tiles(frame, this_threads_copy.fill(frame, pad_x, pad_y), labels, dists);
  });
}

void Classifier::classify_tiles(const FrameData& frame, const Tables& tables, std::span<std::uint8_t> labels,
                                std::span<float> dists) const {
  const std::size_t C = static_cast<std::size_t>(num_classes_);
  // Tiles of pixels, each labelled as one set; the output does not depend on the tiling.
  const int tiles_x = (width_ + kTileWidth - 1) / kTileWidth;
  const int bands = 2 * ((height_ + 2 * kTileHeightMax - 1) / (2 * kTileHeightMax));
  const int tile_height = (height_ + bands - 1) / bands;
  const int tiles_y = (height_ + tile_height - 1) / tile_height;
  tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x * tiles_y), [&](const tbb::blocked_range<int>& r) {
    Scratch s;
    for (int tile = r.begin(); tile != r.end(); ++tile) {
      const int x0 = tile % tiles_x * kTileWidth, y0 = tile / tiles_x * tile_height;
      const int x1 = std::min(width_, x0 + kTileWidth), y1 = std::min(height_, y0 + tile_height);
      const std::size_t tw = static_cast<std::size_t>(x1 - x0), m = tw * static_cast<std::size_t>(y1 - y0);
      s.xs.resize(m);
      s.ys.resize(m);
      for (std::size_t i = 0; i < m; ++i) {
        s.xs[i] = x0 + static_cast<std::int32_t>(i % tw);
        s.ys[i] = y0 + static_cast<std::int32_t>(i / tw);
      }
      const Tile t{x0, y0, x1 - x0, y1 - y0};
      classify_set(frame, tables, s, m, m, !dists.empty(), &t);
      for (std::size_t i = 0; i < m; ++i) {  // to the pixel's place in the frame
        const std::size_t to = static_cast<std::size_t>(s.ys[i]) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(s.xs[i]);
        labels[to] = s.labels[i];
        if (!dists.empty()) std::copy_n(s.dists.data() + i * C, C, dists.data() + to * C);
      }
    }
  });
}

}  // namespace smseg::forest
