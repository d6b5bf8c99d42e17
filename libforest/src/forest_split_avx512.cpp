// The AVX-512 split of forest_split.hpp.
#include "forest_split.hpp"

#include <algorithm>
#include <bit>
#include <cstddef>
#include <stdexcept>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define SMSEG_HAVE_AVX512_SPLIT 1
#endif

namespace smseg::forest::detail {

static_assert(sizeof(RoutedPixel) == 8 && offsetof(RoutedPixel, cell) == 0,
              "split_avx512 reads a pixel as one 64-bit lane whose low half is its cell");

#ifdef SMSEG_HAVE_AVX512_SPLIT

bool split_avx512_available() {
  static const bool available = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
                                __builtin_cpu_supports("avx512dq");
  return available;
}

__attribute__((target("avx512f,avx512vl,avx512dq"))) std::uint32_t split_avx512(
    RoutedPixel* a, RoutedPixel* right, std::uint32_t b, std::uint32_t e, const double* table,
    const WindowCorners& corners, float threshold) {
  const double* top_a = table + corners.top_a;
  const double* top_b = table + corners.top_b;
  const double* bot_a = table + corners.bot_a;
  const double* bot_b = table + corners.bot_b;
  const __m256 t = _mm256_set1_ps(threshold);
  const __m512d zero = _mm512_setzero_pd();
  std::uint32_t l = b, k = 0;
  for (std::uint32_t i = b; i < e; i += 8) {
    // The last block may be short: its missing lanes load nothing, gather nothing and go nowhere.
    const auto live = static_cast<__mmask8>(e - i >= 8 ? 0xffu : (1u << (e - i)) - 1u);
    const __m512i pixels = _mm512_maskz_loadu_epi64(live, a + i);
    const __m256i cells = _mm512_maskz_cvtepi64_epi32(0xff, pixels);  // each lane's low half
    // A run's cells increase (raster order, kept by the stable splits); where its eight pixels are
    // neighbours in a row (80 % of the blocks on the CamVid-size forest: a node's pixels are regions
    // of the image), one load per corner reads what the four gathers would. The two cells are read
    // as integers, not taken out of the vector, so that the branch is decided sooner: a mispredicted
    // one then costs less (bench_eval CamVid per pixel 21-22 -> 19-19.5 ms; loading two vectors per
    // corner and permuting for blocks spread over up to 16 cells was slower).
    const int first = a[i].cell;
    __m512d ta, tb, ba, bb;
    if (live == 0xff && a[i + 7].cell - first == 7) {
      ta = _mm512_loadu_pd(top_a + first);
      tb = _mm512_loadu_pd(top_b + first);
      ba = _mm512_loadu_pd(bot_a + first);
      bb = _mm512_loadu_pd(bot_b + first);
    } else {
      ta = _mm512_mask_i32gather_pd(zero, live, cells, top_a, 8);
      tb = _mm512_mask_i32gather_pd(zero, live, cells, top_b, 8);
      ba = _mm512_mask_i32gather_pd(zero, live, cells, bot_a, 8);
      bb = _mm512_mask_i32gather_pd(zero, live, cells, bot_b, 8);
    }
    // The scalar loop's sums in its order, rounded to float as static_cast<float> does; "not less
    // than" is its !(v < threshold), NaN included.
    const __m256 v = _mm512_maskz_cvtpd_ps(0xff, _mm512_sub_pd(_mm512_sub_pd(bb, tb), _mm512_sub_pd(ba, ta)));
    const __mmask8 goes_right = _mm256_mask_cmp_ps_mask(live, v, t, _CMP_NLT_UQ);
    const auto goes_left = static_cast<__mmask8>(live & ~goes_right);
    const unsigned nl = std::popcount(static_cast<unsigned>(goes_left));
    const unsigned nr = std::popcount(static_cast<unsigned>(goes_right));
    // Compressed in registers, then stored under a mask of the count: no write past the lanes that
    // count (a + l + nl <= a + i + 8 holds the pixels just read; what lies after e is another run's).
    _mm512_mask_storeu_epi64(a + l, static_cast<__mmask8>((1u << nl) - 1u), _mm512_maskz_compress_epi64(goes_left, pixels));
    _mm512_mask_storeu_epi64(right + k, static_cast<__mmask8>((1u << nr) - 1u),
                             _mm512_maskz_compress_epi64(goes_right, pixels));
    l += nl;
    k += nr;
  }
  std::copy(right, right + k, a + l);
  return l;
}

namespace {

#define SMSEG_AVX512 __attribute__((target("avx512f,avx512vl,avx512dq"), always_inline)) inline

// GCC 12 warns that the unmasked forms of these read an undefined vector (-Wmaybe-uninitialized
// inside its own headers); the masked forms with every lane set are the same instructions.
SMSEG_AVX512 __m512i shl64(__m512i v, unsigned k) { return _mm512_maskz_slli_epi64(0xff, v, k); }
SMSEG_AVX512 __m512i shr64(__m512i v, unsigned k) { return _mm512_maskz_srli_epi64(0xff, v, k); }
SMSEG_AVX512 __m512i sar64(__m512i v, unsigned k) { return _mm512_maskz_srai_epi64(0xff, v, k); }
SMSEG_AVX512 __m256i narrow(__m512i v) { return _mm512_maskz_cvtepi64_epi32(0xff, v); }
SMSEG_AVX512 __m512i widen(__m256i v) { return _mm512_maskz_cvtepi32_epi64(0xff, v); }

// One vector of route_avx512's pixels: eight lanes, each a pixel of the set and the node it is at.
struct LaneVector {
  __m256i node, x, y, pixel;
  __mmask8 live;
};

// Where route_avx512 takes its pixels from: the set, and the next pixel not yet taken.
struct PixelSource {
  const std::int32_t *xs, *ys;
  std::int32_t n;  // the set's size
  std::int32_t next = 0;
};

// Lanes `free` of v take the source's next pixels, in lane order, at node `root`; those past the
// end go quiet.
SMSEG_AVX512 void take(LaneVector& v, __mmask8 free, PixelSource& source, __m256i root) {
  const __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  v.pixel = _mm256_mask_expand_epi32(v.pixel, free, _mm256_add_epi32(iota, _mm256_set1_epi32(source.next)));
  const __mmask8 fresh = _mm256_mask_cmplt_epi32_mask(free, v.pixel, _mm256_set1_epi32(source.n));
  v.live = static_cast<__mmask8>((v.live & ~free) | fresh);
  // The fresh lanes are the first of `free` (in lane order), so they take the next coordinates in a
  // row: read in place, no gather (none at all when no lane is fresh: the pointer is only kept valid).
  const std::int32_t from = std::min(source.next, source.n);
  v.x = _mm256_mask_expandloadu_epi32(v.x, fresh, source.xs + from);
  v.y = _mm256_mask_expandloadu_epi32(v.y, fresh, source.ys + from);
  v.node = _mm256_mask_mov_epi32(v.node, fresh, root);
  source.next += std::popcount(static_cast<unsigned>(free));
}

// A corner's address: the attribute's table plus the cell (clipped row * stride + clipped column).
SMSEG_AVX512 __m512i corner(__m512i base, __m256i row, __m256i col) {
  return _mm512_add_epi64(base, shl64(widen(_mm256_add_epi32(row, col)), 3));
}

// window_sum's clipping of a coordinate to [0, hi].
SMSEG_AVX512 __m256i clip(__m256i v, __m256i hi) {
  return _mm256_min_epi32(_mm256_max_epi32(v, _mm256_setzero_si256()), hi);
}

}  // namespace

__attribute__((target("avx512f,avx512vl,avx512dq"))) void route_avx512(
    const void* nodes, std::uint32_t root, const double* const* sats, std::size_t num_sats, int width, int height,
    const std::int32_t* xs, const std::int32_t* ys, std::size_t n, std::int32_t* leaf) {
  if (n == 0) return;
  if (num_sats > 16 || n > 0x7fffffffu) throw std::logic_error("route_avx512: at most 16 tables and 2^31 pixels");
  // Two vectors in flight: one vector's step waits for its node and then for its tables (two
  // gathers in a row), and the other's step fills the wait. (bench_eval, CamVid grid B = 20, V = 6,
  // 2 threads, on an AMD Zen 5: 1, 2, 4, 8 vectors 1.51, 1.09, 1.15, 1.27 ms; beyond two the gathers'
  // throughput, not their latency, is the limit, and the vectors no longer fit in registers.)
  constexpr int kVectors = 2;
  const auto* words = static_cast<const long long*>(nodes);  // node i: words 2i (rectangle), 2i + 1 (threshold, next)
  alignas(64) long long bases[16] = {};                       // the tables' addresses, by attribute
  for (std::size_t f = 0; f < num_sats; ++f) bases[f] = reinterpret_cast<long long>(sats[f]);
  const __m512i bases_lo = _mm512_load_si512(bases), bases_hi = _mm512_load_si512(bases + 8);
  const __m256i zero = _mm256_setzero_si256();
  const __m256i W = _mm256_set1_epi32(width), H = _mm256_set1_epi32(height), S = _mm256_set1_epi32(width + 1);
  const __m256i root_v = _mm256_set1_epi32(static_cast<int>(root)), one = _mm256_set1_epi32(1);
  const __m256i leaf_bit = _mm256_set1_epi32(1 << 8), attr_bits = _mm256_set1_epi32(0xff);
  const __m512d none = _mm512_setzero_pd();
  PixelSource source{xs, ys, static_cast<std::int32_t>(n)};
  LaneVector lanes[kVectors];
  for (LaneVector& v : lanes) {
    v = LaneVector{zero, zero, zero, zero, 0};
    take(v, 0xff, source, root_v);
  }
  for (;;) {
    __mmask8 any = 0;
    for (LaneVector& v : lanes) {
      any |= v.live;
      const __m256i index = _mm256_add_epi32(v.node, v.node);
      const __m512i rect = _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), v.live, index, words, 8);
      const __m512i tail = _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), v.live, index, words + 1, 8);
      const __m256i link = narrow(shr64(tail, 32));  // next: child or leaf row << 9
      const __m256 threshold = _mm256_castsi256_ps(narrow(tail));
      const __mmask8 at_leaf = _mm256_mask_test_epi32_mask(v.live, link, leaf_bit);
      const auto step = static_cast<__mmask8>(v.live & ~at_leaf);
      // The rectangle's int16 fields, sign-extended: x0 bits 0..15, x1 16..31, y0 32..47, y1 48..63.
      const __m256i x0 = narrow(sar64(shl64(rect, 48), 48));
      const __m256i x1 = narrow(sar64(shl64(rect, 32), 48));
      const __m256i y0 = narrow(sar64(shl64(rect, 16), 48));
      const __m256i y1 = narrow(sar64(rect, 48));
      const __m256i xa = clip(_mm256_add_epi32(v.x, x0), W), xb = clip(_mm256_add_epi32(v.x, x1), W);
      const __m256i top = _mm256_mullo_epi32(clip(_mm256_add_epi32(v.y, y0), H), S);
      const __m256i bot = _mm256_mullo_epi32(clip(_mm256_add_epi32(v.y, y1), H), S);
      const __m512i base = _mm512_permutex2var_epi64(bases_lo, widen(_mm256_and_si256(link, attr_bits)), bases_hi);
      const __m512d ta = _mm512_mask_i64gather_pd(none, step, corner(base, top, xa), nullptr, 1);
      const __m512d tb = _mm512_mask_i64gather_pd(none, step, corner(base, top, xb), nullptr, 1);
      const __m512d ba = _mm512_mask_i64gather_pd(none, step, corner(base, bot, xa), nullptr, 1);
      const __m512d bb = _mm512_mask_i64gather_pd(none, step, corner(base, bot, xb), nullptr, 1);
      // window_sum's order, rounded to float; "not less than" is the scalar walk's !(v < threshold).
      const __m256 value = _mm512_maskz_cvtpd_ps(0xff, _mm512_sub_pd(_mm512_sub_pd(bb, tb), _mm512_sub_pd(ba, ta)));
      const __mmask8 right = _mm256_mask_cmp_ps_mask(step, value, threshold, _CMP_NLT_UQ);
      const __m256i child = _mm256_srli_epi32(link, 9);
      v.node = _mm256_mask_add_epi32(_mm256_mask_mov_epi32(v.node, step, child), right, child, one);
      _mm256_mask_i32scatter_epi32(leaf, at_leaf, v.pixel, child, 4);  // a leaf's row
      if (at_leaf) take(v, at_leaf, source, root_v);  // (branching past it when no lane is at a leaf: -8 %)
    }
    if (!any) break;
  }
}

__attribute__((target("avx512f,avx512vl,avx512dq"))) void sum_votes_avx512(
    const float* probs, std::size_t padded, std::size_t classes, const std::int32_t* leaf, std::size_t n,
    std::size_t M, std::uint8_t* labels, float* dists) {
  const auto in_row = static_cast<__mmask16>((1u << padded) - 1u);
  const auto is_class = static_cast<__mmask16>((1u << classes) - 1u);  // dists' lanes
  for (std::size_t i = 0; i < n; ++i) {
    // acc = 0.0f + q0, then += each later tree's row: the scalar loop's order in every lane.
    __m512 acc = _mm512_maskz_loadu_ps(in_row, probs + static_cast<std::size_t>(leaf[i]) * padded);
    for (std::size_t t = 1; t < M; ++t)
      acc = _mm512_add_ps(acc, _mm512_maskz_loadu_ps(in_row, probs + static_cast<std::size_t>(leaf[t * n + i]) * padded));
    alignas(64) float sums[16];
    _mm512_store_ps(sums, acc);
    std::size_t best = 0;  // the first class of the largest sum, as the scalar loop
    for (std::size_t c = 1; c < classes; ++c)
      if (sums[c] > sums[best]) best = c;
    labels[i] = static_cast<std::uint8_t>(best);
    if (dists) _mm512_mask_storeu_ps(dists + i * classes, is_class, acc);
  }
}

#else

bool split_avx512_available() { return false; }

void sum_votes_avx512(const float*, std::size_t, std::size_t, const std::int32_t*, std::size_t, std::size_t,
                      std::uint8_t*, float*) {
  throw std::logic_error("sum_votes_avx512 called on a build without AVX-512");  // set_simd never allows it
}

void route_avx512(const void*, std::uint32_t, const double* const*, std::size_t, int, int, const std::int32_t*,
                  const std::int32_t*, std::size_t, std::int32_t*) {
  throw std::logic_error("route_avx512 called on a build without AVX-512");  // set_simd never allows it
}

std::uint32_t split_avx512(RoutedPixel*, RoutedPixel*, std::uint32_t, std::uint32_t, const double*,
                           const WindowCorners&, float) {
  throw std::logic_error("split_avx512 called on a build without AVX-512");  // set_simd never allows it
}

#endif

}  // namespace smseg::forest::detail
