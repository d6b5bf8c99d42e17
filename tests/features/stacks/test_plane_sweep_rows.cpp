// The plane sweep's per-pixel row loops (features/stacks/src/plane_sweep_rows.hpp) against the
// one-pixel-at-a-time loops they replaced, written out here as they were: bit for bit on rows of every
// length from 1 to 37 (every tail after the vector lanes), with ties, windows outside the image, flat
// windows and scores at the thresholds.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

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

// The inside mask against OpenCV's own nearest-neighbour warp of an image of ones, which it replaces: bit
// for bit for the sweep's homographies (near the identity, the neighbour a few pixels off, at the sizes
// the sweep runs at) and for wild ones (strong perspective, a vanishing line through the image, where W
// is 0 or changes sign), exact ties, on images wider and narrower than a warp block and shorter than its
// 16 rows. (Whether X0 is taken at the block's first column or the row's first changes no mask here.)
TEST(PlaneSweepRows, InsideMaskIsOpenCvsNearestWarpOfOnes) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const std::vector<cv::Size> sizes = {{480, 360}, {240, 180}, {320, 240}, {37, 23}, {100, 7}, {1241, 376}, {65, 17}};
  // Exact ties: half-pixel shifts put the last column at width - 0.5 (an odd width rounds it to even,
  // inside) and the first at -0.5 (to -0, inside); a last row of zeros makes W 0 everywhere (OpenCV then
  // takes the source pixel (0, 0)).
  const std::vector<cv::Matx33d> special = {{1, 0, 0.5, 0, 1, 0.5, 0, 0, 1},   {1, 0, -0.5, 0, 1, -0.5, 0, 0, 1},
                                            {1, 0, 1.5, 0, 1, -1.5, 0, 0, 1},  {2, 0, -0.5, 0, 2, 0.5, 0, 0, 2},
                                            {1, 0.3, 2, 0.1, 1, -3, 0, 0, 0}};
  int compared = 0;
  for (const cv::Size size : sizes) {
    const cv::Mat ones(size, CV_8UC1, cv::Scalar(1));
    for (int trial = 0; trial < 60 + int(special.size()); ++trial) {
      cv::Matx33d H;
      if (trial >= 60) {
        H = special[trial - 60];
      } else if (trial % 3 == 0) {  // wild: anything, the last row too
        for (double& m : H.val) m = u(rng) * (trial % 2 ? 2.0 : 0.02);
        H(2, 2) = u(rng);
      } else {  // a plane sweep's: near the identity, shifted by up to a tenth of the image
        const double s = trial % 3 == 1 ? 1e-3 : 3e-2;
        H = cv::Matx33d(1 + s * u(rng), s * u(rng), 0.1 * size.width * u(rng), s * u(rng), 1 + s * u(rng),
                        0.1 * size.height * u(rng), 1e-4 * u(rng), 1e-4 * u(rng), 1 + s * u(rng));
      }
      cv::Mat want;
      cv::warpPerspective(ones, want, H, size, cv::INTER_NEAREST | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT,
                          cv::Scalar(0));
      for (const auto isa : smseg::stacks::sweep_rows::inside_isas()) {  // every instruction set it runs
        cv::Mat got(size, CV_8UC1);
        for (int y = 0; y < size.height; ++y)
          smseg::stacks::sweep_rows::inside_row(H.val, y, size.width, size.height, got.ptr(y), isa);
        const int differ = cv::countNonZero(got != want);
        EXPECT_EQ(differ, 0) << size << " trial " << trial << " instruction set " << int(isa) << " H " << H;
      }
      compared += cv::countNonZero(want) > 0 && cv::countNonZero(want) < size.area();  // a border inside
    }
  }
  EXPECT_GT(compared, 100) << "too few masks with both inside and outside pixels to mean anything";
}

}  // namespace
