// extract-features: a stereo sequence -> tracks, camera path and per-frame feature stacks.
#include <cstdio>
#include <iostream>
#include <sstream>

#include <tbb/global_control.h>

#include "smseg/cli.hpp"
#include "smseg/features/extract.hpp"

int main(int argc, char** argv) {
  using namespace smseg;
  using namespace smseg::features;
  CLI::App app{
      "Run the front end of a stereo sequence and write its feature stacks (thesis 3.2.2, 3.2.3):\n"
      "disparity (block matching with a left-right check by default), keypoints matched frame to frame\n"
      "(symmetric nearest neighbours), tracks and their filters, camera motion (Arun SVD in RANSAC),\n"
      "then per frame the features fH fC fOx fOy fD fR as summed-area tables, the greyscale image and,\n"
      "for labelled frames, the labels: WORK/stacks.json and WORK/stacks/*.npy. Also WORK/tracks.json\n"
      "(tracks, camera path, front-end summary), WORK/cloud.pcd (one point per track, class colours and\n"
      "labels; opens in pcl_viewer) and WORK/path.png (top-down camera path and cloud). Parallel over\n"
      "frames; frames already written are skipped (resumable) unless --force.",
      "extract-features"};
  std::string seq_dir, work, frames = "0:", stereo = "bm", detector = "sift", preview;
  ExtractOptions opt;
  int threads = 0;
  double camera_height = 0;
  bool quiet = false;
  app.add_option("SEQUENCE", seq_dir, "sequence folder (holding sequence.json)")->required();
  app.add_option("-o,--out", work, "work folder to write")->required();
  app.add_option("--frames", frames, "frames whose stacks are written, A:B half-open (the front end sees all)")
      ->capture_default_str();
  app.add_option("--stereo", stereo, "disparity: bm (block matching) | sgbm (semi-global) | given (from the sequence)")
      ->capture_default_str();
  app.add_option("--num-disparities", opt.front_end.stereo.num_disparities, "disparity search range, multiple of 16")
      ->capture_default_str();
  app.add_option("--block-size", opt.front_end.stereo.block_size, "matching window side (odd)")->capture_default_str();
  app.add_option("--keypoints", detector, "keypoint detector: sift | orb | akaze")->capture_default_str();
  app.add_option("--max-keypoints", opt.front_end.tracking.max_keypoints, "strongest keypoints kept per frame")
      ->capture_default_str();
  app.add_option("--min-track-frames", opt.front_end.filters.min_frames, "a track must live in this many frames")
      ->capture_default_str();
  app.add_flag("--require-label", opt.front_end.filters.require_label,
               "drop tracks that never pass through a labelled frame (the thesis's training filter)");
  bool no_refine = false;
  app.add_flag("--no-refine", no_refine,
               "motion from RANSAC + Arun SVD alone (the thesis method), without the reprojection refinement");
  app.add_option("--camera-height", camera_height, "camera height above the ground in metres (default: the sequence's)");
  app.add_flag("--causal", opt.features.causal, "fC from the camera path up to the current frame only (on-line use)");
  app.add_option("--future-frames", opt.features.future_frames, "frames of camera motion applied to a point's last position (fC)")
      ->capture_default_str();
  app.add_option("--preview", preview, "comma-separated frames to write false-colour feature pictures of (WORK/preview/)");
  app.add_flag("--force", opt.force, "rewrite frames already done (and a work folder made with other options)");
  app.add_option("--threads", threads, "worker threads (0: all cores); the output does not depend on it")
      ->capture_default_str();
  app.add_flag("-q,--quiet", quiet, "no progress on stderr");
  return run_tool(app, argc, argv, [&] {
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
    opt.front_end.stereo.method = parse_stereo_method(stereo, "--stereo");
    opt.front_end.tracking.detector = parse_keypoint_method(detector, "--keypoints");
    if (app.count("--camera-height")) {
      if (!(camera_height > 0)) throw Error("", "--camera-height", "must be positive (metres)");
      opt.front_end.camera_height = camera_height;
    }
    opt.front_end.refine.enabled = !no_refine;
    opt.frames = FrameRange::parse(frames, "--frames");
    std::stringstream ss(preview);
    for (std::string item; std::getline(ss, item, ',');)
      if (!item.empty()) opt.preview.push_back(FrameRange::parse(item, "--preview").begin);
    opt.progress = !quiet;
    opt.front_end.validate();
    opt.features.validate();
    const Sequence seq = load_sequence(seq_dir);
    const ExtractReport r = extract_features(seq, work, opt);
    write_cloud(fs::path(work) / "cloud.pcd", r.cloud, seq);
    const auto& s = r.summary;
    char line[512];
    std::snprintf(line, sizeof line,
                  "%s: %d frames written, %d already done; front end %.1f s (%.1f ms/frame), features %.2f ms/frame;\n"
                  "valid points per frame: mean %.0f, min %d; tracks kept %ld of %ld; mean track length %.1f; "
                  "motion inlier ratio %.2f; bridged pairs %zu; %.1f MB per frame on disk",
                  work.c_str(), r.frames_written, r.frames_skipped, r.front_end_seconds,
                  1000 * r.front_end_seconds / std::max(1, s.frames), 1000 * r.features_seconds_per_frame,
                  s.valid_points_per_frame_mean, s.valid_points_per_frame_min, s.filters.kept_tracks, s.filters.tracks,
                  s.track_length_mean, s.inlier_ratio_mean, s.bridged_pairs.size(), r.bytes_per_frame / 1e6);
    std::cout << line << "\n";
    return 0;
  });
}
