// eval-stereo-path: accuracy of a front end's output (WORK/tracks.json, from the stereo front end or
// from monocular structure from motion, `extract-features --motion sfm`) against a synthetic sequence's
// ground truth: absolute trajectory error (rigid and similarity alignment) as metres and as a share of
// the path length, relative pose error per frame pair, and the relative depth error of the tracked
// points. For SfM work folders it also repeats what the SfM reported (focal length and its source,
// reprojection RMS, key frames, posed / still / bridged frames).
#include <cstdio>
#include <iostream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "smseg/common/cli.hpp"
#include "smseg/frontend/trajectory.hpp"
#include "smseg/frontend/tracks_io.hpp"
#include "smseg/common/io.hpp"

namespace {

using namespace smseg;
using namespace smseg::features;

Json path_json(const PathError& e) {
  return Json{{"rmse_m", e.rmse},       {"max_m", e.max_error}, {"path_length_m", e.path_length},
              {"relative", e.relative}, {"scale", e.scale},     {"frames", e.frames}};
}

// Top-down (world X-Z) plot, ground truth red, estimate black (both as given, aligned at frame 0).
cv::Mat plot(const std::vector<Pose>& est, const std::vector<Pose>& gt, int size) {
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Accuracy of the front end (stereo or monocular SfM) against a synthetic sequence's ground truth: absolute\n"
               "trajectory error (camera centres, rigid and similarity Umeyama alignment) in metres and as a\n"
               "share of the ground-truth path length, relative pose error per frame pair, and the median\n"
               "relative depth error of the tracked points (WORK/tracks.json) against the ground-truth depth.",
               "eval-stereo-path"};
  std::string seq_path, work, out, plot_path;
  app.add_option("sequence", seq_path, "sequence folder (or its sequence.json), with ground-truth poses and depth")
      ->required();
  app.add_option("work", work, "work folder holding tracks.json (or the tracks file itself)")->required();
  app.add_option("-o,--output", out, "result JSON file (default: none, report on stdout only)");
  app.add_option("--plot", plot_path, "top-down PNG of both paths (red: ground truth, black: estimate)");
  return run_tool(app, argc, argv, [&] {
    const Sequence seq = load_sequence(seq_path);
    fs::path tracks_path = work;
    if (fs::is_directory(tracks_path)) tracks_path /= "tracks.json";
    const TracksFile tf = read_tracks(tracks_path);
    const FrontEndResult& r = tf.result;
    if (seq.gt_poses.empty()) throw Error(seq.manifest.string(), "gt_poses", "the sequence has no ground-truth poses");
    const int n = static_cast<int>(r.poses.size());
    if (r.first_frame + n > static_cast<int>(seq.gt_poses.size()))
      throw Error(tracks_path.string(), "frame_count", "more frames than the sequence's ground truth");
    const std::vector<Pose> gt(seq.gt_poses.begin() + r.first_frame, seq.gt_poses.begin() + r.first_frame + n);
    const PathError rigid = absolute_path_error(r.poses, gt, PathAlignment::Rigid);
    const PathError sim = absolute_path_error(r.poses, gt, PathAlignment::Similarity);
    const RelativeError rpe = relative_path_error(r.poses, gt);
    const DepthError depth = tracked_depth_error(r.tracks, [&](int f) {
      return seq.frames[static_cast<std::size_t>(f)].gt_depth.empty() ? cv::Mat() : seq.load_gt_depth(f);
    });
    // Drift against the raw start-aligned path (both start at the same pose by construction).
    const double end_drift = (pose_centre(r.poses.back()) - pose_centre(gt.back())).norm();

    std::printf("frames %d, ground-truth path length %.2f m\n", n, rigid.path_length);
    std::printf("ATE rigid:      %.3f m RMS (max %.3f m) = %.2f %% of the path length\n", rigid.rmse, rigid.max_error,
                100 * rigid.relative);
    std::printf("ATE similarity: %.3f m RMS = %.2f %% (scale %.4f)\n", sim.rmse, 100 * sim.relative, sim.scale);
    std::printf("end-point drift (start-aligned): %.3f m = %.2f %%\n", end_drift,
                rigid.path_length > 0 ? 100 * end_drift / rigid.path_length : 0.0);
    std::printf("RPE per frame pair: translation %.4f m RMS (max %.4f), rotation %.4f deg RMS (max %.4f)\n",
                rpe.translation_rmse, rpe.translation_max, rpe.rotation_rmse_deg, rpe.rotation_max_deg);
    std::printf("tracked depth error: median %.2f %%, mean %.2f %%, p90 %.2f %%, median signed %+.2f %% "
                "(%ld of %ld observations with ground truth)\n",
                100 * depth.median_relative, 100 * depth.mean_relative, 100 * depth.p90_relative,
                100 * depth.median_signed_relative, depth.evaluated, depth.observations);
    if (const auto& m = r.summary.sfm)
      std::printf("sfm: focal %.1f px (%s), key frames %d, posed %d / still %d / bridged %d frames, reprojection RMS "
                  "%.3f px, scale %.4g m/unit\n",
                  m->focal, m->focal_source.c_str(), m->keyframes, m->posed_frames, m->still_frames, m->bridged_frames,
                  m->reprojection_rms_px, m->scale);
    if (!out.empty()) {
      Json j{{"format", "smseg-stereo-path-eval"},
             {"version", 1},
             {"sequence", seq.manifest.string()},
             {"tracks", tracks_path.string()},
             {"ate_rigid", path_json(rigid)},
             {"ate_similarity", path_json(sim)},
             {"end_drift_m", end_drift},
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
             {"per_frame_error_m", rigid.errors}};
      if (r.summary.sfm) j["sfm"] = summary_to_json(r.summary)["sfm"];
      write_json_atomic(out, j);
    }
    if (!plot_path.empty()) cv::imwrite(plot_path, plot(r.poses, gt, 700));
    return 0;
  });
}
