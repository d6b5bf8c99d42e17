#pragma once
// Classification (thesis section 2.3.4): each pixel runs through every tree; the trees' leaf
// distributions (normalised class frequencies) are summed and the class of maximum sum is the label
// (ties: the lowest class index). The classifier flattens the trees into packed POD nodes with
// float thresholds rounded up to the next float, which decides exactly as float(value) < t.
// Whole frames and pixel lists take a fast path (forest_tiles.cpp): the trees laid out breadth first
// in 16-byte nodes, bands of pixels routed tree by tree and node by node (each split partitions its
// pixels between its children), the same double window sums: bit for bit posterior()'s labels and
// distributions. Its vector kernels are written once with Google Highway and chosen at run time
// (simd_target(); SMSEG_SIMD=scalar|avx2|avx512 forces one).

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "smseg/forest/data.hpp"
#include "smseg/forest/forest.hpp"

namespace smseg::forest {

struct Pixel {
  int x = 0, y = 0;
};

namespace detail {
struct SimdKernels;  // forest_simd.hpp
/// A pixel in partition_tree's runs (forest_tiles.cpp: the scalar path).
struct RoutedPixel {
  std::int32_t cell;  // y * stride + x: the pixel's cell in the tables
  std::int32_t at;    // its place in the set (Scratch::xs[at], Scratch::ys[at])
};
/// Pixels of a tile row per chunk entry (partition_chunks: the vector path).
inline constexpr int kChunkPixels = 16;
/// Up to kChunkPixels neighbouring pixels of a tile row that reach the same node: chunk `chunk` of the
/// tile (its first pixel's cell in Scratch::chunk_cell), bit l of `bits` for its pixel l.
struct ChunkEntry {
  std::uint16_t chunk;
  std::uint16_t bits;
};
/// The four corners of a window relative to a pixel's cell, as offsets into its table.
struct WindowCorners {
  std::ptrdiff_t top_a, top_b, bot_a, bot_b;  // value = (bot_b - top_b) - (bot_a - top_a)
};
}  // namespace detail

class Classifier {
 public:
  explicit Classifier(const Forest& forest);
  /// With each class's leaf probability multiplied by class_weights[c] (one per class, >= 0): labels
  /// and distributions are then those of the weighted posterior (prior_correction in forest.hpp).
  Classifier(const Forest& forest, const std::vector<double>& class_weights);

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

  /// The SIMD target of the fast paths (whole frames' splits, pixel lists' walks, the summed votes):
  /// "scalar" (the reference loops) or a Highway target ("avx2", "avx512"; "neon" on 64-bit Arm). By
  /// default the one the environment variable SMSEG_SIMD names (Error naming SMSEG_SIMD when the name
  /// is unknown or the processor lacks that target), else the best this processor runs. The same labels
  /// and distributions on every target, bit for bit.
  std::string simd_target() const;
  /// Error when `name` is unknown or the processor lacks that target (for tests and benchmarks).
  void set_simd_target(std::string_view name);
  /// The targets this processor runs, "scalar" first, then from the narrowest vectors to the widest.
  static std::vector<std::string> simd_targets();
  /// The target a new Classifier (and the trainer) takes: SMSEG_SIMD's, else the best this processor
  /// runs; Error naming SMSEG_SIMD as simd_target(). Tools call it before reading their data.
  static std::string default_simd_target();

 private:
  struct PackedNode {
    std::int16_t x0, x1, y0, y1;  // window rectangle relative to the pixel (textons: x0, y0 = offset)
    std::int32_t feature;         // attribute; -1 leaf
    float threshold;              // smallest float >= the double threshold
    std::int32_t left, right;     // children; leaf: left = row of the leaf table
  };
  template <bool kTextons>
  int run(const FrameData& frame, int x, int y, float* acc) const;
  /// Compact breadth-first node of the fast path (16 bytes, four to a cache line): a split's two
  /// children are adjacent (right = left + 1), so one index leads to both.
  struct CompactNode {
    std::int16_t x0, x1, y0, y1;  // as PackedNode
    float threshold;              // as PackedNode
    std::uint32_t next;           // bits 0..7: attribute; bit 8: leaf; bits 9..31: left child or leaf row
  };                              // (a leaf reads attribute 0 over an empty window: harmless, unused)
  static constexpr std::uint32_t kLeafBit = 1u << 8;
  /// Per-task buffers, reused from one pixel set to the next (no allocation per set).
  struct Scratch {
    std::vector<std::int32_t> xs, ys;  // the set's pixels
    std::vector<std::uint32_t> index;  // after order_inside_first: each pixel's place in the caller's order
    std::vector<std::int32_t> leaf;    // leaf row per tree and pixel: leaf[t * n + i]
    using Routed = detail::RoutedPixel;
    std::vector<Routed> routed, right;  // partition_tree's runs, and the right-hand side of a split
    std::vector<std::uint8_t> goes_right;  // partition_tree: each pixel's test outcome at the node
    std::vector<detail::ChunkEntry> chunks, chunks_spare;  // partition_chunks' runs, and a split's left side
    std::vector<std::int32_t> chunk_cell;                   // each chunk's first cell in the tables
    struct Run {
      std::uint32_t node;
      std::uint32_t b, e;
    };
    std::vector<Run> runs;              // partition_tree's stack of nodes still to split
    std::vector<std::uint8_t> labels;  // the set's labels and distributions, in set order
    std::vector<float> dists;
  };
  /// Reorders the set's n pixels (stably) so that those whose windows all stay inside the image come
  /// first; s.index keeps where each came from. Returns how many are inside.
  std::size_t order_inside_first(Scratch& s, std::size_t n) const;
  // Whole frames: tiles of pixels per task, whole rows wide (a set of many pixels spreads each node's
  // fixed cost over more of them), in an even number of bands of equal height, at most
  // kTileHeightMax rows (bench_eval on the CamVid-size forest: 45-row bands ~10 % faster than 24-row
  // ones; an even count keeps two threads equally busy: 8 bands on a 360-row frame, 6 on 240 rows).
  static constexpr int kTileWidth = 512, kTileHeightMax = 45;
  /// A tile of the frame: columns [x0, x0 + width), rows [y0, y0 + height); its pixels in raster order.
  struct Tile {
    int x0, y0, width, height;
  };
  /// The tables an "inside" pixel reads without clipping: one pointer per attribute to the cell of
  /// pixel (0, 0), and the row stride (the frame's own tables, or PaddedTables).
  struct Tables {
    const double* const* at;
    std::ptrdiff_t stride;
  };
  /// A frame's summed-area tables copied with margins as wide as the forest's windows reach, which
  /// repeat the border cells: a corner outside the image reads the cell window_sum's clamping reads,
  /// so every pixel of the frame is "inside" (no clipping, the same sums bit for bit). The copy is
  /// in memory the kernel may back with 2 MB pages (a window's corners lie up to a hundred rows
  /// apart: fewer pages to look up). Kept per thread, frame to frame.
  class PaddedTables {
   public:
    PaddedTables() = default;
    PaddedTables(const PaddedTables&) = delete;
    PaddedTables& operator=(const PaddedTables&) = delete;
    ~PaddedTables();
    /// Fills the copy of `frame`'s tables for a classifier whose windows reach pad_x columns and
    /// pad_y rows beyond the pixel.
    Tables fill(const FrameData& frame, int pad_x, int pad_y);

   private:
    void reserve(std::size_t values);
    double* data_ = nullptr;
    std::size_t bytes_ = 0;
    std::vector<const double*> at_;
  };
  /// classify_frame's work: the frame cut into tiles (TBB over tiles), each a set whose pixels all
  /// read `tables` without clipping (and whose rows' last chunks may read kChunkPixels cells beyond).
  void classify_tiles(const FrameData& frame, const Tables& tables, std::span<std::uint8_t> labels,
                      std::span<float> dists) const;
  /// Evaluation of a set of pixels (s.xs, s.ys, n of them, the first `inside` of which keep every
  /// window of the forest inside `tables`; see forest_tiles.cpp): each tree routes the set through its
  /// compact nodes, the inside ones without clipping: a tile (whole frames, where each node gets many
  /// neighbouring pixels; `tile` gives its place, every pixel inside) node by node (partition_tree,
  /// or partition_chunks with a SIMD target), a list of pixels (classify_pixels' few scattered pixels:
  /// tile null) with several pixels in flight, each to its leaf (route_tree, tree by tree; or, for
  /// forests without texton tests, the target's walk: every tree's pixels in one walk, each lane taking
  /// the next (pixel, tree) as soon as its own reaches a leaf). The leaf distributions are then summed tree by tree (the same
  /// float sums as posterior()) and give the labels. Out: s.labels[i], s.dists[i * C + c] (if
  /// with_dists).
  void classify_set(const FrameData& frame, const Tables& tables, Scratch& s, std::size_t n, std::size_t inside,
                    bool with_dists, const Tile* tile) const;
  /// Routes pixels [b, e) of the set through the tree at `root`, kLanes at a time: leaf[i] for each.
  template <bool kClamp, bool kTextons>
  void route_tree(const FrameData& frame, const Tables& tables, const Scratch& s, std::size_t b, std::size_t e,
                  std::uint32_t root, std::int32_t* leaf) const;
  /// Routes the tile's pixels through the tree at `root`, node by node, in chunk entries (up to
  /// kChunkPixels row neighbours each, split by the target's split_chunks): leaf[i] for each. Every
  /// window of every pixel must lie inside `tables`, and kChunkPixels cells beyond each row's end too.
  void partition_chunks(const FrameData& frame, const Tables& tables, const Tile& tile, Scratch& s, std::uint32_t root,
                        std::int32_t* leaf) const;
  /// partition_chunks' split at a texton test, pixel by pixel: run [b, e) of s.chunks, as
  /// SimdKernels::split_chunks splits it (the right-hand run first). Returns where the left-hand run
  /// begins; *end: where it ends.
  std::uint32_t split_chunks_texton(const FrameData& frame, const Tile& tile, const CompactNode& c, Scratch& s,
                                    std::uint32_t b, std::uint32_t e, std::uint32_t* end) const;
  /// Routes the set's n pixels through the tree at `root`, node by node: leaf[i] for each. Every
  /// window of every pixel must lie inside `tables` (no clipping).
  void partition_tree(const FrameData& frame, const Tables& tables, Scratch& s, std::size_t n, std::uint32_t root,
                      std::int32_t* leaf) const;
  /// One split of partition_tree without SIMD: run [b, e) of s.routed by node c's test (a window of
  /// `table` at the corners w, or a texton test when `texton`). Returns the first right-hand pixel.
  std::uint32_t split_scalar(const FrameData& frame, const double* table, const detail::WindowCorners& w,
                             const CompactNode& c, bool texton, Scratch& s, std::uint32_t b, std::uint32_t e) const;
  /// Whether pixel (x, y) keeps every window of the forest inside the image.
  bool inside(int x, int y) const { return x >= inner_x0_ && x <= inner_x1_ && y >= inner_y0_ && y <= inner_y1_; }
  void build_compact(const Forest& forest);

  int width_ = 0, height_ = 0, num_classes_ = 0, num_features_ = 0;
  bool textons_ = false;
  const detail::SimdKernels* simd_ = nullptr;  // the target's kernels (forest_simd.hpp); null: scalar
  std::vector<std::int32_t> roots_;
  std::vector<PackedNode> nodes_;  // the trees as in the file (posterior(): the reference path)
  int inner_x0_ = 0, inner_x1_ = -1;  // columns where every window of the forest stays inside the image
  int inner_y0_ = 0, inner_y1_ = -1;  // rows likewise
  std::vector<std::uint32_t> compact_roots_;
  std::vector<CompactNode> compact_;  // the trees breadth first, one after the other
  int padded_classes_ = 0;         // num_classes_ rounded up to a multiple of 16 (zeros after)
  std::vector<float> leaf_probs_;  // leaf row r: leaf_probs_[r * padded_classes_ + c]
};

}  // namespace smseg::forest
