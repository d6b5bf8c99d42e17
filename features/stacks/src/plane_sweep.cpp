// Plane-sweep depth of a monocular frame: see plane_sweep.hpp.
#include "smseg/stacks/plane_sweep.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include <Eigen/Core>
#include <Eigen/LU>
#include <opencv2/imgproc.hpp>

#include "smseg/common/error.hpp"
#include "smseg/frontend/trajectory.hpp"
#include "plane_sweep_rows.hpp"

namespace smseg::stacks {

namespace sweep_rows {

// One row of plane_scores: s = ZNCC where the window is inside and both windows have texture, else -1.
// Without branches and through restrict pointers, so that the compiler makes vector code of it (this file
// is compiled with -fno-math-errno and -fno-trapping-math: see CMakeLists.txt): the same float operations
// in the same order as one pixel at a time, the quotient computed everywhere and kept where it counts.
void zncc(const float* __restrict mj, const float* __restrict qj, const float* __restrict mij,
          const float* __restrict mi, const float* __restrict si, const std::uint8_t* __restrict in, int n,
          float* __restrict s) {
  for (int x = 0; x < n; ++x) {
    const float variance = qj[x] - mj[x] * mj[x];
    const float sj = std::sqrt(variance > 0.0f ? variance : 0.0f);  // std::max(0.0f, variance)
    const float denominator = si[x] * sj;
    const float zncc = (mij[x] - mi[x] * mj[x]) / denominator;
    s[x] = ((in[x] != 0) & (denominator > 1e-3f)) ? zncc : -1.0f;
  }
}

namespace {

// One block's columns of inside_row as 0 / 1 in 64-bit lanes (doubles and 64-bit integers, one width),
// so that the compiler makes vector code of it: inlined into one function per instruction set below.
__attribute__((always_inline)) inline void inside_block(const double* M, double X0, double Y0, double W0, int bw,
                                                        double width, double height, std::int64_t* __restrict in) {
  // v + 1.5 * 2^52 - 1.5 * 2^52 is v rounded to nearest, ties to even, for |v| < 2^51 (cvtpd_epi32's
  // rounding); larger values, infinities and NaN stay outside the image, as OpenCV's saturated ones do.
  constexpr double kRound = 6755399441055744.0;
  const double m0 = M[0], m3 = M[3], m6 = M[6];
  for (int x1 = 0; x1 < bw; ++x1) {
    const double x = x1;
    const double w = m6 * x + W0;
    const double inverse = w != 0.0 ? 1.0 / w : 0.0;
    const double X = ((X0 + m0 * x) * inverse + kRound) - kRound;
    const double Y = ((Y0 + m3 * x) * inverse + kRound) - kRound;
    in[x1] = (X >= 0.0) & (X < width) & (Y >= 0.0) & (Y < height);
  }
}

#if defined(__x86_64__) || defined(__i386__)
#define SMSEG_INSIDE_BLOCK_ARGS                                                                            \
  const double *M, double X0, double Y0, double W0, int bw, double width, double height, std::int64_t *in
void inside_block_sse2(SMSEG_INSIDE_BLOCK_ARGS) { inside_block(M, X0, Y0, W0, bw, width, height, in); }
__attribute__((target("avx2"))) void inside_block_avx2(SMSEG_INSIDE_BLOCK_ARGS) {
  inside_block(M, X0, Y0, W0, bw, width, height, in);
}
__attribute__((target("avx512f"))) void inside_block_avx512(SMSEG_INSIDE_BLOCK_ARGS) {
  inside_block(M, X0, Y0, W0, bw, width, height, in);
}
#undef SMSEG_INSIDE_BLOCK_ARGS
#endif

}  // namespace

#if defined(__x86_64__) || defined(__i386__)
std::vector<InsideIsa> inside_isas() {
  std::vector<InsideIsa> isas{InsideIsa::Sse2};
  if (__builtin_cpu_supports("avx2")) isas.push_back(InsideIsa::Avx2);
  if (__builtin_cpu_supports("avx512f")) isas.push_back(InsideIsa::Avx512);
  return isas;
}
#else
std::vector<InsideIsa> inside_isas() { return {InsideIsa::Best}; }  // the compiler's own vectors elsewhere
#endif

void inside_row(const double* M, int y, int cols, int rows, std::uint8_t* out, InsideIsa isa) {
#if defined(__x86_64__) || defined(__i386__)
  static const InsideIsa best = inside_isas().back();
  const InsideIsa use = isa == InsideIsa::Best ? best : isa;
  const auto block = use == InsideIsa::Avx512 ? &inside_block_avx512
                     : use == InsideIsa::Avx2 ? &inside_block_avx2
                                              : &inside_block_sse2;
#else
  (void)isa;
  const auto block = &inside_block;
#endif
  // OpenCV's blocks: 16 rows (fewer in a shorter image) of 1024 / 16 columns (at most the image's).
  const int block_cols = std::min(1024 / std::min(16, rows), cols);
  std::int64_t in[1024];
  for (int xb = 0; xb < cols; xb += block_cols) {
    const int bw = std::min(block_cols, cols - xb);
    const double X0 = M[0] * xb + M[1] * y + M[2], Y0 = M[3] * xb + M[4] * y + M[5], W0 = M[6] * xb + M[7] * y + M[8];
    block(M, X0, Y0, W0, bw, cols, rows, in);
    for (int x1 = 0; x1 < bw; ++x1) out[xb + x1] = static_cast<std::uint8_t>(in[x1]);
  }
}

namespace {

// Four lanes in GCC / Clang vector extensions (SSE2 on any x86-64): comparisons and selects only, so
// every lane is what the one-at-a-time loops give. `select(m, a, b)`: a where m is all ones, else b.
typedef float V4f __attribute__((vector_size(16)));
typedef std::int32_t V4i __attribute__((vector_size(16)));
template <class V, class T>
V load(const T* p) {
  V v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <class T, class V>
void store(T* p, V v) {
  std::memcpy(p, &v, sizeof v);
}
inline V4f select(V4i m, V4f a, V4f b) { return (V4f)(((V4i)a & m) | ((V4i)b & ~m)); }  // casts keep the bits
inline V4i select(V4i m, V4i a, V4i b) { return (a & m) | (b & ~m); }

}  // namespace

// Four lanes at a time (the vector helpers above), then one at a time.
void best_plane(const float* in, int n, int p, float* b, int* k) {
  int x = 0;
  for (; x + 4 <= n; x += 4) {
    const V4i better = load<V4f>(in + x) > load<V4f>(b + x);
    store(b + x, select(better, load<V4f>(in + x), load<V4f>(b + x)));
    store(k + x, select(better, V4i{p, p, p, p}, load<V4i>(k + x)));
  }
  for (; x < n; ++x)
    if (in[x] > b[x]) {
      b[x] = in[x];
      k[x] = p;
    }
}

// The same.
void joint_best_plane(const float* s, const float* before, int n, int p, float* b, int* k, float* l, float* r,
                      float* w) {
  int x = 0;
  for (; x + 4 <= n; x += 4) {
    const V4f sv = load<V4f>(s + x), bv = load<V4f>(b + x), wv = load<V4f>(w + x);
    const V4i kv = load<V4i>(k + x);
    store(w + x, select(sv < wv, sv, wv));  // std::min(w, s)
    const V4i better = sv > bv;
    const V4i next = kv == (V4i{p, p, p, p} - 1);  // the plane after the best so far: its score is the right one
    store(b + x, select(better, sv, bv));
    store(l + x, select(better, load<V4f>(before + x), load<V4f>(l + x)));
    store(r + x, select(better, V4f{kNoScore, kNoScore, kNoScore, kNoScore}, select(next, sv, load<V4f>(r + x))));
    store(k + x, select(better, V4i{p, p, p, p}, kv));
  }
  for (; x < n; ++x) {
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

}  // namespace sweep_rows

namespace {

// Box means of a float image over the sweep window.
cv::Mat box_mean(const cv::Mat& m, int window) {
  cv::Mat out;
  cv::boxFilter(m, out, CV_32F, cv::Size(window, window), cv::Point(-1, -1), true, cv::BORDER_REFLECT);
  return out;
}

// The reference image's window statistics, computed once per frame.
struct ReferenceWindows {
  cv::Mat image, mean, stddev;  // CV_32F
};

ReferenceWindows reference_windows(const cv::Mat& gray, int window) {
  ReferenceWindows r;
  gray.convertTo(r.image, CV_32F);
  r.mean = box_mean(r.image, window);
  const cv::Mat mean_sq = box_mean(r.image.mul(r.image), window);
  r.stddev.create(gray.size(), CV_32F);
  for (int y = 0; y < gray.rows; ++y) {
    const float *m = r.mean.ptr<float>(y), *q = mean_sq.ptr<float>(y);
    float* s = r.stddev.ptr<float>(y);
    for (int x = 0; x < gray.cols; ++x) s[x] = std::sqrt(std::max(0.0f, q[x] - m[x] * m[x]));
  }
  return r;
}

// A neighbour prepared for warping: its float image and the reference-to-neighbour
// camera motion (X_n = R X_r + t).
struct PreparedView {
  cv::Mat image;
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
};

PreparedView prepare(const SweepView& v, const sequence::Pose& reference_pose) {
  PreparedView p;
  v.gray.convertTo(p.image, CV_32F);
  const Eigen::Matrix3d Rr = frontend::pose_rotation(reference_pose), Rn = frontend::pose_rotation(v.pose);
  p.R = Rn.transpose() * Rr;
  p.t = Rn.transpose() * (frontend::pose_centre(reference_pose) - frontend::pose_centre(v.pose));
  return p;
}

// ZNCC per pixel of the reference against the neighbour warped through the plane Z = depth of the
// reference camera; -1 where the window reaches outside the neighbour's image.
void plane_scores(const ReferenceWindows& ref, const PreparedView& v, const Eigen::Matrix3d& K, double depth,
                  int window, cv::Mat& score) {
  const Eigen::Matrix3d H = K * (v.R + v.t * Eigen::RowVector3d(0, 0, 1.0 / depth)) * K.inverse();
  cv::Matx33d Hcv;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Hcv(r, c) = H(r, c);
  cv::Mat warped, inside;
  // WARP_INVERSE_MAP: warped(x) = neighbour(H x), H taking reference pixels to neighbour pixels.
  cv::warpPerspective(v.image, warped, Hcv, ref.image.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                      cv::BORDER_REPLICATE);
  // Where the neighbour's pixel is: the nearest-neighbour warp of an image of ones, computed here
  // (sweep_rows::inside_row; the neighbour and the reference have one size).
  inside.create(ref.image.size(), CV_8UC1);
  for (int y = 0; y < inside.rows; ++y) sweep_rows::inside_row(Hcv.val, y, inside.cols, inside.rows, inside.ptr(y));
  cv::erode(inside, inside, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(window, window)), cv::Point(-1, -1), 1,
            cv::BORDER_CONSTANT, cv::Scalar(0));
  const cv::Mat mean = box_mean(warped, window);
  const cv::Mat mean_sq = box_mean(warped.mul(warped), window);
  const cv::Mat mean_cross = box_mean(warped.mul(ref.image), window);
  score.create(ref.image.size(), CV_32F);
  for (int y = 0; y < score.rows; ++y)
    sweep_rows::zncc(mean.ptr<float>(y), mean_sq.ptr<float>(y), mean_cross.ptr<float>(y), ref.mean.ptr<float>(y),
                     ref.stddev.ptr<float>(y), inside.ptr<std::uint8_t>(y), score.cols, score.ptr<float>(y));
}

// The best plane so far per pixel.
struct BestPlane {
  cv::Mat score, plane;  // CV_32F, CV_32S
  explicit BestPlane(cv::Size size)
      : score(size, CV_32F, cv::Scalar(-std::numeric_limits<float>::infinity())), plane(size, CV_32S, cv::Scalar(-1)) {}
  void update(const cv::Mat& s, int p) {
    for (int y = 0; y < s.rows; ++y)
      sweep_rows::best_plane(s.ptr<float>(y), s.cols, p, score.ptr<float>(y), plane.ptr<int>(y));
  }
};

using sweep_rows::kNoScore;

// The joint best plane, and the scores of the planes either side of it: a new best at p takes the
// previous plane's score as its left one; the plane after the best gives its right one.
// `worst` keeps the lowest score (how flat the scores are).
void update_joint(const cv::Mat& joint, const cv::Mat& previous, int p, BestPlane& best, cv::Mat& left, cv::Mat& right,
                  cv::Mat& worst) {
  for (int y = 0; y < joint.rows; ++y)
    sweep_rows::joint_best_plane(joint.ptr<float>(y), previous.ptr<float>(y), joint.cols, p, best.score.ptr<float>(y),
                                 best.plane.ptr<int>(y), left.ptr<float>(y), right.ptr<float>(y),
                                 worst.ptr<float>(y));
}

}  // namespace

void PlaneSweepOptions::validate() const {
  if (!(max_step_px > 0)) throw Error("", "plane_sweep.max_step_px", "must be > 0");
  if (min_planes < 3 || max_planes > 4096 || max_planes < min_planes)
    throw Error("", "plane_sweep.max_planes", "needs 3 <= min_planes <= max_planes <= 4096");
  if (!(min_depth > 0) || !(max_depth > min_depth))
    throw Error("", "plane_sweep.min_depth", "needs 0 < min_depth < max_depth");
  if (window < 3 || window % 2 == 0 || window > 31) throw Error("", "plane_sweep.window", "must be odd, 3..31");
  if (!(min_score >= -1 && min_score <= 1)) throw Error("", "plane_sweep.min_score", "must be in [-1, 1]");
  if (!(min_texture >= 0)) throw Error("", "plane_sweep.min_texture", "must be >= 0");
  if (!(min_score_range >= 0 && min_score_range <= 2))
    throw Error("", "plane_sweep.min_score_range", "must be in [0, 2]");
  if (consistency_planes < 0) throw Error("", "plane_sweep.consistency_planes", "must be >= 0");
  if (!(scale >= 0.1 && scale <= 1)) throw Error("", "plane_sweep.scale", "must be in 0.1..1");
}

int sweep_plane_count(const sequence::Pose& reference_pose, const std::vector<SweepView>& neighbours, double focal,
                      const PlaneSweepOptions& o) {
  double baseline = 0;
  for (const auto& v : neighbours)
    baseline = std::max(baseline, (frontend::pose_centre(v.pose) - frontend::pose_centre(reference_pose)).norm());
  const double span_px = focal * baseline * (1.0 / o.min_depth - 1.0 / o.max_depth);
  const double wanted = std::ceil(span_px / o.max_step_px) + 1;
  return static_cast<int>(std::clamp(wanted, double(o.min_planes), double(o.max_planes)));
}

namespace {

// The sweep at the images' own resolution (scale ignored).
cv::Mat sweep_at_own_resolution(const cv::Mat& reference_gray, const sequence::Pose& reference_pose,
                                const std::vector<SweepView>& neighbours, const sequence::Calibration& camera,
                                const PlaneSweepOptions& o) {
  cv::Mat depth(reference_gray.size(), CV_32FC1, cv::Scalar(0));
  if (neighbours.size() < 2) return depth;  // no consistency check possible: nothing is trusted

  const ReferenceWindows ref = reference_windows(reference_gray, o.window);
  std::vector<PreparedView> views;
  for (const auto& v : neighbours) views.push_back(prepare(v, reference_pose));
  const double fx = *camera.fx, fy = camera.fy.value_or(fx);
  Eigen::Matrix3d K;
  K << fx, 0, camera.cx, 0, fy, camera.cy, 0, 0, 1;

  const double near_inv = 1.0 / o.min_depth, far_inv = 1.0 / o.max_depth;
  const int planes = sweep_plane_count(reference_pose, neighbours, fx, o);
  const double step = (near_inv - far_inv) / (planes - 1);
  BestPlane best_joint(reference_gray.size());  // the mean score over the neighbours
  std::vector<BestPlane> best_own(views.size(), BestPlane(reference_gray.size()));
  // The mean scores of the planes either side of the joint best (for the parabola), kept as the sweep
  // goes so that no cost volume is held.
  cv::Mat left(reference_gray.size(), CV_32F, cv::Scalar(kNoScore)), right = left.clone();
  cv::Mat worst(reference_gray.size(), CV_32F, cv::Scalar(1));
  cv::Mat score, joint(reference_gray.size(), CV_32F), previous(reference_gray.size(), CV_32F, cv::Scalar(kNoScore));
  for (int p = 0; p < planes; ++p) {
    const double depth_p = 1.0 / (far_inv + p * step);
    joint.setTo(0);
    for (std::size_t n = 0; n < views.size(); ++n) {
      plane_scores(ref, views[n], K, depth_p, o.window, score);
      best_own[n].update(score, p);
      joint += score;
    }
    joint /= static_cast<double>(views.size());
    update_joint(joint, previous, p, best_joint, left, right, worst);
    std::swap(joint, previous);
  }

  for (int y = 0; y < depth.rows; ++y) {
    float* out = depth.ptr<float>(y);
    const float* texture = ref.stddev.ptr<float>(y);
    for (int x = 0; x < depth.cols; ++x) {
      const int p = best_joint.plane.at<int>(y, x);
      const float best = best_joint.score.at<float>(y, x);
      if (p < 0 || best < o.min_score || texture[x] < o.min_texture) continue;
      if (best - worst.at<float>(y, x) < o.min_score_range) continue;  // no parallax: every plane fits
      bool agree = true;
      for (const auto& b : best_own) agree = agree && std::abs(b.plane.at<int>(y, x) - p) <= o.consistency_planes;
      if (!agree) continue;
      // Between planes: the vertex of the parabola through the best plane and its two neighbours.
      double offset = 0;
      const double a = left.at<float>(y, x), b = best_joint.score.at<float>(y, x), c = right.at<float>(y, x);
      const double curvature = a - 2 * b + c;
      if (a != kNoScore && c != kNoScore && curvature < 0) offset = std::clamp(0.5 * (a - c) / curvature, -0.5, 0.5);
      out[x] = static_cast<float>(1.0 / (far_inv + (p + offset) * step));
    }
  }
  return depth;
}

// `depth` brought to `size`: bilinear where the four source pixels around a pixel all have a depth,
// else the nearest source pixel's depth (0 stays "none").
cv::Mat depth_to_size(const cv::Mat& depth, cv::Size size) {
  cv::Mat valid, smooth, nearest, all_valid;
  cv::threshold(depth, valid, 0, 1, cv::THRESH_BINARY);
  cv::resize(depth, smooth, size, 0, 0, cv::INTER_LINEAR);
  cv::resize(valid, all_valid, size, 0, 0, cv::INTER_LINEAR);
  cv::resize(depth, nearest, size, 0, 0, cv::INTER_NEAREST);
  // A bilinear weight sum of exactly 1 means every contributing source pixel was valid.
  cv::Mat mixed = cv::Mat(all_valid < 1.0f - 1e-6f);
  nearest.copyTo(smooth, mixed);
  return smooth;
}

// The sweep of images shrunk to `small` (area averaging), the camera scaled with them, its depth
// brought back to the reference's size.
cv::Mat sweep_shrunk(const cv::Mat& reference_gray, const sequence::Pose& reference_pose,
                     const std::vector<SweepView>& neighbours, const sequence::Calibration& camera,
                     const PlaneSweepOptions& o, cv::Size small) {
  const cv::Size full = reference_gray.size();
  const auto shrink = [&](const cv::Mat& gray) {
    cv::Mat out;
    cv::resize(gray, out, small, 0, 0, cv::INTER_AREA);
    return out;
  };
  std::vector<SweepView> small_views;
  for (const auto& v : neighbours) small_views.push_back({shrink(v.gray), v.pose});
  // Pixel centres map as (x + 0.5) * s - 0.5 under the resize.
  const double sx = double(small.width) / full.width, sy = double(small.height) / full.height;
  sequence::Calibration small_camera = camera;
  small_camera.fx = *camera.fx * sx;
  small_camera.fy = camera.fy.value_or(*camera.fx) * sy;
  small_camera.cx = (camera.cx + 0.5) * sx - 0.5;
  small_camera.cy = (camera.cy + 0.5) * sy - 0.5;
  const cv::Mat depth = sweep_at_own_resolution(shrink(reference_gray), reference_pose, small_views, small_camera, o);
  return depth_to_size(depth, full);
}

}  // namespace

cv::Mat plane_sweep_depth(const cv::Mat& reference_gray, const sequence::Pose& reference_pose,
                          const std::vector<SweepView>& neighbours, const sequence::Calibration& camera,
                          const PlaneSweepOptions& o) {
  o.validate();
  if (!camera.fx || !(*camera.fx > 0)) throw Error("", "plane_sweep", "the camera needs a focal length");
  if (reference_gray.empty() || reference_gray.type() != CV_8UC1)
    throw Error("", "plane_sweep", "the reference image must be a non-empty 8-bit grey image");
  for (const auto& v : neighbours)
    if (v.gray.size() != reference_gray.size() || v.gray.type() != CV_8UC1)
      throw Error("", "plane_sweep", "every neighbour image must be 8-bit grey of the reference's size");
  const cv::Size full = reference_gray.size();
  const cv::Size small(std::max(1, int(std::lround(full.width * o.scale))),
                       std::max(1, int(std::lround(full.height * o.scale))));
  if (small == full) return sweep_at_own_resolution(reference_gray, reference_pose, neighbours, camera, o);
  return sweep_shrunk(reference_gray, reference_pose, neighbours, camera, o, small);
}

std::vector<int> sweep_neighbours(int f, const std::vector<bool>& usable, const std::vector<sequence::Pose>& poses,
                                  const SweepNeighbourOptions& o) {
  const int n = static_cast<int>(usable.size());
  if (f < 0 || f >= n || !usable[f] || static_cast<int>(poses.size()) != n) return {};
  const auto baseline = [&](int g) { return (frontend::pose_centre(poses[g]) - frontend::pose_centre(poses[f])).norm(); };
  // Per side: the nearest frame at least target_baseline away, else the widest at least min_baseline.
  const auto pick = [&](int dir) {
    int widest = -1;
    for (int k = 1; k <= o.reach; ++k) {
      const int g = f + dir * k;
      if (g < 0 || g >= n || !usable[g] || baseline(g) < o.min_baseline) continue;
      if (baseline(g) >= o.target_baseline) return g;
      if (widest < 0 || baseline(g) > baseline(widest)) widest = g;
    }
    return widest;
  };
  const int before = pick(-1), after = pick(1);
  if (before >= 0 && after >= 0) return {before, after};
  // One side only (the ends of the sequence): that side's pick and the next qualifying frame beyond
  // it, else the nearest qualifying one before it.
  const int dir = before >= 0 ? -1 : 1, first = before >= 0 ? before : after;
  if (first < 0) return {};
  int second = -1;
  for (int g = first + dir; second < 0 && std::abs(g - f) <= o.reach && g >= 0 && g < n; g += dir)
    if (usable[g] && baseline(g) >= o.min_baseline) second = g;
  for (int g = f + dir; second < 0 && g != first; g += dir)
    if (usable[g] && baseline(g) >= o.min_baseline) second = g;
  if (second < 0) return {};
  return {first, second};
}

}  // namespace smseg::stacks
