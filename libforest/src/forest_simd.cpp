// The classifier's and the grower's vector kernels (forest_simd.hpp), once for every Highway target: Highway's
// foreach_target compiles this file again per target (AVX2 and AVX-512 on x86-64), and
// simd_kernels picks among them at run time. The dispatch is ours, not HWY_DYNAMIC_DISPATCH: that one
// asks libhwy which targets the processor runs, and smseg's static library would then make every
// program that links it link libhwy too. The SSSE3 and SSE4 targets are left out (two doubles to a
// vector: the scalar loops do as well), and so are Highway's scalar targets (the reference loops are
// the scalar path).
#define HWY_DISABLED_TARGETS (HWY_SSSE3 | HWY_SSE4)

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cctype>
#include <cstring>
#include <stdexcept>
#include <vector>
#include <string>

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "forest_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/cache_control.h>
#include <hwy/highway.h>

#include "forest_simd.hpp"
#include "smseg/common/error.hpp"

HWY_BEFORE_NAMESPACE();
namespace smseg::forest::detail {
namespace HWY_NAMESPACE {
#if HWY_TARGET != HWY_SCALAR && HWY_TARGET != HWY_EMU128
namespace hn = hwy::HWY_NAMESPACE;

// The bits of a mask of `d`'s lanes, lane 0 lowest.
template <class D, class M>
HWY_INLINE std::uint32_t mask_bits(D d, M m) {
  std::uint8_t bytes[8] = {};
  hn::StoreMaskBits(d, m, bytes);
  std::uint32_t bits;
  std::memcpy(&bits, bytes, sizeof bits);
  return bits;
}

// The pixels of a chunk that go right: !(value < bound), the value summed in window_sum's order (the
// same as !(float(value) < threshold): float_bound). Each lane reads its own cell: the chunk's pixels
// are row neighbours, so one load per corner and vector. (Rounding to float and comparing floats, as
// the scalar loop does, costs two conversions a vector: bench_eval CamVid per pixel on one thread of a
// loaded Xeon VM, AVX2 36-38 ms against 33-36; AVX-512 the same within the noise.)
HWY_INLINE std::uint32_t chunk_goes_right(const double* ta, const double* tb, const double* ba, const double* bb,
                                          std::ptrdiff_t cell, double bound) {
  const hn::CappedTag<double, kChunkPixels> d;
  const auto t = hn::Set(d, bound);
  const std::size_t N = hn::Lanes(d);
  std::uint32_t bits = 0;
  for (std::size_t j = 0; j < static_cast<std::size_t>(kChunkPixels); j += N) {
    const auto v = hn::Sub(hn::Sub(hn::LoadU(d, bb + cell + j), hn::LoadU(d, tb + cell + j)),
                           hn::Sub(hn::LoadU(d, ba + cell + j), hn::LoadU(d, ta + cell + j)));
    bits |= mask_bits(d, hn::Not(hn::Lt(v, t))) << j;
  }
  return bits;
}

std::uint32_t SplitChunks(ChunkEntry* a, ChunkEntry* spare, std::uint32_t b, std::uint32_t e,
                          const std::int32_t* chunk_cell, const double* table, const WindowCorners& corners,
                          double bound, std::uint32_t* end) {
  const double* ta = table + corners.top_a;
  const double* tb = table + corners.top_b;
  const double* ba = table + corners.bot_a;
  const double* bb = table + corners.bot_b;
  for (std::uint32_t i = b; i < e; ++i)
    spare[i - b].bits = static_cast<std::uint16_t>(chunk_goes_right(ta, tb, ba, bb, chunk_cell[a[i].chunk], bound));
  return split_entries(a, spare, b, e, end);
}

void LeafRows(const ChunkEntry* a, std::uint32_t b, std::uint32_t e, std::int32_t row, int per_row, int width,
              std::int32_t* leaf) {
  const hn::CappedTag<std::int32_t, kChunkPixels> d;
  const std::size_t N = hn::Lanes(d);
  const auto v = hn::Set(d, row);
  for (std::uint32_t i = b; i < e; ++i) {
    std::int32_t* first = leaf + a[i].chunk / per_row * width + a[i].chunk % per_row * kChunkPixels;
    for (std::size_t j = 0; j < static_cast<std::size_t>(kChunkPixels); j += N) {
      const std::uint32_t part = static_cast<std::uint32_t>(a[i].bits) >> j;
      std::uint8_t bytes[8] = {};
      std::memcpy(bytes, &part, sizeof part);
      hn::BlendedStore(v, hn::LoadMaskBits(d, bytes), d, first + j);
    }
  }
}

// The walk's lanes (Walk): per vector of lanes in flight, each lane's item (tree-major: item k is
// pixel k % n in tree k / n, and its leaf goes to leaf[k]), node and coordinates, all in 32-bit
// lanes; kept in memory between steps (whole vectors only: a narrow store read back by a wide load
// would stall).
struct WalkLanes {
  static constexpr std::size_t kMax = 4 * HWY_LANES(std::int32_t);
  alignas(64) std::int32_t item[kMax], node[kMax], x[kMax], y[kMax];
};

// What walk_step reads: the nodes, the tables and the items.
struct WalkFrame {
  const std::int64_t* words;     // node i: words 2i (rectangle), 2i + 1 (threshold, next)
  const double* first;           // the first table; the others at offsets[attribute] doubles from it
  const std::int32_t* offsets;   // padded to a whole vector
  const std::int32_t* xy;        // the set's pixels, x | y << 16, then its first lanes again
  const std::int32_t* roots;     // per tree, then roots[0] again for the items past the last
  std::int32_t* leaf;            // per item (and a spare slot at `items` for lanes that write nothing)
  std::int32_t width, height, stride, n, items;
  bool few_tables;               // at most one vector's lanes of tables: offsets by a permutation
};

// window_sum's clipping of coordinates to [0, hi].
template <class V>
HWY_INLINE V clip(V v, V hi) {
  return hn::Min(hn::Max(v, hn::Zero(hn::DFromV<V>())), hi);
}

// Lane l's rank among the set lanes of an 8-bit mask: how many set lanes are below it.
struct LaneRanks {
  alignas(32) std::int32_t rank[256][8];
  LaneRanks() {
    for (int m = 0; m < 256; ++m)
      for (int l = 0; l < 8; ++l) rank[m][l] = std::popcount(static_cast<unsigned>(m) & ((1u << l) - 1u));
  }
};
const LaneRanks kRanks;

// Each lane's rank among the lanes of `bits` (lane 0 lowest).
template <class D>
HWY_INLINE hn::Vec<D> lane_ranks(D d, std::uint32_t bits) {
  if constexpr (hn::MaxLanes(d) <= 8) {
    return hn::LoadU(d, kRanks.rank[bits & 0xff]);
  } else if constexpr (hn::MaxLanes(d) == 16) {
    const hn::Half<D> dh;
    const auto low = hn::LoadU(dh, kRanks.rank[bits & 0xff]);
    const auto high = hn::Add(hn::LoadU(dh, kRanks.rank[(bits >> 8) & 0xff]), hn::Set(dh, std::popcount(bits & 0xffu)));
    return hn::Combine(d, high, low);
  } else {
    alignas(64) std::int32_t r[hn::MaxLanes(d)];
    for (std::size_t l = 0; l < hn::Lanes(d); ++l) r[l] = std::popcount(bits & ((1u << l) - 1u));
    return hn::Load(d, r);
  }
}

// The four doubles of a window's corners for the lanes of `cell` (32-bit table indices), gathered by
// halves with 64-bit indices (Highway has no gather of doubles by 32-bit indices).
template <class D>
struct CornerGather {
  hn::Repartition<std::int64_t, D> d64;
  hn::Repartition<double, D> dd;
  hn::Half<D> dh;
  const double* first;
  HWY_INLINE hn::Vec<decltype(dd)> lower(hn::Vec<D> cell) const {
    return hn::GatherIndex(dd, first, hn::PromoteTo(d64, hn::LowerHalf(dh, cell)));
  }
  HWY_INLINE hn::Vec<decltype(dd)> upper(hn::Vec<D> cell) const {
    return hn::GatherIndex(dd, first, hn::PromoteTo(d64, hn::UpperHalf(dh, cell)));
  }
};

// The node's test for every lane of a vector: whether each goes right (float(value) >= threshold or
// NaN, as the scalar walk), from the node's rectangle words and threshold, the lane's coordinates.
template <class D>
HWY_INLINE hn::Mask<D> goes_right(D d, const WalkFrame& f, hn::Vec<D> x, hn::Vec<D> y, hn::Vec<D> rect_x,
                                  hn::Vec<D> rect_y, hn::Vec<D> link, hn::Vec<D> threshold_bits) {
  const hn::Repartition<float, D> df;
  const hn::Rebind<float, hn::Repartition<double, D>> dfh;
  // The rectangle's int16 fields, sign-extended: x0 | x1 << 16, y0 | y1 << 16.
  const auto W = hn::Set(d, f.width), H = hn::Set(d, f.height);
  const auto xa = clip(hn::Add(x, hn::ShiftRight<16>(hn::ShiftLeft<16>(rect_x))), W);
  const auto xb = clip(hn::Add(x, hn::ShiftRight<16>(rect_x)), W);
  const auto ya = clip(hn::Add(y, hn::ShiftRight<16>(hn::ShiftLeft<16>(rect_y))), H);
  const auto yb = clip(hn::Add(y, hn::ShiftRight<16>(rect_y)), H);
  const auto attr = hn::And(link, hn::Set(d, 0xff));
  const auto base = f.few_tables ? hn::TableLookupLanes(hn::LoadU(d, f.offsets), hn::IndicesFromVec(d, attr))
                                 : hn::GatherIndex(d, f.offsets, attr);
  const auto S = hn::Set(d, f.stride);
  const auto top = hn::Add(base, hn::Mul(ya, S)), bot = hn::Add(base, hn::Mul(yb, S));
  const auto ta = hn::Add(top, xa), tb = hn::Add(top, xb), ba = hn::Add(bot, xa), bb = hn::Add(bot, xb);
  const CornerGather<D> g{{}, {}, {}, f.first};
  // window_sum's order in each half.
  const auto low = hn::Sub(hn::Sub(g.lower(bb), g.lower(tb)), hn::Sub(g.lower(ba), g.lower(ta)));
  const auto high = hn::Sub(hn::Sub(g.upper(bb), g.upper(tb)), hn::Sub(g.upper(ba), g.upper(ta)));
  const auto value = hn::Combine(df, hn::DemoteTo(dfh, high), hn::DemoteTo(dfh, low));
  return hn::RebindMask(d, hn::Not(hn::Lt(value, hn::BitCast(df, threshold_bits))));
}

// One step of the lanes [g, g + N) of the state: each lane at a split takes its child; each lane at a
// leaf writes the leaf's row for its item (when it has one) and takes the next item (next + its rank
// among the leaf lanes: the next items, in lane order) from its tree's root. Returns the lanes at a
// leaf; *written: how many of them wrote a leaf.
HWY_INLINE std::uint32_t walk_step(const WalkFrame& f, WalkLanes& s, std::size_t g, std::int32_t next,
                                   std::size_t* written) {
  const hn::ScalableTag<std::int32_t> d;
  const hn::RebindToUnsigned<decltype(d)> du;
  const hn::Repartition<std::int64_t, decltype(d)> d64;
  const hn::Half<decltype(d)> dh;
  const auto node = hn::Load(d, s.node + g), x = hn::Load(d, s.x + g), y = hn::Load(d, s.y + g);
  // The nodes' two words, gathered by halves, then split into 32-bit lanes: even halves of the words
  // (rectangle x0 | x1, threshold), odd halves (y0 | y1, next).
  const auto index_low = hn::ShiftLeft<1>(hn::PromoteTo(d64, hn::LowerHalf(dh, node)));
  const auto index_high = hn::ShiftLeft<1>(hn::PromoteTo(d64, hn::UpperHalf(dh, node)));
  const auto rect_low = hn::BitCast(d, hn::GatherIndex(d64, f.words, index_low));
  const auto rect_high = hn::BitCast(d, hn::GatherIndex(d64, f.words, index_high));
  const auto tail_low = hn::BitCast(d, hn::GatherIndex(d64, f.words + 1, index_low));
  const auto tail_high = hn::BitCast(d, hn::GatherIndex(d64, f.words + 1, index_high));
  const auto link = hn::ConcatOdd(d, tail_high, tail_low);
  const auto right = goes_right(d, f, x, y, hn::ConcatEven(d, rect_high, rect_low), hn::ConcatOdd(d, rect_high, rect_low),
                                link, hn::ConcatEven(d, tail_high, tail_low));
  const auto child = hn::BitCast(d, hn::ShiftRight<9>(hn::BitCast(du, link)));
  const auto stepped = hn::Sub(child, hn::VecFromMask(d, right));  // the right child follows the left
  const auto at_leaf = hn::TestBit(link, hn::Set(d, 1 << 8));
  if (hn::AllFalse(d, at_leaf)) {
    hn::Store(stepped, d, s.node + g);
    *written = 0;
    return 0;
  }
  const auto item = hn::Load(d, s.item + g), items = hn::Set(d, f.items);
  const auto writes = hn::And(at_leaf, hn::Lt(item, items));
  hn::ScatterIndex(child, d, f.leaf, hn::IfThenElse(writes, item, items));
  const std::uint32_t leaves = mask_bits(d, at_leaf);
  // The next items [next, next + leaves) lie in the set's pixels from `from` on (wrapping once into
  // the next tree: a vector holds at most n lanes), in a row of f.xy.
  const std::int32_t tree = next < f.items ? next / f.n : 0, from = next - tree * f.n < f.n ? next - tree * f.n : 0;
  const auto rank = lane_ranks(d, leaves);
  const auto taken = hn::Add(hn::Set(d, next), rank);
  const auto xy = hn::TableLookupLanes(hn::LoadU(d, f.xy + from), hn::IndicesFromVec(d, rank));
  const auto wraps = hn::Not(hn::Lt(hn::Add(hn::Set(d, from), rank), hn::Set(d, f.n)));
  const auto root = hn::IfThenElse(wraps, hn::Set(d, f.roots[tree + 1]), hn::Set(d, f.roots[tree]));
  // Lanes past the last item read cell (0, 0) of the tables, which stays in the cache.
  const auto live = hn::And(at_leaf, hn::Lt(taken, items));
  hn::Store(hn::IfThenElse(at_leaf, root, stepped), d, s.node + g);
  hn::Store(hn::IfThenElse(at_leaf, taken, item), d, s.item + g);
  hn::Store(hn::IfThenElse(live, hn::And(xy, hn::Set(d, 0xffff)), hn::IfThenElse(at_leaf, hn::Set(d, -32768), x)), d, s.x + g);
  hn::Store(hn::IfThenElse(live, hn::ShiftRight<16>(xy), hn::IfThenElse(at_leaf, hn::Set(d, -32768), y)), d, s.y + g);
  *written = hn::CountTrue(d, writes);
  return leaves;
}

bool Walk(const void* nodes, const std::uint32_t* roots, std::size_t M, const double* const* sats, std::size_t num_sats,
          int width, int height, const std::int32_t* xs, const std::int32_t* ys, std::size_t n, std::int32_t* leaf) {
  const hn::ScalableTag<std::int32_t> d;
  const std::size_t N = hn::Lanes(d);
  // Every table index in 32 bits: the tables' places relative to the first, plus a cell.
  const std::int64_t cells = static_cast<std::int64_t>(width + 1) * (height + 1);
  std::vector<std::int32_t> offsets(std::max(num_sats, N), 0);
  for (std::size_t a = 0; a < num_sats; ++a) {
    const std::ptrdiff_t bytes = reinterpret_cast<const char*>(sats[a]) - reinterpret_cast<const char*>(sats[0]);
    if (bytes % static_cast<std::ptrdiff_t>(sizeof(double)) != 0) return false;
    const std::int64_t at = bytes / static_cast<std::ptrdiff_t>(sizeof(double));
    if (at < -(std::int64_t(1) << 31) + cells || at > (std::int64_t(1) << 31) - 1 - cells) return false;
    offsets[a] = static_cast<std::int32_t>(at);
  }
  const std::size_t total = n * M;
  if (n < N || N > 16 || total > (std::size_t(1) << 30) || num_sats > 256) return false;
  std::vector<std::int32_t> xy(n + N), tree_roots(M + 1);
  for (std::size_t i = 0; i < n + N; ++i) xy[i] = xs[i % n] | ys[i % n] << 16;
  for (std::size_t t = 0; t <= M; ++t) tree_roots[t] = static_cast<std::int32_t>(roots[t < M ? t : 0]);
  const WalkFrame f{static_cast<const std::int64_t*>(nodes), sats[0], offsets.data(), xy.data(), tree_roots.data(), leaf,
                    width, height, width + 1, static_cast<std::int32_t>(n), static_cast<std::int32_t>(total), num_sats <= N};
  // 32 lanes in flight: each vector's step waits for its nodes, then for its table cells (two gathers
  // in a row), and the other vectors' steps fill the wait. (bench_eval, CamVid grid, one thread, Xeon
  // VM: AVX-512 one vector of 16 lanes 3.1 ms, two 2.5, three 2.5; AVX2 three, four or six vectors of
  // 8 lanes the same within 1 %.)
  const std::size_t vectors = std::clamp<std::size_t>(32 / N, 1, std::min(WalkLanes::kMax, total) / N);
  WalkLanes s;
  for (std::size_t l = 0; l < vectors * N; ++l) {
    s.item[l] = static_cast<std::int32_t>(l);
    const bool live = l < total;
    s.node[l] = static_cast<std::int32_t>(roots[live ? l / n : 0]);
    s.x[l] = live ? xs[l % n] : -32768;
    s.y[l] = live ? ys[l % n] : -32768;
  }
  auto next = static_cast<std::int32_t>(vectors * N);
  // One step's code for every vector: unrolled, the two 16-lane steps of AVX-512 interleaved and ran
  // out of registers (bench_eval CamVid grid, one thread: 2.1 ms against 1.8).
  for (std::size_t done = 0; done < total;)
#pragma GCC unroll 1
    for (std::size_t v = 0; v < vectors; ++v) {
      std::size_t written = 0;
      next += static_cast<std::int32_t>(std::popcount(walk_step(f, s, v * N, next, &written)));
      done += written;
    }
  return true;
}

// The first class of the largest sum (the scalar loop's choice: the sums are finite and not negative):
// the largest of the classes' lanes, then the first lane equal to it.
HWY_INLINE std::size_t first_of_largest(const float* sums, std::size_t padded, std::size_t classes) {
  const hn::CappedTag<float, 16> d;
  const std::size_t N = hn::Lanes(d);
  auto largest = hn::Set(d, -1.0f);
  for (std::size_t j = 0; j < padded; j += N)
    largest = hn::Max(largest, hn::IfThenElse(hn::FirstN(d, classes > j ? classes - j : 0), hn::LoadU(d, sums + j),
                                              hn::Set(d, -1.0f)));
  largest = hn::MaxOfLanes(d, largest);
  for (std::size_t j = 0; j < padded; j += N) {
    const auto equal = hn::And(hn::Eq(hn::LoadU(d, sums + j), largest), hn::FirstN(d, classes > j ? classes - j : 0));
    const std::intptr_t at = hn::FindFirstTrue(d, equal);
    if (at >= 0) return j + static_cast<std::size_t>(at);
  }
  return 0;
}

void SumVotes(const float* probs, std::size_t padded, std::size_t classes, const std::int32_t* leaf, std::size_t n,
              std::size_t M, std::uint8_t* labels, float* dists) {
  const hn::CappedTag<float, 16> d;
  const std::size_t N = hn::Lanes(d);
  alignas(64) float sums[16];
  for (std::size_t i = 0; i < n; ++i) {
    // 0.0f + the first tree's row, then += each later tree's row: the scalar loop's order in every lane.
    for (std::size_t j = 0; j < padded; j += N) {
      auto acc = hn::LoadU(d, probs + static_cast<std::size_t>(leaf[i]) * padded + j);
      for (std::size_t t = 1; t < M; ++t)
        acc = hn::Add(acc, hn::LoadU(d, probs + static_cast<std::size_t>(leaf[t * n + i]) * padded + j));
      hn::StoreU(acc, d, sums + j);
    }
    labels[i] = static_cast<std::uint8_t>(first_of_largest(sums, padded, classes));
    if (dists) std::copy(sums, sums + classes, dists + i * classes);
  }
}

// The grower's node scan (SimdKernels::row_range, count_below). Rows lie anywhere in the value matrix
// (a node's tests are scattered over it): the block's part of the row kRowsAhead tests on is asked for
// while this one is read, as the grower's own loops do.
constexpr std::size_t kRowsAhead = 4;
HWY_INLINE void prefetch_block(const float* r, std::size_t B) {
  for (std::size_t j = 0; j < B; j += 64 / sizeof(float)) hwy::Prefetch(r + j);
}

void RowRange(const float* rows, std::size_t nc, const std::uint32_t* ord, std::size_t m, std::size_t j0,
              std::size_t B, float* lo, float* hi) {
  const hn::ScalableTag<float> d;
  const std::size_t N = hn::Lanes(d), BN = B - B % N;
  const float* first = rows + std::size_t{ord[0]} * nc + j0;
  std::copy(first, first + B, lo);
  std::copy(first, first + B, hi);
  for (std::size_t i = 1; i < m; ++i) {
    const float* r = rows + std::size_t{ord[i]} * nc + j0;
    if (i + kRowsAhead < m) prefetch_block(rows + std::size_t{ord[i + kRowsAhead]} * nc + j0, B);
    for (std::size_t j = 0; j < BN; j += N) {
      // IfThenElse, not Min / Max: the grower's `v < lo ? v : lo` whatever a NaN does to Min.
      const auto v = hn::LoadU(d, r + j), l = hn::LoadU(d, lo + j), h = hn::LoadU(d, hi + j);
      hn::StoreU(hn::IfThenElse(hn::Lt(v, l), v, l), d, lo + j);
      hn::StoreU(hn::IfThenElse(hn::Gt(v, h), v, h), d, hi + j);
    }
    for (std::size_t j = BN; j < B; ++j) {
      lo[j] = r[j] < lo[j] ? r[j] : lo[j];
      hi[j] = r[j] > hi[j] ? r[j] : hi[j];
    }
  }
}

void CountBelow(const float* rows, std::size_t nc, const std::uint32_t* ord, std::size_t i0, std::size_t i1,
                std::size_t m, std::size_t j0, std::size_t B, const float* tf, std::int32_t* cnt) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const std::size_t N = hn::Lanes(d), BN = B - B % N;
  for (std::size_t i = i0; i < i1; ++i) {
    const float* r = rows + std::size_t{ord[i]} * nc + j0;
    if (i + kRowsAhead < m) prefetch_block(rows + std::size_t{ord[i + kRowsAhead]} * nc + j0, B);
    for (std::size_t j = 0; j < BN; j += N) {
      const auto below = hn::RebindMask(di, hn::Lt(hn::LoadU(d, r + j), hn::LoadU(d, tf + j)));
      hn::StoreU(hn::Sub(hn::LoadU(di, cnt + j), hn::VecFromMask(di, below)), di, cnt + j);  // true is -1
    }
    for (std::size_t j = BN; j < B; ++j) cnt[j] += r[j] < tf[j] ? 1 : 0;
  }
}

// The target's name for SMSEG_SIMD: Highway's, in lower case ("avx2", "neon"), but "avx512" for AVX3.
std::string target_name() {
  if (HWY_TARGET == HWY_AVX3) return "avx512";
  std::string s = hwy::TargetName(HWY_TARGET);
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

const SimdKernels* Kernels() {
  static const std::string name = target_name();
  static const SimdKernels kernels{name.c_str(), &SplitChunks, &LeafRows, &Walk, &SumVotes, &RowRange, &CountBelow};
  return &kernels;
}

#endif  // HWY_TARGET != HWY_SCALAR && HWY_TARGET != HWY_EMU128
}  // namespace HWY_NAMESPACE
}  // namespace smseg::forest::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace smseg::forest::detail {

namespace {

// A compiled target: whether this processor runs it, and its kernels.
struct Compiled {
  bool (*runs)();
  const SimdKernels* (*kernels)();
};

#if HWY_ARCH_X86
// F16C from CPUID (leaf 1, ECX bit 29): clang 14's __builtin_cpu_supports does not know "f16c".
bool has_f16c() {
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  return __get_cpuid(1, &eax, &ebx, &ecx, &edx) != 0 && ((ecx >> 29) & 1u) != 0;
}
bool runs_avx2() {
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi") &&
         __builtin_cpu_supports("bmi2") && has_f16c() && __builtin_cpu_supports("sse4.2") &&
         __builtin_cpu_supports("pclmul") && __builtin_cpu_supports("aes");
}
bool runs_avx512() {
  return runs_avx2() && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
         __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw");
}
#endif
[[maybe_unused]] bool runs_baseline() { return true; }  // the target the compiler builds for anyway

// Narrowest vectors first.
const std::vector<Compiled>& compiled() {
  static const std::vector<Compiled> targets = [] {
    std::vector<Compiled> t;
#if HWY_ARCH_X86 && (HWY_TARGETS & HWY_AVX2)
    t.push_back({&runs_avx2, &N_AVX2::Kernels});
#endif
#if HWY_ARCH_X86 && (HWY_TARGETS & HWY_AVX3)
    t.push_back({&runs_avx512, &N_AVX3::Kernels});
#endif
#if !HWY_ARCH_X86 && HWY_STATIC_TARGET != HWY_SCALAR && HWY_STATIC_TARGET != HWY_EMU128
    // Elsewhere (NEON on 64-bit Arm) the baseline target only: the one every such processor runs.
    t.push_back({&runs_baseline, &HWY_STATIC_DISPATCH(Kernels)});
#endif
    return t;
  }();
  return targets;
}

std::string accepted_names() {
  std::string names = "scalar";
  for (const Compiled& c : compiled()) names += std::string("|") + c.kernels()->name;
  return names;
}

}  // namespace

const SimdKernels* simd_kernels(std::string_view name, const std::string& what) {
  if (name == "scalar") return nullptr;
  for (const Compiled& c : compiled()) {
    if (name != c.kernels()->name) continue;
    if (c.runs()) return c.kernels();
    std::string runs;
    for (const std::string& s : simd_target_names()) runs += (runs.empty() ? "" : ", ") + s;
    throw Error("", what, "'" + std::string(name) + "': this processor lacks it (it runs " + runs + ")");
  }
  throw Error("", what, "unknown SIMD target '" + std::string(name) + "' (expected " + accepted_names() + ")");
}

const SimdKernels* default_simd_kernels() {
  if (const char* forced = std::getenv("SMSEG_SIMD"); forced && *forced) return simd_kernels(forced, "SMSEG_SIMD");
  const SimdKernels* best = nullptr;
  for (const Compiled& c : compiled())
    if (c.runs()) best = c.kernels();
  return best;
}

std::vector<std::string> simd_target_names() {
  std::vector<std::string> names{"scalar"};
  for (const Compiled& c : compiled())
    if (c.runs()) names.emplace_back(c.kernels()->name);
  return names;
}

}  // namespace smseg::forest::detail
#endif  // HWY_ONCE
