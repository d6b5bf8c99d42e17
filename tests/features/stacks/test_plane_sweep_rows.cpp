// The plane sweep's per-pixel row loops (features/stacks/src/plane_sweep_rows.hpp) against the
// one-pixel-at-a-time loops they replaced, written out here as they were: bit for bit on rows of every
// length from 1 to 37 (every tail after the vector lanes), with ties, windows outside the image, flat
// windows and scores at the thresholds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "plane_sweep_rows.hpp"

namespace {

using smseg::stacks::sweep_rows::kNoScore;

// The loops as they were before the rows went to vector code (git show 1822ef3^:features/stacks/src/plane_sweep.cpp).
void zncc_reference(const float* mj, const float* qj, const float* mij, const float* mi, const float* si,
                    const std::uint8_t* in, int n, float* s) {
  for (int x = 0; x < n; ++x) {
    const float sj = std::sqrt(std::max(0.0f, qj[x] - mj[x] * mj[x]));
    const float denominator = si[x] * sj;
    s[x] = in[x] && denominator > 1e-3f ? (mij[x] - mi[x] * mj[x]) / denominator : -1.0f;
  }
}

void best_plane_reference(const float* in, int n, int p, float* b, int* k) {
  for (int x = 0; x < n; ++x)
    if (in[x] > b[x]) {
      b[x] = in[x];
      k[x] = p;
    }
}

void joint_reference(const float* s, const float* before, int n, int p, float* b, int* k, float* l, float* r,
                     float* w) {
  for (int x = 0; x < n; ++x) {
    w[x] = std::min(w[x], s[x]);
    if (s[x] > b[x]) {
      b[x] = s[x];
      k[x] = p;
      l[x] = before[x];
      r[x] = kNoScore;
    } else if (k[x] == p - 1) {
      r[x] = s[x];
    }
  }
}

// Bit for bit (so -0.0 against 0.0 or two NaNs of different payloads would show).
template <class T>
void expect_same_bits(const std::vector<T>& got, const std::vector<T>& want, const char* what, int n) {
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < got.size(); ++i)
    EXPECT_EQ(0, std::memcmp(&got[i], &want[i], sizeof(T))) << what << " at " << i << " of a row of " << n << ": "
                                                            << got[i] << " against " << want[i];
}

// Scores drawn from a few values so that ties between planes are common, with the ends of ZNCC's range
// and the "no such plane" marker among them.
float tied_score(std::mt19937& rng) {
  static const float values[] = {-1.0f, -0.5f, 0.0f, 0.25f, 0.5f, 0.75f, 1.0f, kNoScore};
  std::uniform_real_distribution<float> any(-1.0f, 1.0f);
  std::uniform_int_distribution<int> pick(0, 9);
  const int i = pick(rng);
  return i < 8 ? values[i] : any(rng);
}

TEST(PlaneSweepRows, ZnccIsTheOnePixelLoop) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> grey(0.0f, 255.0f), spread(0.0f, 40.0f);
  std::uniform_int_distribution<int> coin(0, 3), texture(0, 4);
  for (int n = 1; n <= 37; ++n)
    for (int trial = 0; trial < 20; ++trial) {
      std::vector<float> mj(n), qj(n), mij(n), mi(n), si(n);
      std::vector<std::uint8_t> in(n);
      for (int x = 0; x < n; ++x) {
        mj[x] = grey(rng);
        mi[x] = grey(rng);
        si[x] = coin(rng) == 0 ? 0.0f : spread(rng);
        // Flat windows (variance 0, or a rounding below 0), texture exactly at the 1e-3 threshold
        // (si * sj = 1e-3 * 1), and real texture.
        switch (texture(rng)) {
          case 0: qj[x] = mj[x] * mj[x]; break;
          case 1: qj[x] = mj[x] * mj[x] - 1e-3f; break;
          case 2:
            mj[x] = 0.0f;
            qj[x] = 1.0f;
            si[x] = 1e-3f;
            break;
          default: qj[x] = mj[x] * mj[x] + spread(rng) * spread(rng);
        }
        mij[x] = mi[x] * mj[x] + (grey(rng) - 128.0f) * 4.0f;
        in[x] = coin(rng) == 0 ? 0 : 1;
      }
      std::vector<float> got(n), want(n);
      smseg::stacks::sweep_rows::zncc(mj.data(), qj.data(), mij.data(), mi.data(), si.data(), in.data(), n,
                                      got.data());
      zncc_reference(mj.data(), qj.data(), mij.data(), mi.data(), si.data(), in.data(), n, want.data());
      expect_same_bits(got, want, "zncc", n);
    }
}

TEST(PlaneSweepRows, BestPlaneIsTheOnePixelLoop) {
  std::mt19937 rng(11);
  for (int n = 1; n <= 37; ++n) {
    std::vector<float> b_got(n, -INFINITY), b_want(n, -INFINITY);
    std::vector<int> k_got(n, -1), k_want(n, -1);
    for (int p = 0; p < 12; ++p) {
      std::vector<float> in(n);
      for (float& v : in) v = tied_score(rng);
      smseg::stacks::sweep_rows::best_plane(in.data(), n, p, b_got.data(), k_got.data());
      best_plane_reference(in.data(), n, p, b_want.data(), k_want.data());
    }
    expect_same_bits(b_got, b_want, "best score", n);
    expect_same_bits(k_got, k_want, "best plane", n);
  }
}

TEST(PlaneSweepRows, JointBestPlaneIsTheOnePixelLoop) {
  std::mt19937 rng(13);
  for (int n = 1; n <= 37; ++n) {
    // As the sweep starts them: no best yet, no neighbours' scores, the worst at 1.
    std::vector<float> b_got(n, -INFINITY), l_got(n, kNoScore), r_got(n, kNoScore), w_got(n, 1.0f);
    std::vector<int> k_got(n, -1);
    std::vector<float> b_want = b_got, l_want = l_got, r_want = r_got, w_want = w_got;
    std::vector<int> k_want = k_got;
    std::vector<float> previous(n, kNoScore), s(n);
    for (int p = 0; p < 16; ++p) {
      for (float& v : s) v = tied_score(rng);
      smseg::stacks::sweep_rows::joint_best_plane(s.data(), previous.data(), n, p, b_got.data(), k_got.data(),
                                                  l_got.data(), r_got.data(), w_got.data());
      joint_reference(s.data(), previous.data(), n, p, b_want.data(), k_want.data(), l_want.data(), r_want.data(),
                      w_want.data());
      previous = s;
    }
    expect_same_bits(b_got, b_want, "joint best score", n);
    expect_same_bits(k_got, k_want, "joint best plane", n);
    expect_same_bits(l_got, l_want, "left score", n);
    expect_same_bits(r_got, r_want, "right score", n);
    expect_same_bits(w_got, w_want, "worst score", n);
  }
}

}  // namespace
