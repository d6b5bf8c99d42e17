#pragma once
// Randomness of the forest, independent of the standard library's distributions (whose output is
// implementation-defined), so that the same seed gives the same forest on every platform.
//
// - Rng: xoshiro256** seeded through splitmix64; one per tree, from tree_seed(seed, tree).
// - hash_uniform: a stateless counter-based draw, used for node thresholds so that candidates can
//   be scored in parallel inside one node while staying identical whatever the thread count.

#include <cstdint>

namespace smseg::forest {

__extension__ typedef unsigned __int128 uint128_t;  // GCC/Clang extension; -Wpedantic safe

/// splitmix64 finaliser: a good 64-bit mixing function (Steele, Lea & Flood 2014).
constexpr std::uint64_t mix64(std::uint64_t x) noexcept {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

/// The seed of tree `tree` of a forest trained with `seed` (docs/design.md section 7: one generator per tree).
constexpr std::uint64_t tree_seed(std::uint64_t seed, int tree) noexcept {
  return mix64(mix64(seed) ^ mix64(0xA5A5A5A5ULL + static_cast<std::uint64_t>(tree)));
}

/// A double in [0, 1) with 53 random bits.
constexpr double to_unit(std::uint64_t x) noexcept {
  return static_cast<double>(x >> 11) * 0x1.0p-53;
}

/// Stateless uniform [0, 1) from three counters (tree seed, node, candidate).
constexpr double hash_uniform(std::uint64_t a, std::uint64_t b, std::uint64_t c) noexcept {
  return to_unit(mix64(a ^ mix64(b ^ mix64(c))));
}

/// xoshiro256** 1.0 (Blackman & Vigna).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) noexcept {
    std::uint64_t z = seed;
    for (auto& si : s_) {
      z += 0x9E3779B97F4A7C15ULL;
      si = mix64(z);
    }
  }
  std::uint64_t next() noexcept {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  /// Uniform in [0, 1).
  double uniform() noexcept { return to_unit(next()); }
  /// Uniform integer in [0, n), n >= 1, unbiased (Lemire's method with rejection).
  std::uint64_t below(std::uint64_t n) noexcept {
    uint128_t m = static_cast<uint128_t>(next()) * n;
    auto low = static_cast<std::uint64_t>(m);
    if (low < n) {
      const std::uint64_t threshold = (0 - n) % n;
      while (low < threshold) {
        m = static_cast<uint128_t>(next()) * n;
        low = static_cast<std::uint64_t>(m);
      }
    }
    return static_cast<std::uint64_t>(m >> 64);
  }
  /// Uniform integer in [lo, hi], lo <= hi.
  int uniform_int(int lo, int hi) noexcept {
    return lo + static_cast<int>(below(static_cast<std::uint64_t>(static_cast<std::int64_t>(hi) - lo + 1)));
  }

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) noexcept { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4];
};

}  // namespace smseg::forest
