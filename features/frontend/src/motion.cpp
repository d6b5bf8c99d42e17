#include "smseg/frontend/motion.hpp"
#include "smseg/frontend/trajectory.hpp"

#include "pair_motion.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace smseg::frontend {

namespace {

// splitmix64: a small, well-mixed generator whose stream depends only on (seed, stream).
struct SplitMix {
  std::uint64_t s;
  std::uint64_t next() {
    std::uint64_t z = (s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  int below(int n) { return static_cast<int>(next() % static_cast<std::uint64_t>(n)); }
};

std::uint64_t mix(std::uint64_t seed, std::uint64_t stream) {
  SplitMix a{seed ^ 0x5851f42d4c957f2dULL};
  const std::uint64_t h = a.next();
  SplitMix b{h ^ (stream * 0xd1342543de82ef95ULL + 0x632be59bd9b4e019ULL)};
  return b.next();
}

Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& M) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d V = svd.matrixV();
  if ((U * V.transpose()).determinant() < 0) U.col(2) *= -1;
  return U * V.transpose();
}


// Inliers of m over all correspondences under the depth-scaled threshold; returns count and SSE.
int count_inliers(const RigidMotion& m, const std::vector<Eigen::Vector3d>& p, const std::vector<Eigen::Vector3d>& q,
                  const std::vector<double>& thr2, std::vector<std::uint8_t>* mask, double* sse) {
  int n = 0;
  double s = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double r2 = (m.apply(p[i]) - q[i]).squaredNorm();
    const bool in = r2 <= thr2[i];
    if (mask) (*mask)[i] = in ? 1 : 0;
    if (in) ++n, s += r2;
  }
  if (sse) *sse = s;
  return n;
}


Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

Eigen::Matrix3d exp_so3(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a < 1e-12) return nearest_rotation(Eigen::Matrix3d::Identity() + skew(w));
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

// d(u, v, d)/dY of the stereo projection at Y (camera frame, Y.z() > 0).
Eigen::Matrix3d projection_jacobian(const StereoCamera& c, const Eigen::Vector3d& Y) {
  const double iz = 1.0 / Y.z(), iz2 = iz * iz;
  Eigen::Matrix3d J;
  J << c.fx * iz, 0, -c.fx * Y.x() * iz2, 0, c.fy * iz, -c.fy * Y.y() * iz2, 0, 0, -c.fx * c.baseline * iz2;
  return J;
}

constexpr double kMinDepth = 1e-3;  // metres: points behind or at the camera give no residual

// Symmetric reprojection residuals of one correspondence under M (X_b = R X_a + T); false when a
// moved point falls behind a camera. r_fwd: frame a's point in frame b; r_bwd: frame b's point in a.
bool symmetric_residuals(const RigidMotion& M, const Eigen::Vector3d& Xa, const Eigen::Vector3d& Xb,
                         const Eigen::Vector3d& ma, const Eigen::Vector3d& mb, const StereoCamera& c,
                         Eigen::Vector3d& r_fwd, Eigen::Vector3d& r_bwd, Eigen::Vector3d& Y, Eigen::Vector3d& Z) {
  Y = M.R * Xa + M.t;
  Z = M.R.transpose() * (Xb - M.t);
  if (Y.z() < kMinDepth || Z.z() < kMinDepth) return false;
  r_fwd = c.project(Y) - mb;
  r_bwd = c.project(Z) - ma;
  return true;
}

double huber_weight(double r, double k) { return r <= k ? 1.0 : k / r; }

}  // namespace

RigidMotion fit_rigid(const std::vector<Eigen::Vector3d>& p, const std::vector<Eigen::Vector3d>& q) {
  if (p.size() != q.size()) throw Error("", "points", "fit_rigid needs as many target points as source points");
  if (p.empty()) throw Error("", "points", "fit_rigid needs at least one correspondence");
  const double n = static_cast<double>(p.size());
  Eigen::Vector3d pm = Eigen::Vector3d::Zero(), qm = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < p.size(); ++i) pm += p[i], qm += q[i];
  pm /= n;
  qm /= n;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < p.size(); ++i) H += (p[i] - pm) * (q[i] - qm).transpose();
  RigidMotion m;
  if (H.cwiseAbs().maxCoeff() > 0) {
    // H = U S V^T, R = V U^T; a reflection (det -1) is fixed by flipping V's last column (Arun 1987,
    // Umeyama 1991).
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Matrix3d U = svd.matrixU();
    Eigen::Matrix3d V = svd.matrixV();
    if ((V * U.transpose()).determinant() < 0) V.col(2) *= -1;
    m.R = V * U.transpose();
  }
  if (!m.R.allFinite()) m.R.setIdentity();
  m.t = qm - m.R * pm;
  return m;
}

void RansacOptions::validate() const {
  auto bad = [](const char* f, const std::string& why) { throw Error("", std::string("motion.") + f, why); };
  if (max_iterations < 1) bad("max_iterations", "must be >= 1");
  if (!(confidence > 0 && confidence < 1)) bad("confidence", "must be in (0, 1)");
  if (!(inlier_threshold > 0)) bad("inlier_threshold", "must be > 0 (metres)");
  if (!(reference_depth > 0)) bad("reference_depth", "must be > 0 (metres)");
  if (!(depth_exponent >= 0 && depth_exponent <= 4)) bad("depth_exponent", "must be in 0..4");
  if (min_inliers < 3) bad("min_inliers", "must be >= 3");
  if (!(min_inlier_ratio >= 0 && min_inlier_ratio <= 1)) bad("min_inlier_ratio", "must be in 0..1");
}

namespace {

/// Squared inlier threshold per correspondence: the threshold grows with the depth past reference_depth.
std::vector<double> inlier_thresholds2(const std::vector<Eigen::Vector3d>& p, const RansacOptions& o) {
  std::vector<double> thr2(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double scale = std::pow(std::max(1.0, p[i].z() / o.reference_depth), o.depth_exponent);
    const double t = o.inlier_threshold * scale;
    thr2[i] = t * t;
  }
  return thr2;
}

/// A motion, its inlier count (-1: none fitted) and the inliers' summed squared error.
struct Hypothesis {
  RigidMotion motion;
  int inliers = -1;
  double sse = std::numeric_limits<double>::infinity();
};

/// Three distinct indices below n.
std::array<int, 3> draw_three(SplitMix& rng, int n) {
  const int a = rng.below(n);
  int b = rng.below(n - 1);
  if (b >= a) ++b;
  int c = rng.below(n - 2);
  if (c >= std::min(a, b)) ++c;
  if (c >= std::max(a, b)) ++c;
  return {a, b, c};
}

/// RANSAC over minimal samples of three: the hypothesis with the most inliers (then the least error),
/// drawing until the confidence is reached (at most max_iterations non-degenerate samples).
Hypothesis ransac_motion(const std::vector<Eigen::Vector3d>& p, const std::vector<Eigen::Vector3d>& q,
                         const std::vector<double>& thr2, const RansacOptions& o, std::uint64_t stream) {
  const int n = static_cast<int>(p.size());
  SplitMix rng{mix(o.seed, stream)};
  Hypothesis best;
  long needed = o.max_iterations;
  std::vector<Eigen::Vector3d> sp(3), sq(3);
  int drawn = 0, attempts = 0;
  while (drawn < needed && attempts < 10 * o.max_iterations) {
    ++attempts;
    const auto [a, b, c] = draw_three(rng, n);
    sp = {p[a], p[b], p[c]};
    sq = {q[a], q[b], q[c]};
    // Degenerate samples (collinear or coincident points) do not define a rotation.
    if ((sp[1] - sp[0]).cross(sp[2] - sp[0]).norm() < 1e-8 || (sq[1] - sq[0]).cross(sq[2] - sq[0]).norm() < 1e-8)
      continue;
    ++drawn;
    const RigidMotion m = fit_rigid(sp, sq);
    double sse = 0;
    const int k = count_inliers(m, p, q, thr2, nullptr, &sse);
    if (!(k > best.inliers || (k == best.inliers && sse < best.sse))) continue;
    best = {m, k, sse};
    const double w = static_cast<double>(k) / n;
    if (w >= 1.0) {
      needed = drawn;
    } else if (w > 0) {
      const double denom = std::log(1.0 - w * w * w);
      if (denom < 0) {
        const double it = std::ceil(std::log(1.0 - o.confidence) / denom);
        needed = std::min<long>(o.max_iterations, static_cast<long>(std::max(1.0, it)));
      }
    }
  }
  return best;
}

/// Refits best on its inliers until the inlier set stops growing; its inlier mask into mask.
void refit_on_inliers(const std::vector<Eigen::Vector3d>& p, const std::vector<Eigen::Vector3d>& q,
                      const std::vector<double>& thr2, Hypothesis& best, std::vector<std::uint8_t>& mask) {
  const int n = static_cast<int>(p.size());
  mask.assign(n, 0);
  best.inliers = count_inliers(best.motion, p, q, thr2, &mask, &best.sse);
  for (int round = 0; round < 5 && best.inliers >= 3; ++round) {
    std::vector<Eigen::Vector3d> ip, iq;
    for (int i = 0; i < n; ++i)
      if (mask[i]) ip.push_back(p[i]), iq.push_back(q[i]);
    const RigidMotion refit = fit_rigid(ip, iq);
    std::vector<std::uint8_t> mask2(n);
    double sse2 = 0;
    const int k2 = count_inliers(refit, p, q, thr2, &mask2, &sse2);
    if (k2 < best.inliers || (k2 == best.inliers && sse2 >= best.sse)) break;
    best = {refit, k2, sse2};
    mask.swap(mask2);
  }
}

}  // namespace

MotionEstimate estimate_motion(const std::vector<Eigen::Vector3d>& p, const std::vector<Eigen::Vector3d>& q,
                               const RansacOptions& o, std::uint64_t stream) {
  if (p.size() != q.size()) throw Error("", "points", "estimate_motion needs as many target points as source points");
  MotionEstimate est;
  const int n = static_cast<int>(p.size());
  est.points = n;
  est.inlier_mask.assign(n, 0);
  if (n < 3) return est;
  const std::vector<double> thr2 = inlier_thresholds2(p, o);
  Hypothesis best = ransac_motion(p, q, thr2, o, stream);
  if (best.inliers < 0) best.motion = fit_rigid(p, q);  // every sample degenerate: the least-squares fit of all
  std::vector<std::uint8_t> mask;
  refit_on_inliers(p, q, thr2, best, mask);
  const int k = best.inliers;
  est.motion = best.motion;
  est.inliers = k;
  est.inlier_mask = std::move(mask);
  est.rms = k > 0 ? std::sqrt(best.sse / k) : 0;
  est.ok = k >= o.min_inliers && k >= o.min_inlier_ratio * n;
  return est;
}

StereoCamera StereoCamera::from(const sequence::Calibration& calib) {
  if (!calib.fx || !(*calib.fx > 0)) throw Error("", "calibration.fx", "the stereo camera needs the focal length");
  if (!calib.baseline || !(*calib.baseline > 0))
    throw Error("", "calibration.baseline", "the stereo camera needs the baseline");
  StereoCamera c;
  c.fx = *calib.fx;
  c.fy = calib.fy.value_or(c.fx);
  c.cx = calib.cx;
  c.cy = calib.cy;
  c.baseline = *calib.baseline;
  return c;
}

Eigen::Vector3d StereoCamera::project(const Eigen::Vector3d& X) const {
  const double iz = 1.0 / X.z();
  return {fx * X.x() * iz + cx, fy * X.y() * iz + cy, fx * baseline * iz};
}

Eigen::Vector3d StereoCamera::backproject(const Eigen::Vector3d& uvd) const {
  const double z = fx * baseline / uvd.z();
  return {(uvd.x() - cx) * z / fx, (uvd.y() - cy) * z / fy, z};
}

void RefineOptions::validate() const {
  auto bad = [](const char* f, const std::string& why) { throw Error("", std::string("refine.") + f, why); };
  if (iterations < 1 || iterations > 1000) bad("iterations", "must be in 1..1000");
  if (!(huber_px > 0)) bad("huber_px", "must be > 0 (pixels)");
  if (!(inlier_px > 0)) bad("inlier_px", "must be > 0 (pixels)");
  if (!(disparity_weight >= 0) || !std::isfinite(disparity_weight)) bad("disparity_weight", "must be >= 0");
  if (!(second_min_share >= 0 && second_min_share <= 1)) bad("second_min_share", "must be in 0..1");
}

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// The stereo measurements (u, v, d) of the correspondences in frames a and b, their back-projections,
/// and which of them are usable (positive, finite disparities in both frames and not left out by `use`).
struct StereoPairs {
  const std::vector<Eigen::Vector3d>& uvd_a;
  const std::vector<Eigen::Vector3d>& uvd_b;
  const StereoCamera& cam;
  const RefineOptions& o;
  const std::vector<std::uint8_t>& use;
  int n;
  std::vector<Eigen::Vector3d> Xa, Xb;
  std::vector<std::uint8_t> valid;
  Eigen::Vector3d Dw;  ///< residual weights: the disparity residual by disparity_weight

  StereoPairs(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b, const StereoCamera& c,
              const RefineOptions& opts, const std::vector<std::uint8_t>& used)
      : uvd_a(a), uvd_b(b), cam(c), o(opts), use(used), n(static_cast<int>(a.size())), Xa(n), Xb(n), valid(n, 0),
        Dw(1, 1, opts.disparity_weight) {
    for (int i = 0; i < n; ++i) {
      if (!(uvd_a[i].z() > 0) || !(uvd_b[i].z() > 0) || !uvd_a[i].allFinite() || !uvd_b[i].allFinite()) continue;
      Xa[i] = cam.backproject(uvd_a[i]);
      Xb[i] = cam.backproject(uvd_b[i]);
      valid[i] = 1;
    }
  }

  /// Weighted symmetric residuals of correspondence i under M; false when a point falls behind a camera.
  bool residuals(const RigidMotion& M, int i, Eigen::Vector3d& rf, Eigen::Vector3d& rb, Eigen::Vector3d& Y,
                 Eigen::Vector3d& Z) const {
    if (!symmetric_residuals(M, Xa[i], Xb[i], uvd_a[i], uvd_b[i], cam, rf, rb, Y, Z)) return false;
    rf = rf.cwiseProduct(Dw);
    rb = rb.cwiseProduct(Dw);
    return true;
  }

  /// Adds correspondence i's Huber-weighted Gauss-Newton terms to H and g.
  void add_normal_equations(const RigidMotion& M, int i, const Eigen::Vector3d& rf, const Eigen::Vector3d& rb,
                            const Eigen::Vector3d& Y, const Eigen::Vector3d& Z, Matrix6d& H, Vector6d& g) const {
    Eigen::Matrix<double, 3, 6> Jf, Jb;
    Jf.leftCols<3>() = -skew(Y);
    Jf.rightCols<3>().setIdentity();
    Jf = Dw.asDiagonal() * projection_jacobian(cam, Y) * Jf;
    const Eigen::Matrix3d Rt = M.R.transpose();
    Jb.leftCols<3>() = Rt * skew(Xb[i]);
    Jb.rightCols<3>() = -Rt;
    Jb = Dw.asDiagonal() * projection_jacobian(cam, Z) * Jb;
    const double wf = huber_weight(rf.norm(), o.huber_px), wb = huber_weight(rb.norm(), o.huber_px);
    H += wf * Jf.transpose() * Jf + wb * Jb.transpose() * Jb;
    g += wf * Jf.transpose() * rf + wb * Jb.transpose() * rb;
  }

  /// Robust cost of M over the used correspondences; optionally the normal equations and how many
  /// correspondences counted.
  double cost(const RigidMotion& M, Matrix6d* H, Vector6d* g, int* used) const {
    double cost = 0;
    int k = 0;
    if (H) H->setZero(), g->setZero();
    for (int i = 0; i < n; ++i) {
      if (!valid[i] || (!use.empty() && !use[i])) continue;
      Eigen::Vector3d rf, rb, Y, Z;
      if (!residuals(M, i, rf, rb, Y, Z)) {
        cost += 2 * o.huber_px * o.huber_px * 10;  // behind a camera: a large constant penalty
        continue;
      }
      ++k;
      const double nf = rf.norm(), nb = rb.norm();
      for (double r : {nf, nb}) cost += r <= o.huber_px ? 0.5 * r * r : o.huber_px * (r - 0.5 * o.huber_px);
      if (H) add_normal_equations(M, i, rf, rb, Y, Z, *H, *g);
    }
    if (used) *used = k;
    return cost;
  }

  /// The correspondences whose weighted residuals are within inlier_px both ways, and their RMS.
  void inliers_and_rms(const RigidMotion& M, std::vector<std::uint8_t>* inliers, double* rms_px) const {
    if (inliers) inliers->assign(n, 0);
    double sse = 0;
    int k = 0;
    const double thr = o.inlier_px;
    for (int i = 0; i < n; ++i) {
      if (!valid[i]) continue;
      Eigen::Vector3d rf, rb, Y, Z;
      if (!residuals(M, i, rf, rb, Y, Z)) continue;
      if (rf.norm() > thr || rb.norm() > thr) continue;
      if (inliers) (*inliers)[i] = 1;
      sse += 0.5 * (rf.squaredNorm() + rb.squaredNorm());
      ++k;
    }
    if (rms_px) *rms_px = k > 0 ? std::sqrt(sse / k) : 0;
  }
};

/// One Levenberg-Marquardt iteration from M (whose cost and normal equations are given): up to 8 damped
/// steps until one does not raise the cost (then M and lambda updated, and converged set when the step
/// or the gain is negligible); false when none did.
bool lm_step(const StereoPairs& pairs, const Matrix6d& H, const Vector6d& g, double cost, RigidMotion& M,
             double& lambda, bool& converged) {
  for (int tries = 0; tries < 8; ++tries) {
    Matrix6d A = H;
    A.diagonal() += lambda * (H.diagonal().array() + 1e-9).matrix();
    const Vector6d delta = A.ldlt().solve(-g);
    if (!delta.allFinite()) {
      lambda *= 10;
      continue;
    }
    const Eigen::Matrix3d dR = exp_so3(delta.head<3>());
    RigidMotion C;
    C.R = nearest_rotation(dR * M.R);
    C.t = dR * M.t + delta.tail<3>();
    const double c2 = pairs.cost(C, nullptr, nullptr, nullptr);
    if (c2 <= cost) {
      converged = delta.norm() < 1e-10 || cost - c2 < 1e-12 * std::max(1.0, cost);
      M = C;
      lambda = std::max(1e-9, lambda / 3);
      return true;
    }
    lambda *= 4;
  }
  return false;
}

}  // namespace

RigidMotion refine_motion(const RigidMotion& initial, const std::vector<Eigen::Vector3d>& uvd_a,
                          const std::vector<Eigen::Vector3d>& uvd_b, const StereoCamera& cam,
                          const RefineOptions& o, const std::vector<std::uint8_t>& use,
                          std::vector<std::uint8_t>* inliers, double* rms_px) {
  if (uvd_a.size() != uvd_b.size() || (!use.empty() && use.size() != uvd_a.size()))
    throw Error("", "points", "refine_motion needs as many measurements in both frames (and flags)");
  const StereoPairs pairs(uvd_a, uvd_b, cam, o, use);
  RigidMotion M = initial;
  Matrix6d H;
  Vector6d g;
  int used = 0;
  double cost = pairs.cost(M, &H, &g, &used);
  if (used >= 3) {
    double lambda = 1e-4;
    for (int it = 0; it < o.iterations; ++it) {
      bool converged = false;
      if (!lm_step(pairs, H, g, cost, M, lambda, converged)) break;
      if (converged) it = o.iterations;
      cost = pairs.cost(M, &H, &g, &used);
    }
  }
  if (inliers || rms_px) pairs.inliers_and_rms(M, inliers, rms_px);
  return M;
}

sequence::Pose initial_pose(double camera_height) {
  sequence::Pose p;
  p.R = {-1, 0, 0, 0, -1, 0, 0, 0, 1};
  p.t = {0, camera_height, 0};
  return p;
}

namespace detail {

PathChain::PathChain(double camera_height)
    : first_(initial_pose(camera_height)), Rw_(pose_rotation(first_)), c_(first_.t[0], first_.t[1], first_.t[2]) {}

sequence::Pose PathChain::step(PairMotion& pm) {
  if (pm.ok && pm.motion.R.allFinite() && pm.motion.t.allFinite()) {
    pm.bridged = false;
    last_good_ = pm.motion;
  } else {
    pm.ok = false;
    pm.bridged = true;
    pm.motion = last_good_;  // constant velocity
  }
  Rw_ = nearest_rotation(Rw_ * pm.motion.R.transpose());
  c_ = c_ - Rw_ * pm.motion.t;
  return make_pose(Rw_, c_);
}

}  // namespace detail

std::vector<sequence::Pose> chain_poses(std::vector<PairMotion>& pairs, double camera_height) {
  detail::PathChain chain(camera_height);
  std::vector<sequence::Pose> poses;
  poses.reserve(pairs.size() + 1);
  poses.push_back(chain.first());
  for (auto& pm : pairs) poses.push_back(chain.step(pm));
  return poses;
}

namespace detail {

std::vector<PairData> gather_pairs(const std::vector<Track>& tracks, int first_frame, int npairs, bool measurements) {
  std::vector<PairData> d(npairs);
  for (const auto& tr : tracks) {
    for (std::size_t k = 0; k + 1 < tr.size(); ++k) {
      if (tr.frames[k + 1] != tr.frames[k] + 1) continue;
      const int pair = tr.frames[k] - first_frame;
      if (pair < 0 || pair >= npairs) continue;
      d[pair].P.push_back(tr.points[k]);
      d[pair].Q.push_back(tr.points[k + 1]);
      if (measurements) {
        d[pair].ma.emplace_back(tr.pixels[k].x, tr.pixels[k].y, tr.disparities[k]);
        d[pair].mb.emplace_back(tr.pixels[k + 1].x, tr.pixels[k + 1].y, tr.disparities[k + 1]);
      }
    }
  }
  return d;
}

Candidate solve_pair(const PairData& d, const std::vector<int>& subset, const RansacOptions& o, std::uint64_t stream,
                     const StereoCamera* cam, const RefineOptions* ro) {
  const int n_all = static_cast<int>(d.P.size());
  std::vector<Eigen::Vector3d> P, Q, ma, mb;
  for (int i : subset) {
    P.push_back(d.P[i]), Q.push_back(d.Q[i]);
    if (cam) ma.push_back(d.ma[i]), mb.push_back(d.mb[i]);
  }
  const MotionEstimate e = estimate_motion(P, Q, o, stream);
  Candidate c;
  c.pm.motion = e.motion;
  c.pm.points = n_all;
  c.pm.inliers = e.inliers;
  c.pm.ok = e.ok;
  c.pm.rms = e.rms;
  c.inliers.assign(n_all, 0);
  for (std::size_t j = 0; j < subset.size(); ++j) c.inliers[subset[j]] = e.inlier_mask[j];
  if (!cam || !e.ok) return c;
  // Stage 2: reprojection refinement from the RANSAC motion and its inliers, then inliers by
  // reprojection error over the subset, refined again.
  std::vector<std::uint8_t> in;
  double rms_px = 0;
  RigidMotion m = refine_motion(e.motion, ma, mb, *cam, *ro, e.inlier_mask, &in, &rms_px);
  for (int round = 0; round < 2; ++round) m = refine_motion(m, ma, mb, *cam, *ro, in, &in, &rms_px);
  int k_in = 0;
  double sse = 0;
  for (std::size_t i = 0; i < in.size(); ++i)
    if (in[i]) ++k_in, sse += (m.apply(P[i]) - Q[i]).squaredNorm();
  if (k_in >= o.min_inliers && k_in >= o.min_inlier_ratio * static_cast<double>(subset.size())) {
    c.pm.motion = m;
    c.pm.inliers = k_in;
    c.pm.rms = std::sqrt(sse / k_in);
    c.pm.rms_px = rms_px;
    c.inliers.assign(n_all, 0);
    for (std::size_t j = 0; j < subset.size(); ++j) c.inliers[subset[j]] = in[j];
  }
  return c;
}

// Distance between two motions for the constant-velocity choice: metres plus rotation angle in
// radians times 1 m.
double motion_distance(const RigidMotion& a, const RigidMotion& b) {
  const double cosang = std::clamp(((a.R.transpose() * b.R).trace() - 1) / 2, -1.0, 1.0);
  return (a.t - b.t).norm() + std::acos(cosang);
}

std::vector<Candidate> pair_candidates(const PairData& d, std::uint64_t stream, const RansacOptions& o,
                                       const StereoCamera* cam, const RefineOptions* ro) {
  const bool refine = cam && ro && ro->enabled;
  const bool second = refine && ro->second_hypothesis;
  const int n = static_cast<int>(d.P.size());
  std::vector<int> all(n);
  for (int i = 0; i < n; ++i) all[i] = i;
  std::vector<Candidate> cands;
  cands.push_back(solve_pair(d, all, o, stream, refine ? cam : nullptr, ro));
  const Candidate& a = cands[0];
  if (!second || !a.pm.ok) return cands;
  // A second motion among the first one's outliers: with an independently moving object (a person
  // filling the view) the largest rigid set may be the object, not the scene.
  std::vector<int> rest;
  for (int i = 0; i < n; ++i)
    if (!a.inliers[i]) rest.push_back(i);
  const double need = std::max<double>(o.min_inliers, ro->second_min_share * n);
  if (static_cast<double>(rest.size()) < need) return cands;
  Candidate b = solve_pair(d, rest, o, stream + (1ULL << 40), cam, ro);
  if (b.pm.ok && b.pm.inliers >= need) cands.push_back(std::move(b));
  return cands;
}

namespace {

// With second_hypothesis, one more candidate: the refinement started from the previous chosen motion,
// on the correspondences it already explains within 3 inlier_px (the scene, when a moving object
// holds most of the points).
std::optional<Candidate> candidate_from_previous(const PairData& d, const RigidMotion& previous, const RansacOptions& o,
                                                 const StereoCamera& cam, const RefineOptions& ro) {
  const int n = static_cast<int>(d.P.size());
  std::vector<std::uint8_t> loose(n, 0);
  const Eigen::Vector3d Dw(1, 1, ro.disparity_weight);
  int n_loose = 0;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d rf, rb, Y, Z;
    if (!(d.ma[i].z() > 0) || !(d.mb[i].z() > 0)) continue;
    if (!symmetric_residuals(previous, cam.backproject(d.ma[i]), cam.backproject(d.mb[i]), d.ma[i], d.mb[i], cam, rf,
                             rb, Y, Z))
      continue;
    const double thr = 3 * ro.inlier_px;
    if (rf.cwiseProduct(Dw).norm() <= thr && rb.cwiseProduct(Dw).norm() <= thr) loose[i] = 1, ++n_loose;
  }
  const double need = std::max<double>(o.min_inliers, ro.second_min_share * n);
  if (n_loose < need) return std::nullopt;
  std::vector<std::uint8_t> in;
  double rms_px = 0;
  RigidMotion m = refine_motion(previous, d.ma, d.mb, cam, ro, loose, &in, &rms_px);
  for (int round = 0; round < 2; ++round) m = refine_motion(m, d.ma, d.mb, cam, ro, in, &in, &rms_px);
  int k_in = 0;
  double sse = 0;
  for (int i = 0; i < n; ++i)
    if (in[i]) ++k_in, sse += (m.apply(d.P[i]) - d.Q[i]).squaredNorm();
  if (k_in < need) return std::nullopt;
  Candidate c;
  c.pm.motion = m;
  c.pm.points = n;
  c.pm.inliers = k_in;
  c.pm.ok = true;
  c.pm.rms = std::sqrt(sse / k_in);
  c.pm.rms_px = rms_px;
  return c;
}

}  // namespace

PairMotion choose_pair_motion(std::vector<Candidate>& cs, const PairData& d, std::optional<RigidMotion>& previous,
                              const RansacOptions& o, const StereoCamera* cam, const RefineOptions* ro) {
  const bool second = cam && ro && ro->enabled && ro->second_hypothesis;
  if (second && previous && cs[0].pm.ok)
    if (auto c = candidate_from_previous(d, *previous, o, *cam, *ro)) cs.push_back(std::move(*c));
  std::size_t pick = 0;
  if (previous && cs.size() > 1) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < cs.size(); ++j) {
      const double dist = motion_distance(cs[j].pm.motion, *previous);
      if (dist < best) best = dist, pick = j;
    }
  }
  const PairMotion out = cs[pick].pm;
  if (out.ok) previous = out.motion;
  return out;
}

}  // namespace detail

namespace {

// Every pair's hypotheses in parallel (each from its own random stream), then the sequential
// constant-velocity choice.
std::vector<PairMotion> pair_motions(const std::vector<Track>& tracks, int first_frame, int frame_count,
                                     const RansacOptions& o, const StereoCamera* cam, const RefineOptions* ro) {
  o.validate();
  if (ro) ro->validate();
  const bool refine = cam && ro && ro->enabled;
  const int npairs = std::max(0, frame_count - 1);
  const std::vector<detail::PairData> data = detail::gather_pairs(tracks, first_frame, npairs, refine);
  std::vector<std::vector<detail::Candidate>> cands(npairs);
  tbb::parallel_for(tbb::blocked_range<int>(0, npairs, 1), [&](const tbb::blocked_range<int>& r) {
    for (int k = r.begin(); k < r.end(); ++k)
      cands[k] = detail::pair_candidates(data[k], static_cast<std::uint64_t>(first_frame + k), o, cam, ro);
  });
  std::vector<PairMotion> out(npairs);
  std::optional<RigidMotion> previous;
  for (int k = 0; k < npairs; ++k) out[k] = detail::choose_pair_motion(cands[k], data[k], previous, o, cam, ro);
  return out;
}

}  // namespace

std::vector<PairMotion> estimate_pair_motions(const std::vector<Track>& tracks, int first_frame, int frame_count,
                                              const RansacOptions& o) {
  return pair_motions(tracks, first_frame, frame_count, o, nullptr, nullptr);
}

std::vector<PairMotion> estimate_pair_motions(const std::vector<Track>& tracks, int first_frame, int frame_count,
                                              const RansacOptions& o, const StereoCamera& camera,
                                              const RefineOptions& refine) {
  return pair_motions(tracks, first_frame, frame_count, o, &camera, &refine);
}

}  // namespace smseg::frontend
