#pragma once
// The AVX-512 paths of the classifier (forest_tiles.cpp): one split of partition_tree (eight
// pixels' window tests at once, one load or one gather per corner, the same double arithmetic and
// float comparison as the scalar loop, and the stable partition by compress), route_tree's walk of
// scattered pixels, and the summed votes; each gives the scalar code's result bit for bit. Compiled
// for AVX-512 by a function attribute and called only where the processor has it
// (split_avx512_available), so the library runs on any x86-64 (and builds elsewhere without it).
#include <cstddef>
#include <cstdint>

#include "smseg/forest/classify.hpp"

namespace smseg::forest::detail {

/// Whether this processor runs split_avx512 (AVX-512 F, VL and DQ).
bool split_avx512_available();

/// Splits the run a[b, e) stably: the pixels whose value at `table` (from their cell) is below
/// `threshold` stay first, in order, the others follow, in order. `right` has room for e - b
/// pixels. Returns the first pixel of the right-hand side. The run's cells must increase strictly
/// (as partition_tree's tiles do: raster order, kept by every split): eight pixels spanning seven
/// cells are then row neighbours, read by one load per corner.
std::uint32_t split_avx512(RoutedPixel* a, RoutedPixel* right, std::uint32_t b, std::uint32_t e,
                           const double* table, const WindowCorners& corners, float threshold);

/// classify_pixels' walk with AVX-512 (route_tree's work for forests without texton tests): pixels
/// (xs[i], ys[i]), i < n, through the tree whose root is node `root` of `nodes` (16-byte compact nodes:
/// int16 x0, x1, y0, y1; float threshold; uint32 next, as Classifier lays them out), reading the
/// frame's tables `sats` (row stride width + 1; at most 16 attributes). Eight pixels a vector, two
/// vectors in flight; a lane at a leaf writes leaf[i] and takes the next pixel. Every window is
/// clipped as window_sum clips it and summed in its order, rounded to float and compared as the
/// scalar walk does: the same leaves, bit for bit.
void route_avx512(const void* nodes, std::uint32_t root, const double* const* sats, std::size_t num_sats, int width,
                  int height, const std::int32_t* xs, const std::int32_t* ys, std::size_t n, std::int32_t* leaf);

/// classify_set's votes with AVX-512, for forests of at most 16 classes: per pixel i < n, the leaf
/// distributions leaf[t * n + i] (rows of `probs`, `padded` floats each) summed over the trees t < M
/// in order, as float (the scalar loop's sums, lane by lane), and the first class of the largest sum;
/// labels[i], and dists[i * classes + c] unless dists is null.
void sum_votes_avx512(const float* probs, std::size_t padded, std::size_t classes, const std::int32_t* leaf,
                      std::size_t n, std::size_t M, std::uint8_t* labels, float* dists);

}  // namespace smseg::forest::detail
