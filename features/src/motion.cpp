#include "smseg/features/motion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace smseg::features {

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

Eigen::Matrix3d to_eigen(const Pose& p) {
  Eigen::Matrix3d R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(i, j) = p.R[3 * i + j];
  return R;
}

Pose from_eigen(const Eigen::Matrix3d& R, const Eigen::Vector3d& c) {
  Pose p;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) p.R[3 * i + j] = R(i, j);
    p.t[i] = c[i];
  }
  return p;
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

MotionEstimate estimate_motion(const std::vector<Eigen::Vector3d>& p, const std::vector<Eigen::Vector3d>& q,
                               const RansacOptions& o, std::uint64_t stream) {
  if (p.size() != q.size()) throw Error("", "points", "estimate_motion needs as many target points as source points");
  MotionEstimate est;
  const int n = static_cast<int>(p.size());
  est.points = n;
  est.inlier_mask.assign(n, 0);
  if (n < 3) return est;
  std::vector<double> thr2(n);
  for (int i = 0; i < n; ++i) {
    const double scale = std::pow(std::max(1.0, p[i].z() / o.reference_depth), o.depth_exponent);
    const double t = o.inlier_threshold * scale;
    thr2[i] = t * t;
  }
  SplitMix rng{mix(o.seed, stream)};
  RigidMotion best;
  int best_n = -1;
  double best_sse = std::numeric_limits<double>::infinity();
  long needed = o.max_iterations;
  std::vector<Eigen::Vector3d> sp(3), sq(3);
  int drawn = 0, attempts = 0;
  while (drawn < needed && attempts < 10 * o.max_iterations) {
    ++attempts;
    const int a = rng.below(n);
    int b = rng.below(n - 1);
    if (b >= a) ++b;
    int c = rng.below(n - 2);
    if (c >= std::min(a, b)) ++c;
    if (c >= std::max(a, b)) ++c;
    sp = {p[a], p[b], p[c]};
    sq = {q[a], q[b], q[c]};
    // Degenerate samples (collinear or coincident points) do not define a rotation.
    if ((sp[1] - sp[0]).cross(sp[2] - sp[0]).norm() < 1e-8 || (sq[1] - sq[0]).cross(sq[2] - sq[0]).norm() < 1e-8)
      continue;
    ++drawn;
    const RigidMotion m = fit_rigid(sp, sq);
    double sse = 0;
    const int k = count_inliers(m, p, q, thr2, nullptr, &sse);
    if (k > best_n || (k == best_n && sse < best_sse)) {
      best_n = k;
      best_sse = sse;
      best = m;
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
  }
  if (best_n < 0) {  // every sample degenerate: fall back to the least-squares fit of everything
    best = fit_rigid(p, q);
  }
  // Refit on the inliers until the inlier set stops growing.
  std::vector<std::uint8_t> mask(n);
  int k = count_inliers(best, p, q, thr2, &mask, &best_sse);
  for (int round = 0; round < 5 && k >= 3; ++round) {
    std::vector<Eigen::Vector3d> ip, iq;
    for (int i = 0; i < n; ++i)
      if (mask[i]) ip.push_back(p[i]), iq.push_back(q[i]);
    const RigidMotion refit = fit_rigid(ip, iq);
    std::vector<std::uint8_t> mask2(n);
    double sse2 = 0;
    const int k2 = count_inliers(refit, p, q, thr2, &mask2, &sse2);
    if (k2 < k || (k2 == k && sse2 >= best_sse)) break;
    best = refit;
    k = k2;
    best_sse = sse2;
    mask.swap(mask2);
  }
  est.motion = best;
  est.inliers = k;
  est.inlier_mask = std::move(mask);
  est.rms = k > 0 ? std::sqrt(best_sse / k) : 0;
  est.ok = k >= o.min_inliers && k >= o.min_inlier_ratio * n;
  return est;
}

Pose initial_pose(double camera_height) {
  Pose p;
  p.R = {-1, 0, 0, 0, -1, 0, 0, 0, 1};
  p.t = {0, camera_height, 0};
  return p;
}

std::vector<Pose> chain_poses(std::vector<PairMotion>& pairs, double camera_height) {
  std::vector<Pose> poses;
  poses.reserve(pairs.size() + 1);
  poses.push_back(initial_pose(camera_height));
  Eigen::Matrix3d Rw = to_eigen(poses[0]);
  Eigen::Vector3d c(poses[0].t[0], poses[0].t[1], poses[0].t[2]);
  RigidMotion last_good;  // identity until a good pair is seen
  for (auto& pm : pairs) {
    if (pm.ok && pm.motion.R.allFinite() && pm.motion.t.allFinite()) {
      pm.bridged = false;
      last_good = pm.motion;
    } else {
      pm.ok = false;
      pm.bridged = true;
      pm.motion = last_good;  // constant velocity
    }
    Rw = nearest_rotation(Rw * pm.motion.R.transpose());
    c = c - Rw * pm.motion.t;
    poses.push_back(from_eigen(Rw, c));
  }
  return poses;
}

std::vector<PairMotion> estimate_pair_motions(const std::vector<Track>& tracks, int first_frame, int frame_count,
                                              const RansacOptions& o) {
  o.validate();
  const int npairs = std::max(0, frame_count - 1);
  std::vector<std::vector<Eigen::Vector3d>> P(npairs), Q(npairs);
  for (const auto& tr : tracks) {
    for (std::size_t k = 0; k + 1 < tr.size(); ++k) {
      if (tr.frames[k + 1] != tr.frames[k] + 1) continue;
      const int pair = tr.frames[k] - first_frame;
      if (pair < 0 || pair >= npairs) continue;
      P[pair].push_back(tr.points[k]);
      Q[pair].push_back(tr.points[k + 1]);
    }
  }
  std::vector<PairMotion> out(npairs);
  tbb::parallel_for(tbb::blocked_range<int>(0, npairs, 1), [&](const tbb::blocked_range<int>& r) {
    for (int k = r.begin(); k < r.end(); ++k) {
      const MotionEstimate e = estimate_motion(P[k], Q[k], o, static_cast<std::uint64_t>(first_frame + k));
      PairMotion& pm = out[k];
      pm.motion = e.motion;
      pm.points = e.points;
      pm.inliers = e.inliers;
      pm.ok = e.ok;
      pm.rms = e.rms;
    }
  });
  return out;
}

}  // namespace smseg::features
