// The plane sweep's per-pixel loops, one image row at a time (plane_sweep.cpp). They are in vector code
// (compiler-vectorised or four lanes of GCC / Clang vector extensions) and must give, bit for bit, what
// the one-pixel-at-a-time loops they replaced gave, and the inside mask what OpenCV's warp of an image of
// ones gave; tests/features/stacks/test_plane_sweep_rows.cpp holds them to those, on rows of every tail
// length, with ties.
#pragma once

#include <cstdint>
#include <vector>

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

// Row y (of rows >= 1) of the mask cv::warpPerspective makes of a cols x rows image of ones into a
// cols x rows destination (INTER_NEAREST | WARP_INVERSE_MAP, BORDER_CONSTANT 0) with the 3x3 matrix M
// (row-major): 1 where the source pixel round(M (x, y, 1)) lies inside the image, else 0. The
// coordinates are computed as OpenCV 4.6 computes them (imgproc/src/imgwarp.cpp,
// WarpPerspectiveInvoker, and its SSE4.1 processNN): in blocks of the columns OpenCV's warp uses (64 at
// 16 rows or more), from each block's first column xb, X0 = M0 xb + M1 y + M2 (and Y0, W0 alike); for
// column xb + x1, W = M6 x1 + W0, its inverse (0 where W is 0), fX = (X0 + M0 x1) / W rounded to
// nearest, ties to even. Without OpenCV's remapping of an image, BM_PlaneSweepCamVid takes 12 % less.
// The same code compiled for SSE2 (any x86-64), AVX2 and AVX-512 (where the processor has them: the
// widest by default); each must give the same mask, which the tests check. An explicit `isa` must be one
// that inside_isas() lists: the loop of an instruction set the processor lacks would fault.
enum class InsideIsa { Best, Sse2, Avx2, Avx512 };
std::vector<InsideIsa> inside_isas();  // what this processor runs, SSE2 first
void inside_row(const double* M, int y, int cols, int rows, std::uint8_t* out, InsideIsa isa = InsideIsa::Best);

}  // namespace smseg::stacks::sweep_rows
