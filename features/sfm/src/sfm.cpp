// The monocular SfM front end (see sfm.hpp for the pipeline and its decisions).

#include "smseg/sfm/sfm.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/video/tracking.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "smseg/common/progress.hpp"
#include "smseg/frontend/trajectory.hpp"
#include "sfm_map.hpp"
#include "sfm_matching.hpp"

namespace smseg::features {

namespace {

using namespace sfm_matching;
using sfm_map::MapCandidate;
using sfm_map::TrackTable;
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr int kChunk = 32;  // frames detected before their pairs are matched
constexpr double kInf = std::numeric_limits<double>::infinity();

/// World-to-camera pose in the reconstruction frame: X_c = R X + t.
struct CamPose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre() const { return -R.transpose() * t; }
};

enum class FrameStatus : std::uint8_t { None, Init, Pnp, Still, Bridged };

struct Intrinsics {
  double f = 1, cx = 0, cy = 0;
  cv::Mat K() const { return (cv::Mat_<double>(3, 3) << f, 0, cx, 0, f, cy, 0, 0, 1); }
};

double reprojection_error(const CamPose& P, const Eigen::Vector3d& X, const cv::Point2f& px, const Intrinsics& in) {
  const Eigen::Vector3d xc = P.R * X + P.t;
  if (!(xc.z() > 1e-9)) return kInf;
  const double u = in.f * xc.x() / xc.z() + in.cx, v = in.f * xc.y() / xc.z() + in.cy;
  return std::hypot(u - px.x, v - px.y);
}

/// Linear two-view triangulation (DLT on normalised coordinates), then the checks: positive depth,
/// reprojection error below thr in both views, angle between the rays at least min_angle (radians).
bool triangulate(const CamPose& A, const CamPose& B, const cv::Point2f& pa, const cv::Point2f& pb,
                 const Intrinsics& in, double thr, double min_angle, Eigen::Vector3d& X) {
  const Eigen::Vector2d a((pa.x - in.cx) / in.f, (pa.y - in.cy) / in.f);
  const Eigen::Vector2d b((pb.x - in.cx) / in.f, (pb.y - in.cy) / in.f);
  Eigen::Matrix<double, 3, 4> Pa, Pb;
  Pa << A.R, A.t;
  Pb << B.R, B.t;
  Eigen::Matrix4d M;
  M.row(0) = a.x() * Pa.row(2) - Pa.row(0);
  M.row(1) = a.y() * Pa.row(2) - Pa.row(1);
  M.row(2) = b.x() * Pb.row(2) - Pb.row(0);
  M.row(3) = b.y() * Pb.row(2) - Pb.row(1);
  const Eigen::Vector4d h = Eigen::JacobiSVD<Eigen::Matrix4d>(M, Eigen::ComputeFullV).matrixV().col(3);
  if (!(std::abs(h(3)) > 1e-12)) return false;
  X = h.head<3>() / h(3);
  if (!X.allFinite()) return false;
  const Eigen::Vector3d ra = X - A.centre(), rb = X - B.centre();
  const double c = ra.dot(rb) / (ra.norm() * rb.norm());
  if (!(std::acos(std::clamp(c, -1.0, 1.0)) >= min_angle)) return false;
  return reprojection_error(A, X, pa, in) <= thr && reprojection_error(B, X, pb, in) <= thr;
}

}  // namespace

Calibration sfm_camera(const Sequence& seq, double focal) {
  Calibration c = seq.calibration;
  c.fx = c.fy = focal;
  if (c.cx == 0 && c.cy == 0) {
    c.cx = (seq.size.width - 1) / 2.0;
    c.cy = (seq.size.height - 1) / 2.0;
  }
  return c;
}

FrontEndResult run_mono_front_end(const Sequence& seq, const SfmOptions& options, SfmReport* report_out) {
  const auto wall0 = Clock::now();
  options.validate();
  const SfmOptions o = resolve_tracker(options, seq);
  const std::string manifest = seq.manifest.string();
  if (o.tracker == SfmTracker::Descriptors && o.tracking.detector == KeypointMethod::Gftt)
    throw Error(manifest, "tracking.detector",
                "gftt corners have no descriptors, and this sequence's frames call for descriptor matching; use "
                "--tracker klt or another detector");
  const std::optional<double> height = o.camera_height ? o.camera_height : seq.camera_height;
  if (!height)
    throw Error(manifest, "camera_height",
                "monocular SfM takes its metric scale from the camera height (give it in the manifest or as an "
                "option)");
  const int first = o.first_frame;
  const int last = seq.range_end(first, o.last_frame);
  const int n = last - first;
  const int norm = descriptor_norm(o.tracking.detector);
  SfmReport rep;
  rep.tracker = o.tracker;

  // ---- 1. keypoints, matches, geometric verification (parallel per frame / pair) ----
  std::vector<std::vector<cv::Point2f>> px(n);
  std::vector<std::vector<cv::DMatch>> matches(std::max(0, n - 1));
  std::vector<PairInfo> pairs(std::max(0, n - 1));
  std::vector<double> t_kp(n, 0.0), t_match(std::max(0, n - 1), 0.0);
  // Descriptors of every frame (empty with KLT), kept for the local-map matching of step 5: 1500 SIFT
  // keypoints take 0.77 MB per frame.
  std::vector<cv::Mat> desc(n);
  if (o.tracker == SfmTracker::Klt) {
    // Detection in parallel (positions only), then sequential KLT propagation.
    std::vector<std::vector<cv::Point2f>> detected(n);
    {
      Progress progress("sfm keypoints", n, o.progress);
      tbb::parallel_for(tbb::blocked_range<int>(0, n, 1), [&](const tbb::blocked_range<int>& r) {
        for (int i = r.begin(); i < r.end(); ++i) {
          const auto t0 = Clock::now();
          FrameKeypoints kp = detect_keypoints(seq.load_left_gray(first + i), o.tracking);
          for (const auto& k : kp.keypoints) detected[i].push_back(k.pt);
          t_kp[i] = since(t0);
          progress.tick();
        }
      });
      progress.finish();
    }
    Progress progress("sfm tracking", n, o.progress);
    cv::Mat prev_img;
    for (int t = 0; t < n; ++t) {
      const cv::Mat img = seq.load_left_gray(first + t);
      const auto t0 = Clock::now();
      std::vector<cv::DMatch> m;
      px[t] = klt_step(prev_img, t > 0 ? px[t - 1] : std::vector<cv::Point2f>(), img, detected[t],
                       o.tracking.max_keypoints, o.klt, m);
      if (t > 0) {
        pairs[t - 1] = verify_pair(m, px[t - 1], px[t], o);
        matches[t - 1] = std::move(m);
        t_match[t - 1] = since(t0);
      }
      prev_img = img;
      progress.tick();
    }
    progress.finish();
  } else {
  {
      Progress progress("sfm keypoints", n, o.progress);
      for (int c0 = 0; c0 < n; c0 += kChunk) {
        const int c1 = std::min(n, c0 + kChunk);
        tbb::parallel_for(tbb::blocked_range<int>(c0, c1, 1), [&](const tbb::blocked_range<int>& r) {
          for (int i = r.begin(); i < r.end(); ++i) {
            const auto t0 = Clock::now();
            FrameKeypoints kp = detect_keypoints(seq.load_left_gray(first + i), o.tracking);
            for (const auto& k : kp.keypoints) px[i].push_back(k.pt);
            desc[i] = kp.descriptors;
            t_kp[i] = since(t0);
            progress.tick();
          }
        });
        auto match_pair = [&](int t, const cv::Mat& a, const cv::Mat& b) {
          const auto t0 = Clock::now();
          std::vector<cv::DMatch> m =
              o.match_radius_px > 0 ? match_gated(a, px[t], b, px[t + 1], norm, o.match_radius_px, o.lowe_ratio)
              : o.lowe_ratio > 0    ? match_ratio(a, b, norm, o.lowe_ratio)
                                    : match_symmetric(a, b, norm);
          drop_far_matches(m, px[t], px[t + 1], o.tracking);
          pairs[t] = verify_pair(m, px[t], px[t + 1], o);
          if (o.epipolar_ratio > 0 && pairs[t].has_f) {
            // Guided matching along the verified pair's epipolar lines, then verified again (the
            // fundamental matrix is re-estimated from the larger set).
            m = match_epipolar(a, px[t], b, px[t + 1], pairs[t].F, norm, o.fundamental_threshold_px, o.epipolar_ratio);
            drop_far_matches(m, px[t], px[t + 1], o.tracking);
            pairs[t] = verify_pair(m, px[t], px[t + 1], o);
          }
          matches[t] = std::move(m);
          t_match[t] = since(t0);
        };
        if (c0 > 0) match_pair(c0 - 1, desc[c0 - 1], desc[c0]);
        tbb::parallel_for(tbb::blocked_range<int>(c0, c1 - 1, 1), [&](const tbb::blocked_range<int>& r) {
          for (int t = r.begin(); t < r.end(); ++t) match_pair(t, desc[t], desc[t + 1]);
        });
      }
      progress.finish();
    }
  }
  long keypoints = 0;
  std::vector<int> counts(n);
  for (int i = 0; i < n; ++i) {
    counts[i] = static_cast<int>(px[i].size());
    keypoints += counts[i];
  }
  int ntracks = 0;
  TrackTable tracks;
  tracks.tid = chain_matches(counts, matches, &ntracks);
  // Observations of each track: (frame, keypoint), frames ascending. Step 5 merges tracks.
  tracks.tobs.resize(ntracks);
  const auto& tid = tracks.tid;
  auto& tobs = tracks.tobs;
  for (int t = 0; t < n; ++t)
    for (int i = 0; i < counts[t]; ++i) tobs[tid[t][i]].push_back({t, i});

  const auto sfm0 = Clock::now();
  double t_ba = 0;

  // ---- 2. focal length ----
  Intrinsics in;
  const Calibration camera = sfm_camera(seq, 1);  // its principal point; the focal is found below
  in.cx = camera.cx;
  in.cy = camera.cy;
  if (o.focal) {
    in.f = *o.focal;
    rep.focal_source = FocalSource::Option;
  } else if (seq.calibration.fx && *seq.calibration.fx > 0) {
    in.f = *seq.calibration.fx;
    rep.focal_source = FocalSource::Manifest;
  } else {
    // Fundamental matrices between frames a and b up to 30 frames later that share >= 50 tracks and
    // moved >= 10 px (median), sampled along the sequence, plus every consecutive verified pair.
    std::vector<cv::Matx33d> Fs;
    for (const auto& p : pairs)
      if (p.has_f && p.median_motion >= 10) Fs.push_back(p.F);
    const int step = std::max(1, n / 40);
    for (int a = 0; a + 1 < n; a += step) {
      std::vector<cv::Point2f> best_a, best_b;
      for (int b = a + 1; b < std::min(n, a + 31); ++b) {
        std::vector<cv::Point2f> qa, qb;
        std::vector<double> mv;
        for (int i = 0; i < counts[a]; ++i) {
          for (const auto& [f, k] : tobs[tid[a][i]])
            if (f == b) {
              qa.push_back(px[a][i]);
              qb.push_back(px[b][k]);
              mv.push_back(cv::norm(px[b][k] - px[a][i]));
            }
        }
        if (qa.size() < 50) break;
        if (median(mv) >= 10) {
          best_a = std::move(qa);
          best_b = std::move(qb);
        }
      }
      if (best_a.size() < 50) continue;
      std::vector<std::uint8_t> mask;
      const cv::Mat F =
          cv::findFundamentalMat(best_a, best_b, cv::FM_RANSAC, o.fundamental_threshold_px, 0.999, 2000, mask);
      if (F.rows == 3 && F.cols == 3 && cv::countNonZero(mask) >= 30) Fs.push_back(cv::Matx33d(F.ptr<double>()));
    }
    const auto f = estimate_focal_from_fundamentals(Fs, seq.size, &rep.focal_pairs);
    if (f) {
      in.f = *f;
      rep.focal_source = FocalSource::Estimated;
    } else {
      in.f = seq.size.width;
      rep.focal_source = FocalSource::Fallback;
    }
  }
  rep.focal = in.f;
  const cv::Mat K = in.K();
  const double thr = o.reprojection_threshold_px;
  const double min_angle = o.min_triangulation_angle_deg * M_PI / 180;

  // ---- 3-5. incremental reconstruction ----
  std::vector<CamPose> pose(n);
  std::vector<FrameStatus> status(n, FrameStatus::None);
  std::vector<int> pnp_points(n, 0), pnp_inliers(n, 0);
  std::vector<Eigen::Vector3d> X(ntracks, Eigen::Vector3d::Zero());
  std::vector<char> hasX(ntracks, 0);
  std::vector<int> keyframes;

  // Tracks common to frames a and b: (keypoint in a, keypoint in b).
  auto common = [&](int a, int b) {
    std::vector<std::pair<int, int>> c;
    for (int i = 0; i < counts[a]; ++i)
      for (const auto& [f, k] : tobs[tid[a][i]])
        if (f == b) c.push_back({i, k});
    return c;
  };
  auto median_motion = [&](int a, int b) {
    std::vector<double> mv;
    for (const auto& [i, k] : common(a, b)) mv.push_back(cv::norm(px[b][k] - px[a][i]));
    return std::pair<double, int>(median(mv), static_cast<int>(mv.size()));
  };

  // Local / global bundle adjustment over the given key frames, the first n_fixed held.
  std::vector<int> point_index(ntracks, -1);
  auto adjust = [&](const std::vector<int>& frames, int n_fixed, int iterations) {
    if (iterations <= 0 || frames.empty()) return;
    const auto t0 = Clock::now();
    std::vector<BaCamera> cams(frames.size());
    std::vector<Eigen::Vector3d> pts;
    std::vector<int> pt_track;
    std::vector<BaObservation> bobs;
    for (std::size_t c = 0; c < frames.size(); ++c) {
      const int t = frames[c];
      cams[c].R = pose[t].R;
      cams[c].t = pose[t].t;
      cams[c].fixed = static_cast<int>(c) < n_fixed;
      for (int i = 0; i < counts[t]; ++i) {
        const int tr = tid[t][i];
        if (!hasX[tr]) continue;
        // Gross outliers stay out of the adjustment.
        if (reprojection_error(pose[t], X[tr], px[t][i], in) > 4 * thr) continue;
        if (point_index[tr] < 0) {
          point_index[tr] = static_cast<int>(pts.size());
          pts.push_back(X[tr]);
          pt_track.push_back(tr);
        }
        bobs.push_back({static_cast<int>(c), point_index[tr], Eigen::Vector2d(px[t][i].x, px[t][i].y)});
      }
    }
    BaOptions bo;
    bo.iterations = iterations;
    bo.huber_px = thr;
    bundle_adjust(cams, pts, bobs, in.f, in.cx, in.cy, bo);
    for (std::size_t c = 0; c < frames.size(); ++c) {
      pose[frames[c]].R = cams[c].R;
      pose[frames[c]].t = cams[c].t;
    }
    for (std::size_t j = 0; j < pts.size(); ++j) {
      X[pt_track[j]] = pts[j];
      point_index[pt_track[j]] = -1;
    }
    t_ba += since(t0);
  };

  // PnP from the frame's tracks with 3D points and the local-map candidates; `guess` seeds the
  // iterative refinement.
  auto pnp = [&](int t, const CamPose& guess, CamPose& out, const std::vector<MapCandidate>& candidates = {}) {
    std::vector<cv::Point3d> obj;
    std::vector<cv::Point2d> img;
    auto add = [&](int i, int tr) {
      obj.emplace_back(X[tr].x(), X[tr].y(), X[tr].z());
      img.emplace_back(px[t][i].x, px[t][i].y);
    };
    for (int i = 0; i < counts[t]; ++i)
      if (hasX[tid[t][i]]) add(i, tid[t][i]);
    for (const auto& c : candidates) add(c.keypoint, c.track);
    pnp_points[t] = static_cast<int>(obj.size());
    pnp_inliers[t] = 0;
    if (static_cast<int>(obj.size()) < o.min_pnp_points) return false;
    cv::Mat Rg, rvec, tvec;
    cv::eigen2cv(guess.R, Rg);
    cv::Rodrigues(Rg, rvec);
    cv::eigen2cv(guess.t, tvec);
    std::vector<int> inl;
    bool ok = cv::solvePnPRansac(obj, img, K, cv::noArray(), rvec, tvec, false, 300, static_cast<float>(thr), 0.999, inl,
                                 cv::SOLVEPNP_EPNP);
    if (!ok || static_cast<int>(inl.size()) < o.min_pnp_points) return false;
    std::vector<cv::Point3d> o2;
    std::vector<cv::Point2d> i2;
    for (int k : inl) {
      o2.push_back(obj[k]);
      i2.push_back(img[k]);
    }
    // Candidates: the RANSAC pose (OpenCV re-estimates it by EPnP on all inliers, which can come out
    // wrong, mirrored, with many far points as on CamVid), and Levenberg-Marquardt refinements on the
    // inliers started from it and from the guess (the previous frame's pose). The one explaining the
    // most RANSAC inliers within the threshold is kept.
    auto cv_pose = [](const cv::Mat& rv, const cv::Mat& tv, CamPose& P) {
      cv::Mat R;
      cv::Rodrigues(rv, R);
      cv::cv2eigen(R, P.R);
      cv::cv2eigen(tv, P.t);
      return P.R.allFinite() && P.t.allFinite();
    };
    auto explained = [&](const CamPose& P) {
      int c = 0;
      for (int k : inl)
        c += reprojection_error(P, Eigen::Vector3d(obj[k].x, obj[k].y, obj[k].z),
                                cv::Point2f(static_cast<float>(img[k].x), static_cast<float>(img[k].y)), in) <= thr;
      return c;
    };
    int confirmed = -1;
    auto consider = [&](const cv::Mat& rv, const cv::Mat& tv) {
      CamPose P;
      if (!cv_pose(rv, tv, P)) return;
      const int c = explained(P);
      if (c > confirmed) {
        confirmed = c;
        out = P;
      }
    };
    consider(rvec, tvec);
    cv::Mat rv = rvec.clone(), tv = tvec.clone();
    cv::solvePnPRefineLM(o2, i2, K, cv::noArray(), rv, tv);
    consider(rv, tv);
    cv::Mat rg, tg;
    cv::Rodrigues(Rg, rg);
    cv::eigen2cv(guess.t, tg);
    cv::solvePnPRefineLM(o2, i2, K, cv::noArray(), rg, tg);
    consider(rg, tg);
    if (confirmed < std::max(o.min_pnp_points, static_cast<int>(0.8 * static_cast<double>(inl.size())))) return false;
    pnp_inliers[t] = confirmed;
    return true;
  };

  // Local-map candidates of frame t (sfm_map.hpp): the map points of the map_window frames before it.
  const double map_ratio = o.lowe_ratio > 0 ? o.lowe_ratio : 0.8;
  auto local_map_candidates = [&](int t) {
    std::vector<int> window;
    for (int f = std::max(0, t - o.map_window); f < t; ++f)
      if (status[f] != FrameStatus::None) window.push_back(f);
    if (window.empty() || desc[t].empty()) return std::vector<MapCandidate>();
    return sfm_map::match_local_map(t, window, tracks, hasX, desc, norm, map_ratio);
  };
  // The candidates that the frame's pose confirms join their map track (the keypoint's whole track:
  // its later frames then see the point too).
  auto join_confirmed = [&](int t, const std::vector<MapCandidate>& candidates) {
    for (const auto& c : candidates)
      if (reprojection_error(pose[t], X[c.track], px[t][c.keypoint], in) <= thr)
        rep.map_joins += tracks.merge(tid[t][c.keypoint], c.track);
  };

  // Triangulates the tracks of frame t that have no point yet, from their first posed observation.
  auto triangulate_new = [&](int t) {
    for (int i = 0; i < counts[t]; ++i) {
      const int tr = tid[t][i];
      if (hasX[tr] || tobs[tr].size() < 2) continue;
      for (const auto& [f, k] : tobs[tr]) {
        if (f >= t) break;
        if (status[f] == FrameStatus::None) continue;
        Eigen::Vector3d P;
        if (triangulate(pose[f], pose[t], px[f][k], px[t][i], in, thr, min_angle, P)) {
          X[tr] = P;
          hasX[tr] = 1;
        }
        break;  // only the first posed observation: the widest baseline
      }
    }
  };

  Progress progress("sfm", n, o.progress);
  // Initial pair.
  int ia = -1, ib = -1;
  {
    int a = 0;
    for (int b = 1; b < n && ib < 0; ++b) {
      const auto [mm, nc] = median_motion(a, b);
      if (nc < 50) {  // the first frame's tracks died before enough motion: start later
        a = b;
        continue;
      }
      if (mm < o.init_motion_px) continue;
      std::vector<cv::Point2d> qa, qb;
      const auto cm = common(a, b);
      for (const auto& [i, k] : cm) {
        qa.emplace_back(px[a][i].x, px[a][i].y);
        qb.emplace_back(px[b][k].x, px[b][k].y);
      }
      std::vector<std::uint8_t> mask;
      const cv::Mat E = cv::findEssentialMat(qa, qb, K, cv::RANSAC, 0.999, 1.0, 1000, mask);
      if (E.rows != 3 || E.cols != 3) continue;
      cv::Mat R, tv;
      const int good = cv::recoverPose(E, qa, qb, K, R, tv, mask);
      if (good < 30) continue;
      CamPose A, B;
      cv::cv2eigen(R, B.R);
      cv::cv2eigen(tv, B.t);
      std::vector<double> angles;
      std::vector<std::pair<int, Eigen::Vector3d>> made;
      for (std::size_t k = 0; k < cm.size(); ++k) {
        if (!mask[k]) continue;
        Eigen::Vector3d P;
        if (!triangulate(A, B, px[a][cm[k].first], px[b][cm[k].second], in, thr, 0.0, P)) continue;
        const Eigen::Vector3d ra = P - A.centre(), rb = P - B.centre();
        angles.push_back(std::acos(std::clamp(ra.dot(rb) / (ra.norm() * rb.norm()), -1.0, 1.0)));
        made.push_back({tid[a][cm[k].first], P});
      }
      if (made.size() < 30 || median(angles) < o.init_min_angle_deg * M_PI / 180) continue;
      ia = a;
      ib = b;
      pose[a] = A;
      pose[b] = B;
      status[a] = status[b] = FrameStatus::Init;
      for (std::size_t k = 0; k < made.size(); ++k) {
        if (angles[k] < min_angle) continue;
        X[made[k].first] = made[k].second;
        hasX[made[k].first] = 1;
      }
      keyframes = {a, b};
      adjust(keyframes, 2, o.ba_iterations);  // points only
    }
  }

  if (ib >= 0) {
    rep.init_frame_a = first + ia;
    rep.init_frame_b = first + ib;
    // Frames inside the initial pair, then before it (backwards), by PnP.
    auto pose_by_pnp = [&](int t, int neighbour, bool still_pair) {
      if (still_pair && status[neighbour] != FrameStatus::None) {
        pose[t] = pose[neighbour];
        status[t] = FrameStatus::Still;
        return;
      }
      CamPose P;
      if (pnp(t, pose[neighbour], P)) {
        pose[t] = P;
        status[t] = FrameStatus::Pnp;
      } else {
        pose[t] = pose[neighbour];
        status[t] = FrameStatus::Bridged;
      }
    };
    for (int t = ia + 1; t < ib; ++t) pose_by_pnp(t, t - 1, pairs[t - 1].still);
    for (int t = ia - 1; t >= 0; --t) pose_by_pnp(t, t + 1, pairs[t].still);
    progress.tick(ib + 1);
    int last_kf = ib;
    for (int t = ib + 1; t < n; ++t) {
      progress.tick();
      if (pairs[t - 1].still) {
        pose[t] = pose[t - 1];
        status[t] = FrameStatus::Still;
        continue;
      }
      CamPose P;
      // Many of the local map's candidates are wrong at 1 Hz (with them in every PnP, 47 of 0016E5_00390's
      // 68 frames were posed, against 51 without them): they join PnP only when the frame's own tracks
      // cannot pose it, and join their tracks when the pose confirms them.
      const std::vector<MapCandidate> candidates = local_map_candidates(t);
      if (pnp(t, pose[t - 1], P) || pnp(t, pose[t - 1], P, candidates)) {
        pose[t] = P;
        status[t] = FrameStatus::Pnp;
        join_confirmed(t, candidates);
      } else {
        // Bridge by the essential matrix to the previous frame, with the previous step's length.
        status[t] = FrameStatus::Bridged;
        pose[t] = pose[t - 1];
        std::vector<cv::Point2d> qa, qb;
        for (const auto& d : matches[t - 1]) {
          qa.emplace_back(px[t - 1][d.queryIdx].x, px[t - 1][d.queryIdx].y);
          qb.emplace_back(px[t][d.trainIdx].x, px[t][d.trainIdx].y);
        }
        if (qa.size() >= 8) {
          std::vector<std::uint8_t> mask;
          const cv::Mat E = cv::findEssentialMat(qa, qb, K, cv::RANSAC, 0.999, 1.0, 1000, mask);
          cv::Mat R, tv;
          if (E.rows == 3 && E.cols == 3 && cv::recoverPose(E, qa, qb, K, R, tv, mask) >= 15) {
            Eigen::Matrix3d Rr;
            Eigen::Vector3d tr;
            cv::cv2eigen(R, Rr);
            cv::cv2eigen(tv, tr);
            // The last step that moved (frames bridged without motion, e.g. across textureless
            // frames, would otherwise freeze the path for good).
            double step = 0;
            for (int k = t - 1; k >= 1 && step == 0; --k)
              if (status[k] != FrameStatus::Still) step = (pose[k].centre() - pose[k - 1].centre()).norm();
            pose[t].R = Rr * pose[t - 1].R;
            pose[t].t = Rr * pose[t - 1].t + step * tr;
          }
        }
      }
      const auto [mm, nc] = median_motion(last_kf, t);
      const bool weak = pnp_inliers[t] < std::max(3 * o.min_pnp_points, pnp_inliers[last_kf] * 2 / 5);
      if (mm >= o.keyframe_motion_px || status[t] == FrameStatus::Bridged || (weak && mm >= 2 * o.still_motion_px) ||
          nc < 30) {
        triangulate_new(t);
        keyframes.push_back(t);
        last_kf = t;
        const int w = std::min<int>(o.ba_window, static_cast<int>(keyframes.size()));
        std::vector<int> window(keyframes.end() - w, keyframes.end());
        adjust(window, 2, o.ba_iterations);
        if (status[t] == FrameStatus::Bridged) pnp_inliers[t] = 0;
      }
    }
    // ---- 6. final adjustment, re-posing, remaining points ----
    if (o.final_ba && keyframes.size() >= 3) adjust(keyframes, 2, o.final_ba_iterations);
    std::vector<char> is_kf(n, 0);
    for (int k : keyframes) is_kf[k] = 1;
    for (int t = 0; t < n; ++t) {
      if (is_kf[t]) continue;
      if (status[t] == FrameStatus::Still) {
        const int nb = t < ia ? t + 1 : t - 1;
        pose[t] = pose[nb];
        continue;
      }
      CamPose P;
      if (pnp(t, pose[t], P)) {
        pose[t] = P;
        if (status[t] == FrameStatus::Bridged) status[t] = FrameStatus::Pnp;
      }
    }
    // Still frames again, in order (their neighbours may have moved).
    for (int t = ia - 1; t >= 0; --t)
      if (status[t] == FrameStatus::Still) pose[t] = pose[t + 1];
    for (int t = ia + 1; t < n; ++t)
      if (status[t] == FrameStatus::Still && !is_kf[t]) pose[t] = pose[t - 1];
    for (int tr = 0; tr < ntracks; ++tr) {
      if (hasX[tr] || tobs[tr].size() < 2) continue;
      const auto& [fa, ka] = tobs[tr].front();
      const auto& [fb, kb] = tobs[tr].back();
      if (status[fa] == FrameStatus::None || status[fb] == FrameStatus::None) continue;
      Eigen::Vector3d P;
      if (triangulate(pose[fa], pose[fb], px[fa][ka], px[fb][kb], in, thr, min_angle, P)) {
        X[tr] = P;
        hasX[tr] = 1;
      }
    }
  } else {
    progress.tick(n);
  }
  progress.finish();

  // Final observation filter.
  std::vector<std::vector<char>> keep(n);
  double sq = 0;
  long kept = 0;
  for (int t = 0; t < n; ++t) {
    keep[t].assign(counts[t], 0);
    if (status[t] == FrameStatus::None) continue;
    for (int i = 0; i < counts[t]; ++i) {
      const int tr = tid[t][i];
      if (!hasX[tr]) continue;
      const double e = reprojection_error(pose[t], X[tr], px[t][i], in);
      if (e <= thr) {
        keep[t][i] = 1;
        sq += e * e;
        ++kept;
      }
    }
  }
  // A track needs at least two kept observations to count as a 3D point.
  for (int tr = 0; tr < ntracks; ++tr) {
    if (!hasX[tr]) continue;
    int k = 0;
    for (const auto& [f, i] : tobs[tr]) k += keep[f][i];
    if (k < 2) {
      for (const auto& [f, i] : tobs[tr])
        if (keep[f][i]) {
          const double e = reprojection_error(pose[f], X[tr], px[f][i], in);
          sq -= e * e;
          --kept;
          keep[f][i] = 0;
        }
      hasX[tr] = 0;
    }
  }
  rep.observations = kept;
  rep.reprojection_rms_px = kept > 0 ? std::sqrt(std::max(0.0, sq) / static_cast<double>(kept)) : 0;
  rep.points_3d = std::count(hasX.begin(), hasX.end(), 1);
  rep.keyframes = static_cast<int>(keyframes.size());
  for (auto s : status) {
    rep.still_frames += s == FrameStatus::Still;
    rep.pnp_frames += s == FrameStatus::Pnp;
    rep.bridged_frames += s == FrameStatus::Bridged || s == FrameStatus::None;
  }

  // ---- 7. ground plane, metric scale, world frame ----
  double scale = 1;
  Eigen::Matrix3d B = Eigen::Matrix3d::Identity();  // rows: world X, Y, Z in reconstruction coordinates
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  if (ib >= 0) {
    Eigen::Vector3d up = Eigen::Vector3d::Zero();
    for (int t = 0; t < n; ++t)
      if (status[t] != FrameStatus::None) up += -pose[t].R.transpose().col(1);  // camera -y in the world
    up.normalize();
    std::vector<Eigen::Vector3d> cand;
    std::vector<double> below;
    for (int tr = 0; tr < ntracks; ++tr) {
      if (!hasX[tr]) continue;
      // Only well-triangulated points: the rays of the first and last kept observations must be at
      // least ground_min_angle_deg apart (depth errors of far points would bias the plane).
      int fa = -1, fb = -1;
      for (const auto& [f, i] : tobs[tr])
        if (keep[f][i]) {
          if (fa < 0) fa = f;
          fb = f;
        }
      if (fa < 0) continue;
      const Eigen::Vector3d ra = X[tr] - pose[fa].centre(), rb = X[tr] - pose[fb].centre();
      if (std::acos(std::clamp(ra.dot(rb) / (ra.norm() * rb.norm()), -1.0, 1.0)) < o.ground_min_angle_deg * M_PI / 180)
        continue;
      for (const auto& [f, i] : tobs[tr]) {
        if (!keep[f][i]) continue;
        const Eigen::Vector3d xc = pose[f].R * X[tr] + pose[f].t;
        const Eigen::Vector3d c_up = -pose[f].R.transpose().col(1);
        const double h = (pose[f].centre() - X[tr]).dot(c_up);
        if (px[f][i].y > in.cy + o.ground_min_row_share * seq.size.height && xc.z() > 0 && h > 0) {
          cand.push_back(X[tr]);
          below.push_back(h);
        }
        break;
      }
    }
    rep.ground_candidates = static_cast<int>(cand.size());
    const double h_typ = median(below);
    const PlaneFit plane = fit_ground_plane(cand, up, o.ground_threshold * h_typ, o.ground_max_tilt_deg,
                                            o.ground_iterations, o.seed, o.ground_min_inliers);
    Eigen::Vector3d n_up = up;
    double d = 0;
    if (plane.ok) {
      n_up = plane.normal;
      d = plane.d;
      rep.ground_inliers = plane.inliers;
      std::vector<double> hs;
      for (int t = 0; t < n; ++t)
        if (status[t] != FrameStatus::None) hs.push_back(n_up.dot(pose[t].centre()) + d);
      const double h = median(hs);
      if (h > 0) scale = *height / h;
    } else if (cand.size() >= 5 && h_typ > 0) {
      // No plane to trust: the candidates' median depth below the cameras stands for the camera height.
      d = -n_up.dot(pose[0].centre()) + h_typ;
      scale = *height / h_typ;
    } else {
      // Nothing below the cameras: keep the reconstruction's scale, the ground one unit below the first
      // camera.
      d = -n_up.dot(pose[0].centre()) + 1.0;
      scale = *height;
    }
    rep.ground_normal = n_up;
    const Eigen::Vector3d c0 = pose[0].centre();
    origin = c0 - (n_up.dot(c0) + d) * n_up;
    Eigen::Vector3d z = pose[0].R.transpose().col(2);
    z -= z.dot(n_up) * n_up;
    if (!(z.norm() > 1e-6)) z = Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ().dot(n_up) * n_up;
    z.normalize();
    B.row(1) = n_up.transpose();
    B.row(2) = z.transpose();
    B.row(0) = n_up.cross(z).transpose();
  } else {
    // Never initialised: every frame at the first pose of the stereo convention.
    const Pose p0 = initial_pose(*height);
    Eigen::Matrix3d R0;
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) R0(r, k) = p0.R[3 * r + k];
    for (auto& p : pose) {
      p.R = R0.transpose();
      p.t = Eigen::Vector3d::Zero();
    }
    B = Eigen::Matrix3d::Identity();
    origin = Eigen::Vector3d(0, -*height, 0);
    scale = 1;
  }
  rep.scale = scale;

  // ---- output ----
  FrontEndResult res;
  res.first_frame = first;
  res.poses.resize(n);
  for (int t = 0; t < n; ++t)
    res.poses[t] = make_pose(B * pose[t].R.transpose(), scale * B * (pose[t].centre() - origin));
  std::vector<FrameObservations> fobs(n);
  for (int t = 0; t < n; ++t) {
    auto& fo = fobs[t];
    fo.pixels = px[t];
    fo.disparities.assign(counts[t], kInvalidDisparity);
    fo.points.assign(counts[t], Eigen::Vector3d::Zero());
    const cv::Mat labels = seq.is_labelled(first + t) ? seq.load_labels(first + t) : cv::Mat();
    if (!labels.empty()) fo.labels.assign(counts[t], -1);
    for (int i = 0; i < counts[t]; ++i) {
      if (!labels.empty()) {
        const int x = std::clamp(static_cast<int>(std::lround(px[t][i].x)), 0, labels.cols - 1);
        const int y = std::clamp(static_cast<int>(std::lround(px[t][i].y)), 0, labels.rows - 1);
        const std::uint8_t l = labels.at<std::uint8_t>(y, x);
        fo.labels[i] = l == kVoid ? -1 : l;
      }
      if (!keep[t][i] || !hasX[tid[t][i]]) continue;
      const Eigen::Vector3d xc = scale * (pose[t].R * X[tid[t][i]] + pose[t].t);
      fo.points[i] = xc;
      fo.disparities[i] = static_cast<float>(1.0 / xc.z());
    }
  }
  FilterCounts fc;
  res.tracks = build_tracks(fobs, matches, o.filters, fc);
  for (auto& tr : res.tracks)
    for (int& f : tr.frames) f += first;
  res.pair_motions.resize(std::max(0, n - 1));
  for (int t = 0; t + 1 < n; ++t) {
    auto& pm = res.pair_motions[t];
    const Eigen::Matrix3d Ra = B * pose[t].R.transpose(), Rb = B * pose[t + 1].R.transpose();
    const Eigen::Vector3d ca = scale * B * (pose[t].centre() - origin), cb = scale * B * (pose[t + 1].centre() - origin);
    pm.motion.R = Rb.transpose() * Ra;
    pm.motion.t = Rb.transpose() * (ca - cb);
    pm.points = pnp_points[t + 1];
    pm.inliers = pnp_inliers[t + 1];
    pm.bridged = status[t + 1] == FrameStatus::Bridged || status[t + 1] == FrameStatus::None;
    pm.ok = !pm.bridged;
  }
  const double t_sfm = since(sfm0);

  // Summary (as the stereo front end's).
  FrontEndSummary& s = res.summary;
  s.frames = n;
  s.keypoints = keypoints;
  s.filters = fc;
  summarise_tracks_and_motion(res, n, [&](std::size_t k) {
    return status[k + 1] != FrameStatus::Still && res.pair_motions[k].points > 0;
  });
  auto mean = [](const std::vector<double>& v, int denom) {
    return denom > 0 ? std::accumulate(v.begin(), v.end(), 0.0) / denom : 0.0;
  };
  s.seconds.keypoints = mean(t_kp, n);
  s.seconds.matching = mean(t_match, n);
  s.seconds.motion = n > 0 ? t_sfm / n : 0;
  s.seconds.total_wall = since(wall0);
  rep.seconds_sfm = s.seconds.motion;
  rep.seconds_ba = n > 0 ? t_ba / n : 0;
  s.sfm = sfm_summary(rep);
  if (report_out) *report_out = rep;
  return res;
}

}  // namespace smseg::features
