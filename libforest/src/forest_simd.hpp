#pragma once
// The classifier's and the grower's vector kernels (forest_simd.cpp), written once with Google Highway and compiled for
// each target Highway builds here (AVX2 and AVX-512 on x86-64, NEON or SVE elsewhere); the target is
// chosen at run time among those the processor runs (or forced by SMSEG_SIMD). Each gives the scalar
// loops' result bit for bit (forest_tiles.cpp): the same double window sums, rounded to float and
// compared as they do, and the same float sums of the leaf distributions. Highway is used from its
// headers only (no libhwy symbol): the static library needs nothing more at link time.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "smseg/forest/classify.hpp"

namespace smseg::forest::detail {

/// The smallest double d with float(d) >= t, for a float t that is not NaN: float(v) < t exactly when
/// v < d (rounding to the nearest float is monotonic; both are false for a NaN v), so a split may
/// compare the double sums without rounding them. d lies half-way between t and the float below it,
/// or just above that midpoint when the midpoint rounds down (ties go to the even float).
inline double float_bound(float t) {
  constexpr float inf = std::numeric_limits<float>::infinity();
  if (t == -inf) return -std::numeric_limits<double>::infinity();
  const double two128 = std::ldexp(1.0, 128);  // where the float after FLT_MAX would be
  const float below = std::nextafter(t, -inf);
  const double lo = below == -inf ? -two128 : static_cast<double>(below);
  const double hi = t == inf ? two128 : static_cast<double>(t);
  const double mid = lo / 2 + hi / 2;  // exact: two neighbouring floats
  if (t == inf) return mid;            // beyond it values round to infinity (the tie too: FLT_MAX is odd)
  if (below == -inf) return std::nextafter(mid, two128);  // the tie rounds to -infinity
  return static_cast<float>(mid) >= t ? mid : std::nextafter(mid, two128);
}

/// The partition of SimdKernels::split_chunks, once each entry's outcomes are known: run a[b, e) split
/// by spare[i - b].bits, the bits of entry i's pixels that go right; returns m, *end as split_chunks
/// does. (Two passes, the tests then this: the tests' loads wait for no store.)
inline std::uint32_t split_entries(ChunkEntry* a, ChunkEntry* spare, std::uint32_t b, std::uint32_t e, std::uint32_t* end) {
  std::uint32_t r = b, k = 0;
  for (std::uint32_t i = b; i < e; ++i) {
    const ChunkEntry c = a[i];
    const std::uint32_t to_right = spare[i - b].bits & c.bits;  // read before spare[k], k <= i - b, is written
    const std::uint32_t to_left = c.bits & ~to_right;
    // Written to both sides, kept where it has pixels: no branch on the outcome. The right side is
    // written in place (r <= i), the left to the spare room, then after it.
    a[r] = {c.chunk, static_cast<std::uint16_t>(to_right)};
    spare[k] = {c.chunk, static_cast<std::uint16_t>(to_left)};
    r += to_right != 0;
    k += to_left != 0;
  }
  for (std::uint32_t j = 0; j < k; ++j) a[r + j] = spare[j];
  *end = r + k;
  return r;
}

/// The kernels of one target.
struct SimdKernels {
  const char* name;  // "avx2", "avx512", "neon", ... (what SMSEG_SIMD names)
  /// Splits the run a[b, e) of chunk entries by one window test: each entry's pixels whose value at
  /// `table` (window corners relative to the pixel's cell, chunk_cell[chunk] + l for pixel l) is not
  /// below `bound` (float_bound of the node's threshold: the same outcome as rounding the value to
  /// float) go to the right-hand run a[b, m), the others to the left-hand run a[m, *end),
  /// each in order (an entry whose pixels go both ways is in both; one without pixels on a side is not
  /// on that side). `a` has room for 2 (e - b) entries from b, `spare` for e - b; every lane of every
  /// chunk must read inside the tables (lanes beyond a tile row read cells of the margin). Returns m.
  std::uint32_t (*split_chunks)(ChunkEntry* a, ChunkEntry* spare, std::uint32_t b, std::uint32_t e,
                                const std::int32_t* chunk_cell, const double* table, const WindowCorners& corners,
                                double bound, std::uint32_t* end);
  /// partition_chunks' leaves: row `row` to leaf[i] for every pixel i of the entries a[b, e) (a tile
  /// `width` pixels wide, per_row chunks a row; leaf has room for kChunkPixels values past the tile).
  void (*leaf_rows)(const ChunkEntry* a, std::uint32_t b, std::uint32_t e, std::int32_t row, int per_row, int width,
                    std::int32_t* leaf);
  /// classify_pixels' walk (route_tree's work for forests without texton tests): pixels (xs[i], ys[i]),
  /// i < n, through the M trees whose roots are nodes roots[t] of `nodes` (16-byte compact nodes: int16
  /// x0, x1, y0, y1; float threshold; uint32 next, as Classifier lays them out), reading the frame's
  /// tables `sats` (row stride width + 1), several vectors of (pixel, tree) items in flight; leaf[t * n + i]
  /// for each (`leaf` has room for n * M + 1 values). Every window is clipped as window_sum clips it.
  /// Returns false, having written nothing, for a set it does not take: fewer pixels than a vector has
  /// lanes, or tables too far apart in memory for 32-bit indices.
  bool (*walk)(const void* nodes, const std::uint32_t* roots, std::size_t M, const double* const* sats,
               std::size_t num_sats, int width, int height, const std::int32_t* xs, const std::int32_t* ys,
               std::size_t n, std::int32_t* leaf);
  /// classify_set's votes for forests of at most 16 classes (`padded` = 16 floats a leaf row): per
  /// pixel i < n, the rows leaf[t * n + i] of `probs` summed over the trees t < M in order, and the
  /// first class of the largest sum; labels[i], and dists[i * classes + c] unless dists is null.
  void (*sum_votes)(const float* probs, std::size_t padded, std::size_t classes, const std::int32_t* leaf,
                    std::size_t n, std::size_t M, std::uint8_t* labels, float* dists);

  // Training (forest_train.cpp, the grower's scan of a node over a block of candidates): `rows` are
  // test-major values (row t at rows + t * nc), a node's tests the rows ord[i]; the block is the B
  // candidates from j0. Each gives the grower's own loops' result bit for bit, NaN included: rows are
  // taken in order and compared as those loops compare them.

  /// lo[j] = the least and hi[j] the greatest value of candidate j0 + j over the rows ord[0, m), j < B,
  /// folded row by row as `v < lo ? v : lo` and `v > hi ? v : hi` from the first row's values.
  void (*row_range)(const float* rows, std::size_t nc, const std::uint32_t* ord, std::size_t m, std::size_t j0,
                    std::size_t B, float* lo, float* hi);
  /// cnt[j] += the number of rows ord[i], i in [i0, i1), whose value of candidate j0 + j is below tf[j],
  /// j < B. `m` bounds the rows it may ask the memory for ahead of time (ord[0, m) are readable).
  void (*count_below)(const float* rows, std::size_t nc, const std::uint32_t* ord, std::size_t i0, std::size_t i1,
                      std::size_t m, std::size_t j0, std::size_t B, const float* tf, std::int32_t* cnt);
};

/// The kernels of target `name`, null for "scalar" (the reference loops). Error naming `what` when the
/// name is unknown or the processor lacks the target.
const SimdKernels* simd_kernels(std::string_view name, const std::string& what);
/// The classifier's default: the target SMSEG_SIMD names (Error naming SMSEG_SIMD when it cannot be
/// had), else the best target this processor runs.
const SimdKernels* default_simd_kernels();
/// The targets this processor runs, "scalar" first, then from the narrowest vectors to the widest.
std::vector<std::string> simd_target_names();

}  // namespace smseg::forest::detail
