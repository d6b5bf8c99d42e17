// Bundle adjustment for the monocular SfM, with Ceres (docs/design.md 7): the reprojection error of every
// observation, a Huber loss, cameras as (angle-axis, translation) parameter blocks (world-to-camera
// X_c = R X + t), points as 3-vectors; fixed cameras are constant blocks (the gauge, scale included).
// The Schur complement eliminates the points (DENSE_SCHUR for a sliding window, SPARSE_SCHUR for many
// cameras). One thread: Ceres's multi-threaded evaluation sums gradients in a scheduling-dependent
// order, and the front end must not depend on the thread count (the adjustments run sequentially
// inside the incremental reconstruction anyway).

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <glog/logging.h>
#include <suitesparse/SuiteSparse_config.h>

#include "smseg/sfm/sfm.hpp"

namespace smseg::sfm {

namespace {

constexpr double kMinDepth = 1e-6;

std::atomic<bool> g_solver_verbose{false};

/// Messages of the libraries below Ceres that bypass glog: CHOLMOD prints through SuiteSparse's
/// printf hook (SuiteSparse 5; version 7 has a setter instead).
void set_suitesparse_printing(bool on) {
#if SUITESPARSE_MAIN_VERSION < 7
  SuiteSparse_config.printf_func = on ? &std::printf : nullptr;
#else
  SuiteSparse_config_printf_func_set(on ? &std::printf : nullptr);
#endif
}

/// Applies the default (errors only) on first use, so that a program that never calls
/// set_solver_verbose (a test, a library user) is quiet too.
void apply_default_solver_log() {
  static const bool applied = [] {
    if (!g_solver_verbose.load()) set_solver_verbose(false);
    return true;
  }();
  (void)applied;
}

/// Residual (2): projection of point X by camera (angle-axis a, translation t) minus the pixel.
struct Reprojection {
  double u, v, f, cx, cy;
  template <typename T>
  bool operator()(const T* cam, const T* X, T* r) const {
    T p[3];
    ceres::AngleAxisRotatePoint(cam, X, p);
    p[0] += cam[3];
    p[1] += cam[4];
    p[2] += cam[5];
    if (!(p[2] > T(kMinDepth))) return false;  // behind the camera: the step that got there is rejected
    r[0] = T(f) * p[0] / p[2] + T(cx) - T(u);
    r[1] = T(f) * p[1] / p[2] + T(cy) - T(v);
    return true;
  }
};

/// Same residual for a fixed camera (its pose folded into constants): fewer parameters per block.
struct ReprojectionFixed {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  double u, v, f, cx, cy;
  template <typename T>
  bool operator()(const T* X, T* r) const {
    T p[3];
    for (int i = 0; i < 3; ++i) p[i] = T(R(i, 0)) * X[0] + T(R(i, 1)) * X[1] + T(R(i, 2)) * X[2] + T(t(i));
    if (!(p[2] > T(kMinDepth))) return false;
    r[0] = T(f) * p[0] / p[2] + T(cx) - T(u);
    r[1] = T(f) * p[1] / p[2] + T(cy) - T(v);
    return true;
  }
};

using CamBlock = std::array<double, 6>;

CamBlock to_block(const BaCamera& c) {
  const Eigen::AngleAxisd aa(c.R);
  const Eigen::Vector3d w = aa.angle() * aa.axis();
  return {w.x(), w.y(), w.z(), c.t.x(), c.t.y(), c.t.z()};
}

void from_block(const CamBlock& b, BaCamera& c) {
  Eigen::Matrix3d R;
  ceres::AngleAxisToRotationMatrix(b.data(), R.data());  // column-major, as Eigen stores it
  c.R = R;
  c.t = Eigen::Vector3d(b[3], b[4], b[5]);
}

/// RMS reprojection error over the observations in front of their cameras; counts them.
double rms(const std::vector<BaCamera>& cams, const std::vector<Eigen::Vector3d>& pts,
           const std::vector<BaObservation>& obs, double f, double cx, double cy, long* used) {
  double sq = 0;
  long n = 0;
  for (const auto& o : obs) {
    const Eigen::Vector3d xc = cams[o.camera].R * pts[o.point] + cams[o.camera].t;
    if (xc.z() < kMinDepth) continue;
    sq += Eigen::Vector2d(f * xc.x() / xc.z() + cx - o.pixel.x(), f * xc.y() / xc.z() + cy - o.pixel.y())
              .squaredNorm();
    ++n;
  }
  if (used) *used = n;
  return n ? std::sqrt(sq / static_cast<double>(n)) : 0.0;
}

}  // namespace

void set_solver_verbose(bool verbose) {
  g_solver_verbose = verbose;
  const int min_level = verbose ? google::GLOG_INFO : google::GLOG_ERROR;
  FLAGS_minloglevel = min_level;
  FLAGS_stderrthreshold = min_level;
  FLAGS_logtostderr = true;  // no log files in /tmp
  set_suitesparse_printing(verbose);
}

bool solver_verbose() { return g_solver_verbose; }

void BaOptions::validate() const {
  if (iterations < 0) throw Error("", "ba.iterations", "must be >= 0");
  if (!(huber_px > 0)) throw Error("", "ba.huber_px", "must be positive");
}

BaSummary bundle_adjust(std::vector<BaCamera>& cams, std::vector<Eigen::Vector3d>& pts,
                        const std::vector<BaObservation>& obs, double f, double cx, double cy, const BaOptions& opt) {
  opt.validate();
  apply_default_solver_log();
  const int nc = static_cast<int>(cams.size());
  const int np = static_cast<int>(pts.size());
  for (const auto& o : obs)
    if (o.camera < 0 || o.camera >= nc || o.point < 0 || o.point >= np)
      throw Error("", "bundle_adjust", "observation refers to a missing camera or point");
  BaSummary summary;
  summary.initial_rms = rms(cams, pts, obs, f, cx, cy, nullptr);
  summary.final_rms = summary.initial_rms;
  if (obs.empty() || opt.iterations == 0) return summary;

  std::vector<CamBlock> blocks(nc);
  for (int i = 0; i < nc; ++i) blocks[i] = to_block(cams[i]);
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  ceres::HuberLoss huber(opt.huber_px);  // rho(s) = s inside, 2 a sqrt(s) - a^2 outside (s = squared px)
  std::vector<char> in_problem(nc, 0);
  int free_cameras = 0;
  long residuals = 0;
  for (const auto& o : obs) {
    const BaCamera& c = cams[o.camera];
    const Eigen::Vector3d xc = c.R * pts[o.point] + c.t;
    if (xc.z() < kMinDepth) continue;  // behind the camera at the start: no residual for it
    ++residuals;
    if (c.fixed) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ReprojectionFixed, 2, 3>(
                                   new ReprojectionFixed{c.R, c.t, o.pixel.x(), o.pixel.y(), f, cx, cy}),
                               &huber, pts[o.point].data());
    } else {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Reprojection, 2, 6, 3>(
                                   new Reprojection{o.pixel.x(), o.pixel.y(), f, cx, cy}),
                               &huber, blocks[o.camera].data(), pts[o.point].data());
      if (!in_problem[o.camera]) {
        in_problem[o.camera] = 1;
        ++free_cameras;
      }
    }
  }
  if (residuals == 0) return summary;

  ceres::Solver::Options so;
  so.linear_solver_type = free_cameras <= 40 ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  so.max_num_iterations = opt.iterations;
  so.num_threads = 1;  // deterministic (see the header comment)
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  so.function_tolerance = 1e-8;
  ceres::Solver::Summary s;
  ceres::Solve(so, &problem, &s);
  if (g_solver_verbose.load()) std::cerr << "bundle adjustment: " << s.BriefReport() << "\n";
  for (int i = 0; i < nc; ++i)
    if (in_problem[i]) from_block(blocks[i], cams[i]);
  summary.iterations = s.num_successful_steps + s.num_unsuccessful_steps;
  summary.final_rms = rms(cams, pts, obs, f, cx, cy, nullptr);
  return summary;
}

}  // namespace smseg::sfm
