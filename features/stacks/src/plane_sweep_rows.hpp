// The plane sweep's per-pixel loops, one image row at a time (plane_sweep.cpp). They are in vector code
// (compiler-vectorised or four lanes of GCC / Clang vector extensions) and must give, bit for bit, what
// the one-pixel-at-a-time loops they replaced gave; tests/features/stacks/test_plane_sweep_rows.cpp
// holds them to those loops on rows of every tail length, with ties.
#pragma once

#include <cstdint>

namespace smseg::stacks::sweep_rows {

constexpr float kNoScore = -2.0f;  // below any ZNCC: "no such plane"

// s = ZNCC of a window pair from its box means (mj, qj = E[J], E[J^2] of the warped neighbour; mij =
// E[IJ]; mi, si = mean and standard deviation of the reference) where `in` is non-zero and both windows
// have texture (si * sj > 1e-3), else -1.
void zncc(const float* mj, const float* qj, const float* mij, const float* mi, const float* si, const std::uint8_t* in,
          int n, float* s);

// The best plane so far: where in > b, b = in and k = p.
void best_plane(const float* in, int n, int p, float* b, int* k);

// The joint best plane and the scores either side of it: w = min(w, s); where s > b, b = s, k = p,
// l = before (the previous plane's score), r = kNoScore; else where k == p - 1, r = s.
void joint_best_plane(const float* s, const float* before, int n, int p, float* b, int* k, float* l, float* r,
                      float* w);

}  // namespace smseg::stacks::sweep_rows
