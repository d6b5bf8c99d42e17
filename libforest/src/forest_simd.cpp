// The classifier's vector kernels (forest_simd.hpp), once for every Highway target: Highway's
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

// Route's lanes: per vector of pixels in flight, each lane's node, coordinates (y << 32 | x) and place in
// the set (n or more when the lane has no pixel left), kept in memory between steps (whole vectors
// only: a narrow store read back by a wide load would stall).
struct RouteState {
  static constexpr std::size_t kMax = 8 * HWY_LANES(std::int64_t);
  alignas(64) std::int64_t node[kMax], xy[kMax], pixel[kMax];
};

// What route_step reads: the nodes, the tables and the set.
struct RouteFrame {
  const std::int64_t* words;    // node i: words 2i (rectangle), 2i + 1 (threshold, next)
  const std::int64_t* offsets;  // per attribute, its table's place relative to `first`, in doubles
  const double* first;
  const std::int64_t* xy;       // the set's pixels, y << 32 | x
  std::int64_t* leaf;           // their leaf rows (and one slot past them for lanes that write nothing)
  std::int64_t width, height, stride, n;
  std::int64_t root;
  bool few_tables;              // at most N tables: their offsets are one vector's lanes
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

// One step of the lanes [g, g + N) of the state, without a branch on the lanes' outcomes: a lane at a
// split takes its child; a lane at a leaf writes the leaf's row (a scatter: the other lanes write the
// spare slot) and takes the set's next pixel (next + its rank among the leaf lanes: the next pixels,
// in lane order). Returns how many lanes were at a leaf. (Logging the leaves by compressed stores and
// taking the next pixels by one load and a permutation instead of the scatter and the gather: the
// same time with AVX-512, 1.4x slower with AVX2.)
HWY_INLINE std::size_t route_step(const RouteFrame& f, RouteState& s, std::size_t g, std::int64_t next) {
  const hn::ScalableTag<std::int64_t> di;
  const hn::RebindToUnsigned<decltype(di)> du;
  const hn::Repartition<std::int32_t, decltype(di)> d32;
  const hn::Rebind<std::int32_t, decltype(di)> di32;
  const hn::RebindToFloat<decltype(di)> dd;
  const hn::Rebind<float, decltype(dd)> df;
  const hn::Rebind<std::uint32_t, decltype(du)> du32;
  const auto node = hn::Load(di, s.node + g), pixel = hn::Load(di, s.pixel + g), xy = hn::Load(di, s.xy + g);
  const auto n = hn::Set(di, f.n);
  const auto index = hn::Add(node, node);
  const auto rect = hn::GatherIndex(di, f.words, index);
  const auto tail = hn::BitCast(du, hn::GatherIndex(di, f.words + 1, index));
  const auto link = hn::BitCast(di, hn::ShiftRight<32>(tail));  // child or leaf row << 9, leaf bit, attribute
  const auto at_leaf = hn::And(hn::Lt(pixel, n), hn::TestBit(link, hn::Set(di, 1 << 8)));
  // The rectangle's int16 fields, sign-extended: x0 bits 0..15, x1 16..31, y0 32..47, y1 48..63.
  const auto x = hn::And(xy, hn::Set(di, 0xffffffff)), y = hn::ShiftRight<32>(xy);
  const auto W = hn::Set(di, f.width), H = hn::Set(di, f.height);
  const auto xa = clip(hn::Add(x, hn::ShiftRight<48>(hn::ShiftLeft<48>(rect))), W);
  const auto xb = clip(hn::Add(x, hn::ShiftRight<48>(hn::ShiftLeft<32>(rect))), W);
  const auto S = hn::BitCast(d32, hn::Set(di, f.stride));
  const auto attr = hn::And(link, hn::Set(di, 0xff));
  const auto base = f.few_tables ? hn::TableLookupLanes(hn::LoadU(di, f.offsets), hn::IndicesFromVec(di, attr))
                                 : hn::GatherIndex(di, f.offsets, attr);
  const auto top = hn::Add(base, hn::MulEven(hn::BitCast(d32, clip(hn::Add(y, hn::ShiftRight<48>(hn::ShiftLeft<16>(rect))), H)), S));
  const auto bot = hn::Add(base, hn::MulEven(hn::BitCast(d32, clip(hn::Add(y, hn::ShiftRight<48>(rect)), H)), S));
  auto corner = [&](auto row, auto col) { return hn::GatherIndex(dd, f.first, hn::Add(row, col)); };
  const auto value = hn::Sub(hn::Sub(corner(bot, xb), corner(top, xb)), hn::Sub(corner(bot, xa), corner(top, xa)));
  // float(value) < threshold, as the scalar walk; NaN goes right.
  const auto threshold = hn::BitCast(df, hn::TruncateTo(du32, tail));
  const auto right_f = hn::VecFromMask(df, hn::Not(hn::Lt(hn::DemoteTo(df, value), threshold)));
  const auto right = hn::MaskFromVec(hn::PromoteTo(di, hn::BitCast(di32, right_f)));  // all ones stay all ones
  const auto child = hn::ShiftRight<9>(link);
  hn::ScatterIndex(child, di, f.leaf, hn::IfThenElse(at_leaf, pixel, n));
  const std::uint32_t leaves = mask_bits(di, at_leaf);
  static const LaneRanks ranks;
  const auto taken = hn::Add(hn::Set(di, next), hn::PromoteTo(di, hn::LoadU(di32, ranks.rank[leaves & 0xff])));
  const auto new_pixel = hn::IfThenElse(at_leaf, taken, pixel);
  const auto new_xy = hn::GatherIndex(di, f.xy, hn::Min(new_pixel, hn::Set(di, f.n - 1)));
  hn::Store(new_pixel, di, s.pixel + g);
  hn::Store(hn::IfThenElse(at_leaf, new_xy, xy), di, s.xy + g);
  const auto stepped = hn::Add(child, hn::IfThenElseZero(right, hn::Set(di, 1)));
  hn::Store(hn::IfThenElse(at_leaf, hn::Set(di, f.root), stepped), di, s.node + g);
  return static_cast<std::size_t>(std::popcount(leaves));
}

void Route(const void* nodes, std::uint32_t root, const double* const* sats, std::size_t num_sats, int width,
           int height, const std::int32_t* xs, const std::int32_t* ys, std::size_t n, std::int32_t* leaf) {
  if (n == 0) return;
  const hn::ScalableTag<std::int64_t> di;
  const std::size_t N = hn::Lanes(di);
  if (N > 8) throw std::logic_error("the vector walk takes at most 8 lanes");
  // Pixels in flight: each vector's step waits for its node, then for its table cells (two gathers in a
  // row); the other vectors' steps fill the wait. (bench_eval, CamVid grid, one thread, Xeon VM, with
  // a variant of this step that logged the leaves by compressed stores: AVX-512 8, 16, 24, 64 pixels
  // in flight 4.3-4.7, 3.5-3.6, 3.3-3.5, 3.8 ms.)
  const std::size_t vectors = std::clamp<std::size_t>(24 / N, 1, RouteState::kMax / N);
  std::int64_t offsets[256] = {};
  for (std::size_t a = 0; a < num_sats; ++a)
    offsets[a] = static_cast<std::int64_t>(reinterpret_cast<std::uintptr_t>(sats[a]) - reinterpret_cast<std::uintptr_t>(sats[0])) /
                 static_cast<std::int64_t>(sizeof(double));
  std::vector<std::int64_t> xy(n), leaf64(n + 1);
  for (std::size_t i = 0; i < n; ++i)
    xy[i] = static_cast<std::int64_t>(static_cast<std::uint64_t>(static_cast<std::uint32_t>(ys[i])) << 32 | static_cast<std::uint32_t>(xs[i]));
  const RouteFrame f{static_cast<const std::int64_t*>(nodes), offsets, sats[0], xy.data(), leaf64.data(), width, height,
                     width + 1, static_cast<std::int64_t>(n), root, num_sats <= N};
  RouteState s;
  for (std::size_t g = 0; g < vectors * N; ++g) {
    s.node[g] = root;
    s.pixel[g] = static_cast<std::int64_t>(g);  // past n: no pixel
    s.xy[g] = g < n ? xy[g] : 0;
  }
  std::int64_t next = static_cast<std::int64_t>(vectors * N);
  for (std::size_t done = 0; done < n;)
    for (std::size_t v = 0; v < vectors; ++v) {
      const std::size_t leaves = route_step(f, s, v * N, next);
      next += static_cast<std::int64_t>(leaves);
      done += leaves;
    }
  for (std::size_t i = 0; i < n; ++i) leaf[i] = static_cast<std::int32_t>(leaf64[i]);
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

// The target's name for SMSEG_SIMD: Highway's, in lower case ("avx2", "neon"), but "avx512" for AVX3.
std::string target_name() {
  if (HWY_TARGET == HWY_AVX3) return "avx512";
  std::string s = hwy::TargetName(HWY_TARGET);
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

const SimdKernels* Kernels() {
  static const std::string name = target_name();
  static const SimdKernels kernels{name.c_str(), &SplitChunks, &LeafRows, &Route, &SumVotes};
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
