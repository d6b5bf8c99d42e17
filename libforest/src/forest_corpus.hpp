#pragma once
// Training corpora in bounded memory (internal to libforest; see train.hpp for what a corpus is).
//
// A corpus is drawn first (windows, offsets, tests: the tree's random numbers, in the order
// train.hpp gives), then its values are filled by streaming the frames one at a time: every test of
// every tree being built that lies in the frame is evaluated, then the frame is released
// (FrameData::release) so that memory-mapped tables do not pile up in memory. The values go straight
// into the grower's test-major layout (rows[t * candidates + c]), one matrix per tree and no copy.

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "smseg/forest/data.hpp"
#include "smseg/forest/forest.hpp"
#include "smseg/forest/params.hpp"
#include "smseg/forest/train.hpp"

namespace smseg::forest::detail {

/// Draws tests as train.hpp says. Per frame it keeps only cumulative per-row counts of each class
/// (and of all non-void pixels), not a list of pixels: a draw finds the row by binary search, then
/// scans that row of the label image. The k-th pixel of a class in raster order is what a list
/// grouped by class (each class in raster order) gives, so the draws are the same as with such lists.
class TestSampler {
 public:
  explicit TestSampler(const Dataset& data);
  TestPoint draw(Rng& rng, Balance balance) const;
  /// Bytes this sampler holds (for the memory estimate).
  static std::size_t bytes(const Dataset& data);

 private:
  /// Row cumulative counts of frame fi: rows_[fi][k * (H + 1) + y], k < C: class k; k = C: non-void.
  const std::uint32_t* cum(std::size_t fi, std::size_t k) const;
  /// The pixel index of the `rank`-th pixel (0-based, raster order) of class k in frame fi.
  std::uint32_t select(std::size_t fi, std::size_t k, std::uint64_t rank) const;

  const Dataset& data_;
  std::size_t C_, H_;
  std::vector<std::vector<std::uint32_t>> rows_;
  std::vector<std::vector<std::uint64_t>> class_cum_;  // [class][frame] cumulative pixel counts
  std::vector<int> nonempty_, present_;
  std::vector<std::uint64_t> sqrt_cum_;  // per present class: cumulative integer weights ~ sqrt(pixels)
};

/// A tree's corpus without its values: candidates, and tests sorted by class, frame, row, column.
Corpus draw_corpus(const Dataset& data, const TrainParams& params, const TestSampler& sampler, int tree);

/// Fills rows[i] (tests x candidates floats, test-major) for corpora[i], reading each frame once and
/// releasing it after. Parallel over frames.
void fill_rows(const Dataset& data, std::span<const Corpus* const> corpora, std::span<float* const> rows);

/// Attribute `attribute`'s value at pixel (x, y) of a frame: the window's sum of a table for a window
/// feature, a texton test on the greyscale after them. The values the grower splits, bit for bit.
inline float attribute_value(const FrameData& frame, int attribute, const Window& win, int x, int y) {
  const int F = static_cast<int>(frame.sats.size());
  return attribute < F ? static_cast<float>(window_sum(frame.sats[static_cast<std::size_t>(attribute)], frame.width,
                                                       frame.height, x, y, rel_rect(win)))
                       : texton_value(frame.gray, frame.width, frame.height, x, y, win.dx, win.dy, attribute - F);
}

/// Adds params.leaf_tests more tests to the leaf counts of each of `trees` (trees first_tree, first_tree
/// + 1, ... of the forest), drawn as the growing tests are (TrainParams::balance) from a stream of each
/// tree's own; every frame read once and released. Nothing when leaf_tests is 0.
void count_leaf_tests(const Dataset& data, const TrainParams& params, const TestSampler& sampler,
                      std::span<Tree> trees, int first_tree);

/// Memory of training, for TrainParams::memory_mb.
struct MemoryPlan {
  std::size_t fixed_bytes = 0;     ///< the process, sampler, frames being read
  std::size_t per_tree_bytes = 0;  ///< one tree's value matrix, tests and grower
  std::size_t trees_at_once = 0;   ///< how many trees fit next to the fixed part (0: not even one)
};
MemoryPlan plan_memory(const Dataset& data, const TrainParams& params);

}  // namespace smseg::forest::detail
