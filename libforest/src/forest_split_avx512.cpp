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

std::uint32_t split_avx512(RoutedPixel*, RoutedPixel*, std::uint32_t, std::uint32_t, const double*,
                           const WindowCorners&, float) {
  throw std::logic_error("split_avx512 called on a build without AVX-512");  // set_simd never allows it
}

#endif

}  // namespace smseg::forest::detail
