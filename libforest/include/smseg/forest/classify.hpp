#pragma once
// Classification (thesis section 2.3.4): each pixel runs through every tree; the trees' leaf
// distributions (normalised class frequencies) are summed and the class of maximum sum is the label
// (ties: the lowest class index). The classifier flattens the trees into packed POD nodes with
// float thresholds rounded up to the next float, which decides exactly as float(value) < t.

#include <cstdint>
#include <span>
#include <vector>

#include "smseg/forest/data.hpp"
#include "smseg/forest/forest.hpp"

namespace smseg::forest {

struct Pixel {
  int x = 0, y = 0;
};

class Classifier {
 public:
  explicit Classifier(const Forest& forest);

  int num_classes() const { return num_classes_; }
  int width() const { return width_; }
  int height() const { return height_; }

  /// Summed leaf distributions over the trees for one pixel: out[c], c < num_classes()
  /// (sums to the number of trees). Returns the MAP class.
  int posterior(const FrameData& frame, int x, int y, float* out) const;
  int classify(const FrameData& frame, int x, int y) const;

  /// A list of pixels: labels[i] for pixels[i]; dists (optional, may be empty) gets
  /// pixels.size() x num_classes() summed distributions. Parallel over pixels.
  void classify_pixels(const FrameData& frame, std::span<const Pixel> pixels,
                       std::span<std::uint8_t> labels, std::span<float> dists = {}) const;

  /// A whole frame: labels (height x width, row-major); dists (optional, may be empty):
  /// height x width x num_classes() summed distributions. Parallel over rows.
  void classify_frame(const FrameData& frame, std::span<std::uint8_t> labels,
                      std::span<float> dists = {}) const;

  /// Error when the frame does not fit the forest (size, number of tables, greyscale for textons).
  void check_frame(const FrameData& frame) const;

 private:
  struct PackedNode {
    std::int16_t x0, x1, y0, y1;  // window rectangle relative to the pixel (textons: x0, y0 = offset)
    std::int32_t feature;         // attribute; -1 leaf
    float threshold;              // smallest float >= the double threshold
    std::int32_t left, right;     // children; leaf: left = row of the leaf table
  };
  template <bool kTextons>
  int run(const FrameData& frame, int x, int y, float* acc) const;
  struct Item {
    std::int32_t node;
    std::uint32_t begin, end;
  };
  /// Per-task buffers, reused from one pixel set to the next (no allocation per set).
  struct Scratch {
    std::vector<std::int32_t> xs, ys;          // the set's pixels
    std::vector<std::uint64_t> init, keys, tmp;  // routing keys (see classify_set)
    std::vector<std::int32_t> leaf;            // leaf row per tree and pixel: leaf[t * n + i]
    std::vector<Item> stack;
  };
  static constexpr int kBlockRows = 4;    // whole frames: at most this many image rows per set
  static constexpr int kSetPixels = 1280;  // ... and about this many pixels
  /// Breadth-wise evaluation of a set of pixels (s.xs, s.ys, n of them): each tree routes the whole
  /// set node by node as 64-bit keys (table cell, column, index; stable partitions keep the pixels in
  /// memory order, so table reads stream). Pixels in the columns where every window of the forest
  /// stays inside the image come first and, when the set's rows keep the node's window inside too,
  /// read four cells at fixed offsets with no clipping; the others clamp branch-free. Each pixel's
  /// leaf is recorded per tree; then the leaf distributions are summed tree by tree (the same float
  /// sums as posterior()) and give the labels. Out: labels[i], dists[i * C + c] (optional).
  void classify_set(const FrameData& frame, Scratch& s, std::size_t n, std::uint8_t* labels, float* dists) const;

  int width_ = 0, height_ = 0, num_classes_ = 0, num_features_ = 0;
  bool textons_ = false;
  std::vector<std::int32_t> roots_;
  std::vector<PackedNode> nodes_;
  int inner_x0_ = 0, inner_x1_ = -1;  // columns where every window of the forest stays inside the image
  int padded_classes_ = 0;         // num_classes_ rounded up to a multiple of 4 (zeros after)
  std::vector<float> leaf_probs_;  // leaf row r: leaf_probs_[r * padded_classes_ + c]
};

}  // namespace smseg::forest
