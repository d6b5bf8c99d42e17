#pragma once
// Internals shared by the synth_*.cpp files (not a public header): counter-based hashing, a small
// seeded generator with platform-independent distributions, colour helpers, texture evaluation.

#include <array>
#include <cmath>
#include <cstdint>

#include "smseg/synth/synth.hpp"

namespace smseg::synth::detail {

/// SplitMix64 finaliser: a good 64-bit mixer.
inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

inline std::uint64_t hash(std::uint64_t a, std::uint64_t b) { return mix64(a ^ mix64(b)); }
inline std::uint64_t hash(std::uint64_t a, std::uint64_t b, std::uint64_t c) { return hash(hash(a, b), c); }
inline std::uint64_t hash(std::uint64_t a, std::uint64_t b, std::uint64_t c, std::uint64_t d) {
  return hash(hash(a, b, c), d);
}

/// Fast 32-bit integer hash (lowbias32) for texture lattices.
inline std::uint32_t hash32(std::uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}
inline std::uint32_t hash2i(int x, int y, std::uint32_t seed) {
  return hash32(static_cast<std::uint32_t>(x) * 0x9e3779b1u ^ hash32(static_cast<std::uint32_t>(y) + seed));
}
/// Uniform in [0, 1) from a lattice point.
inline float lattice(int x, int y, std::uint32_t seed) {
  return static_cast<float>(hash2i(x, y, seed) >> 8) * (1.0f / 16777216.0f);
}

/// Deterministic generator: the k-th draw is mix64(state + k * golden); distributions are ours, so
/// the same seed gives the same numbers on every platform (unlike std::uniform_real_distribution).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(mix64(seed)) {}
  std::uint64_t next() {
    state_ += 0x9e3779b97f4a7c15ull;
    std::uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  int index(int n) { return static_cast<int>(uniform() * n) % n; }
  bool chance(double p) { return uniform() < p; }

 private:
  std::uint64_t state_;
};

/// sRGB-ish (gamma 2.2) 0..1 to linear.
inline std::array<float, 3> lin(double r, double g, double b) {
  return {static_cast<float>(std::pow(r, 2.2)), static_cast<float>(std::pow(g, 2.2)),
          static_cast<float>(std::pow(b, 2.2))};
}

struct Rgb {
  float r = 0, g = 0, b = 0;
};
inline Rgb rgb(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }
inline Rgb operator*(Rgb a, float k) { return {a.r * k, a.g * k, a.b * k}; }
inline Rgb operator*(Rgb a, Rgb b) { return {a.r * b.r, a.g * b.g, a.b * b.b}; }
inline Rgb operator+(Rgb a, Rgb b) { return {a.r + b.r, a.g + b.g, a.b + b.b}; }
inline Rgb mix(Rgb a, Rgb b, float t) { return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t}; }

/// Rays ignore hits closer than this (in units of the ray direction; for pixel rays, metres of depth).
inline constexpr double kMinLambda = 1e-4;

/// The one ray-quad test, shared by the brute-force cast_ray and the renderer so that both give
/// bit-identical results: true (and best updated) for a front-facing hit nearer than best.
/// `num` must be (q.centre - o).dot(q.normal) (the renderer computes it once per quad and view).
inline bool intersect(const Quad& q, double num, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double& best) {
  const double denom = d.dot(q.normal);
  if (!(denom < 0.0)) return false;
  // lambda = num / denom; with denom < 0, lambda < best <=> num > best * denom (no division for the
  // many quads behind the current best).
  if (!(num > best * denom)) return false;
  const double lambda = num / denom;
  if (!(lambda > kMinLambda) || !(lambda < best)) return false;
  const Eigen::Vector3d r = o + lambda * d - q.centre;
  const double a = r.dot(q.u), b = r.dot(q.v);
  if (std::abs(a) > q.hu || std::abs(b) > q.hv) return false;
  if (q.disc && (a * a) / (q.hu * q.hu) + (b * b) / (q.hv * q.hv) > 1.0) return false;
  best = lambda;
  return true;
}
inline bool intersect(const Quad& q, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double& best) {
  return intersect(q, (q.centre - o).dot(q.normal), o, d, best);
}

/// The direction of the ray through pixel (x, y): R * ((x - cx) / fx, (y - cy) / fx, 1), so that lambda
/// along it is z-depth. Shared by pixel_ray and the renderer (bit-identical rays).
inline Eigen::Vector3d ray_direction(const sequence::Pose& pose, double fx, double cx, double cy, double x, double y) {
  const double a = (x - cx) / fx, b = (y - cy) / fx;
  const auto& R = pose.R;
  return {R[0] * a + R[1] * b + R[2], R[3] * a + R[4] * b + R[5], R[6] * a + R[7] * b + R[8]};
}

/// Albedo (linear RGB) of a material at surface coordinates (s, t) in metres, band-limited for a
/// pixel footprint of fp metres on the surface. Defined in synth_texture.cpp.
Rgb albedo(const Material& m, float s, float t, float fp);

}  // namespace smseg::synth::detail
