// eval-stereo-path's work (see eval_stereo_path.hpp).
#include "smseg/experiments/eval_stereo_path.hpp"

#include <algorithm>
#include <cstdarg>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "smseg/frontend/tracks_io.hpp"
#include "smseg/sfm/sfm_summary.hpp"
#include "smseg/stacks/front_ends.hpp"
#include "smseg/sequence/sequence.hpp"

namespace smseg::experiments {

using namespace smseg::sequence;
using namespace smseg::frontend;

namespace {

Json path_json(const PathError& e) {
  return Json{{"rmse_m", e.rmse},       {"max_m", e.max_error}, {"path_length_m", e.path_length},
              {"relative", e.relative}, {"scale", e.scale},     {"frames", e.frames}};
}

/// printf into a string (the report's lines are short).
[[gnu::format(printf, 1, 2)]] std::string printf_string(const char* fmt, ...) {
  char buf[512];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buf, sizeof buf, fmt, args);
  va_end(args);
  return buf;
}

}  // namespace

StereoPathEvaluation evaluate_stereo_path(const std::string& sequence, const std::string& work) {
  const Sequence seq = load_sequence(sequence);
  StereoPathEvaluation e;
  e.tracks = work;
  if (fs::is_directory(e.tracks)) e.tracks /= "tracks.json";
  const TracksFile tf = stacks::read_tracks(e.tracks);
  check_made_from(tf, e.tracks, seq);
  const FrontEndResult& r = tf.result;
  if (seq.gt_poses.empty()) throw Error(seq.manifest.string(), "gt_poses", "the sequence has no ground-truth poses");
  const int n = static_cast<int>(r.poses.size());
  if (r.first_frame + n > static_cast<int>(seq.gt_poses.size()))
    throw Error(e.tracks.string(), "frame_count", "more frames than the sequence's ground truth");
  e.sequence = seq.manifest.string();
  e.estimate = r.poses;
  e.truth.assign(seq.gt_poses.begin() + r.first_frame, seq.gt_poses.begin() + r.first_frame + n);
  e.rigid = absolute_path_error(r.poses, e.truth, PathAlignment::Rigid);
  e.similarity = absolute_path_error(r.poses, e.truth, PathAlignment::Similarity);
  e.rpe = relative_path_error(r.poses, e.truth);
  e.depth = tracked_depth_error(r.tracks, [&](int f) {
    return seq.frames[static_cast<std::size_t>(f)].gt_depth.empty() ? cv::Mat() : seq.load_gt_depth(f);
  });
  // Drift against the raw start-aligned path (both start at the same pose by construction).
  e.end_drift = (pose_centre(r.poses.back()) - pose_centre(e.truth.back())).norm();
  e.summary = r.summary;
  return e;
}

std::string stereo_path_report(const StereoPathEvaluation& e) {
  const PathError& rigid = e.rigid;
  const PathError& sim = e.similarity;
  const RelativeError& rpe = e.rpe;
  const DepthError& depth = e.depth;
  std::string s = printf_string("frames %d, ground-truth path length %.2f m\n", static_cast<int>(e.estimate.size()),
                         rigid.path_length);
  s += printf_string("ATE rigid:      %.3f m RMS (max %.3f m) = %.2f %% of the path length\n", rigid.rmse, rigid.max_error,
              100 * rigid.relative);
  s += printf_string("ATE similarity: %.3f m RMS = %.2f %% (scale %.4f)\n", sim.rmse, 100 * sim.relative, sim.scale);
  s += printf_string("end-point drift (start-aligned): %.3f m = %.2f %%\n", e.end_drift,
              rigid.path_length > 0 ? 100 * e.end_drift / rigid.path_length : 0.0);
  s += printf_string("RPE per frame pair: translation %.4f m RMS (max %.4f), rotation %.4f deg RMS (max %.4f)\n",
              rpe.translation_rmse, rpe.translation_max, rpe.rotation_rmse_deg, rpe.rotation_max_deg);
  s += printf_string("tracked depth error: median %.2f %%, mean %.2f %%, p90 %.2f %%, median signed %+.2f %% "
              "(%ld of %ld observations with ground truth)\n",
              100 * depth.median_relative, 100 * depth.mean_relative, 100 * depth.p90_relative,
              100 * depth.median_signed_relative, depth.evaluated, depth.observations);
  if (const sfm::SfmSummary* m = sfm::sfm_summary_of(e.summary))
    s += printf_string("sfm: focal %.1f px (%s), key frames %d, posed %d / still %d / bridged %d frames, reprojection RMS "
                "%.3f px, scale %.4g m/unit\n",
                m->focal, m->focal_source.c_str(), m->keyframes, m->posed_frames, m->still_frames, m->bridged_frames,
                m->reprojection_rms_px, m->scale);
  return s;
}

Json stereo_path_json(const StereoPathEvaluation& e) {
  const RelativeError& rpe = e.rpe;
  const DepthError& depth = e.depth;
  Json j{{"format", "smseg-stereo-path-eval"},
         {"version", 1},
         {"sequence", e.sequence},
         {"tracks", e.tracks.string()},
         {"ate_rigid", path_json(e.rigid)},
         {"ate_similarity", path_json(e.similarity)},
         {"end_drift_m", e.end_drift},
         {"rpe",
          {{"pairs", rpe.pairs},
           {"translation_rmse_m", rpe.translation_rmse},
           {"translation_max_m", rpe.translation_max},
           {"rotation_rmse_deg", rpe.rotation_rmse_deg},
           {"rotation_max_deg", rpe.rotation_max_deg}}},
         {"depth",
          {{"observations", depth.observations},
           {"evaluated", depth.evaluated},
           {"median_relative", depth.median_relative},
           {"mean_relative", depth.mean_relative},
           {"p90_relative", depth.p90_relative},
           {"median_signed_relative", depth.median_signed_relative}}},
         {"per_frame_error_m", e.rigid.errors}};
  if (const sfm::SfmSummary* m = sfm::sfm_summary_of(e.summary)) j["sfm"] = m->to_json();
  return j;
}

cv::Mat stereo_path_plot(const StereoPathEvaluation& e, int size) {
  const std::vector<Pose>& est = e.estimate;
  const std::vector<Pose>& gt = e.truth;
  cv::Mat img(size, size, CV_8UC3, cv::Scalar(255, 255, 255));
  double x0 = 1e300, x1 = -1e300, z0 = 1e300, z1 = -1e300;
  for (const auto* path : {&est, &gt})
    for (const auto& p : *path) x0 = std::min(x0, p.t[0]), x1 = std::max(x1, p.t[0]), z0 = std::min(z0, p.t[2]), z1 = std::max(z1, p.t[2]);
  const double span = std::max({x1 - x0, z1 - z0, 1e-6}) * 1.1;
  const double cx = 0.5 * (x0 + x1), cz = 0.5 * (z0 + z1);
  auto px = [&](const Pose& p) {
    return cv::Point(static_cast<int>((p.t[0] - cx) / span * size + size / 2),
                     static_cast<int>(size / 2 - (p.t[2] - cz) / span * size));
  };
  for (std::size_t i = 1; i < gt.size(); ++i) cv::line(img, px(gt[i - 1]), px(gt[i]), cv::Scalar(0, 0, 255), 2);
  for (std::size_t i = 1; i < est.size(); ++i) cv::line(img, px(est[i - 1]), px(est[i]), cv::Scalar(0, 0, 0), 1);
  return img;
}

}  // namespace smseg::experiments
