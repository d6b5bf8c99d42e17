// extract-features: a sequence -> tracks, camera path (stereo, or monocular structure from motion) and
// per-frame feature stacks.
#include <cstdio>
#include <iostream>
#include <sstream>


#include "smseg/cloud/cloud_io.hpp"
#include "smseg/common/cli.hpp"
#include "smseg/common/option_names.hpp"
#include "smseg/stacks/extract.hpp"

int main(int argc, char** argv) {
  using namespace smseg;
  using namespace smseg::features;
  CLI::App app{
      "Run the front end of a sequence and write its feature stacks (thesis 3.2.2, 3.2.3, 3.2.6).\n"
      "Stereo (default for stereo sequences): disparity (block matching with a left-right check by\n"
      "default), Shi-Tomasi corners followed frame to frame by KLT (or SIFT keypoints matched by\n"
      "symmetric nearest neighbours, the thesis's way, with --tracker descriptors), tracks and their\n"
      "filters, camera motion (Arun SVD in RANSAC). Monocular structure from motion (always for mono\n"
      "sequences, --motion sfm for the left images of a stereo one): KLT or descriptor tracks, focal\n"
      "length from --focal, the manifest or self-calibration, essential-matrix initialisation, PnP, key\n"
      "frames and bundle adjustment (Ceres), metric scale from the camera height over a RANSAC ground\n"
      "plane (docs/sfm.md). Then per frame the features fH fC fOx fOy fD fR (and with --appearance nine\n"
      "image channels) as summed-area tables, the greyscale image and,\n"
      "for labelled frames, the labels: WORK/stacks.json and WORK/stacks/*.npy. Also WORK/tracks.json\n"
      "(tracks, camera path, front-end summary), WORK/cloud.pcd (one point per track, class colours and\n"
      "labels; opens in pcl_viewer) and WORK/path.png (top-down camera path and cloud). Parallel over\n"
      "frames; frames already written are skipped unless --force: a killed or failed run resumes, keeping\n"
      "every stack on disk made with the same options from the same sequence (the front end runs again).",
      "extract-features"};
  std::string seq_dir, work, frames = "0:", stereo = "bm", detector = "auto", preview, motion = "auto",
      tracker = "auto", height_reference = "auto";
  ExtractOptions opt;
  int threads = 0;
  double camera_height = 0, focal = 0;
  const SfmOptions sfm_defaults;
  bool quiet = false, verbose = false;
  app.add_option("SEQUENCE", seq_dir, "sequence folder (holding sequence.json)")->required();
  app.add_option("-o,--out", work, "work folder to write")->required();
  app.add_option("--frames", frames, "frames whose stacks are written, A:B half-open (the front end sees all)")
      ->capture_default_str();
  app.add_option("--motion", motion,
                 "the front end tracks and camera motion come from: " + front_end_choices() +
                     " (auto: stereo for stereo sequences, sfm, monocular structure from motion on the left "
                     "images, for mono ones)")
      ->capture_default_str();
  app.add_option("--stereo", stereo, "disparity: bm (block matching) | sgbm (semi-global) | given (from the sequence)")
      ->capture_default_str();
  app.add_option("--num-disparities", opt.front_end.stereo.num_disparities, "disparity search range, multiple of 16")
      ->capture_default_str();
  app.add_option("--block-size", opt.front_end.stereo.block_size, "matching window side (odd)")->capture_default_str();
  app.add_option("--keypoints", detector,
                 "keypoint detector: auto (stereo: gftt with the klt tracker, sift with descriptors; sfm: sift) |\n"
                 "sift | orb | akaze | gftt (Shi-Tomasi corners, no descriptors: --tracker klt only)")
      ->capture_default_str();
  app.add_option("--max-keypoints", opt.front_end.tracking.max_keypoints,
                 "strongest keypoints kept per frame (default: " + std::to_string(opt.front_end.tracking.max_keypoints) +
                     " stereo, " + std::to_string(sfm_defaults.tracking.max_keypoints) + " sfm)");
  app.add_option("--gftt-quality", opt.front_end.tracking.gftt_quality,
                 "gftt: corners weaker than this share of the strongest are dropped")
      ->capture_default_str();
  app.add_option("--min-track-frames", opt.front_end.filters.min_frames, "a track must live in this many frames")
      ->capture_default_str();
  app.add_flag("--require-label", opt.front_end.filters.require_label,
               "training only: drop tracks that never pass through a labelled frame and tracks whose labels\n"
               "disagree (the thesis's training filters; they read the ground truth, so never use them on\n"
               "frames you score)");
  bool no_refine = false;
  app.add_flag("--no-refine", no_refine,
               "motion from RANSAC + Arun SVD alone (the thesis method), without the reprojection refinement");
  std::string gravity = "level";
  app.add_option("--gravity", gravity,
                 "stereo: world Y up along the first camera's up axis (level: the thesis assumes it level) | along\n"
                 "gravity estimated from the camera path and a RANSAC ground plane (estimate; docs/stereo.md)")
      ->capture_default_str();
  app.add_option("--camera-height", camera_height, "camera height above the ground in metres (default: the sequence's)");
  app.add_option("--focal", focal,
                 "sfm: focal length in pixels (default: the manifest's fx, else estimated by self-calibration, "
                 "else the image width)");
  app.add_option("--tracker", tracker,
                 "how keypoints are followed from frame to frame: descriptors (symmetric nearest-neighbour "
                 "matching of the keypoints' descriptors; sfm: for wide baselines such as CamVid's 1 Hz runs) | klt "
                 "(pyramidal Lucas-Kanade from each point, forward-backward checked, new keypoints filling gaps; "
                 "for video) | auto (stereo: klt, which drifts less than the thesis's descriptor matching; sfm: "
                 "descriptors with whole-image matching and Lowe ratio 0.8 when frames are more than 0.25 s apart, "
                 "else klt)")
      ->capture_default_str();
  app.add_option("--match-radius", opt.sfm.match_radius_px,
                 "sfm, descriptors: match candidates within this many pixels; 0 = the whole image (wide baselines)")
      ->capture_default_str();
  app.add_option("--lowe-ratio", opt.sfm.lowe_ratio,
                 "sfm, descriptors: Lowe's ratio test, e.g. 0.8 for wide baselines; 0 = off")
      ->capture_default_str();
  app.add_option("--epipolar-ratio", opt.sfm.epipolar_ratio,
                 "sfm, descriptors: match each verified pair again along its epipolar lines, with this ratio test;\n"
                 "0 = off")
      ->capture_default_str();
  app.add_option("--map-window", opt.sfm.map_window,
                 "sfm, descriptors: also match each frame's keypoints to the 3D points of this many frames before\n"
                 "it (joins tracks broken by a missed match); 0 = off")
      ->capture_default_str();
  app.add_option("--reprojection-threshold", opt.sfm.reprojection_threshold_px,
                 "sfm: inlier threshold of PnP, triangulation and the final filter, pixels")
      ->capture_default_str();
  app.add_option("--keyframe-motion", opt.sfm.keyframe_motion_px,
                 "sfm: median track motion since the last key frame that makes a key frame, pixels")
      ->capture_default_str();
  app.add_option("--ba-window", opt.sfm.ba_window, "sfm: key frames in the local bundle adjustment")
      ->capture_default_str();
  app.add_option("--seed", opt.sfm.seed, "sfm: RANSAC seed")->capture_default_str()
      ->check(smseg::kDecimalDigits);
  app.add_flag("--causal", opt.features.causal,
               "only what is known at each frame (on-line use, what label-stream computes): fC from the camera\n"
               "path up to the frame, and a track's points from the frame it reaches --min-track-frames on");
  app.add_flag("--appearance", opt.features.appearance,
               "also the image's own channels, after the six: fL fA fB (Lab colour), fG0..fG3 (gradient\n"
               "magnitude by orientation) and fRow fCol (position); train-forest --features fH,fC,fOx,fOy,fD,fR\n"
               "leaves them out (structure and motion only)");
  app.add_flag("--dense", opt.features.dense,
               "also dense geometry channels, after the others: fZV (valid), fZI (inverse depth), fZH (height),\n"
               "fZU (surface facing up), fZE (depth edges), fZC (distance to the camera path), from semi-global\n"
               "matching (stereo) or a plane sweep over the SfM's posed neighbour frames (mono); structure and\n"
               "motion, not appearance (docs/stereo.md, docs/sfm.md)");
  app.add_option("--sweep-baseline", opt.features.sweep_baseline,
                 "--dense, monocular: metres between the frame's camera and each neighbour the plane sweep reads\n"
                 "(the nearest frame each side at least this far, within --sweep-reach frames); a video much\n"
                 "denser than its training runs can match their baseline (docs/camvid.md)")
      ->capture_default_str();
  app.add_option("--sweep-reach", opt.features.sweep_reach,
                 "--dense, monocular: frames either side the plane sweep looks for its neighbours in")
      ->capture_default_str();
  app.add_option("--height-reference", height_reference,
                 "what fH and fZH measure heights from: plane (the run's ground plane, world Y), camera (the\n"
                 "ground under each frame's camera: its height relative to the camera plus the cameras' median\n"
                 "height, so a drifting monocular camera path does not shift them) or auto (camera for\n"
                 "structure from motion, plane for stereo)")
      ->capture_default_str();
  app.add_option("--future-frames", opt.features.future_frames,
                 "frames of camera motion applied to a point's last position (fC), and of the camera path\n"
                 "ahead that fZC measures to (--dense)")
      ->capture_default_str();
  app.add_option("--preview", preview, "comma-separated frames to write false-colour feature pictures of (WORK/preview/)");
  app.add_flag("--force", opt.force, "rewrite frames already done (and a work folder made with other options)");
  add_threads_option(app, threads, "the output does not depend on it");
  auto* quiet_flag = app.add_flag("-q,--quiet", quiet, "nothing on stderr but errors (no progress, no solver warnings)");
  app.add_flag("-v,--verbose", verbose, "also the solver libraries' warnings and one summary per bundle adjustment (SfM)")
      ->excludes(quiet_flag);
  return run_tool(app, argc, argv, threads, [&] {
    opt.front_end.stereo.method = parse_stereo_method(stereo, "--stereo");
    opt.front_end.tracker = parse_stereo_tracker(tracker, "--tracker");
    opt.front_end.tracking.detector = parse_keypoint_method(detector, opt.front_end.tracker, "--keypoints");
    check_motion_name(motion, "--motion");
    opt.motion = motion;
    opt.sfm.tracking.detector = detector == "auto" ? KeypointMethod::Sift : parse_keypoint_method(detector, "--keypoints");
    opt.sfm.tracking.gftt_quality = opt.front_end.tracking.gftt_quality;
    if (app.count("--max-keypoints")) opt.sfm.tracking.max_keypoints = opt.front_end.tracking.max_keypoints;
    opt.sfm.filters = opt.front_end.filters;
    opt.sfm.tracker = parse_sfm_tracker(tracker, "--tracker");
    if (app.count("--camera-height")) {
      if (!(camera_height > 0)) throw UsageError("", "--camera-height", "must be positive (metres)");
      opt.front_end.camera_height = camera_height;
    }
    opt.front_end.refine.enabled = !no_refine;
    opt.front_end.gravity.method = as_usage([&] { return parse_gravity_method(gravity, "--gravity"); });
    if (app.count("--focal")) {
      if (!(focal > 0)) throw UsageError("", "--focal", "must be positive (pixels)");
      opt.sfm.focal = focal;
    }
    opt.features.height_reference =
        as_usage([&] { return height_reference_from_string(height_reference, "--height-reference"); });
    opt.frames = as_usage([&] { return FrameRange::parse(frames, "--frames"); });
    std::stringstream ss(preview);
    for (std::string item; std::getline(ss, item, ',');)
      if (!item.empty()) opt.preview.push_back(FrameRange::parse(item, "--preview").begin);
    opt.progress = !quiet;
    set_solver_verbose(verbose);
    static const OptionNames kOptionOf = {
        {"stereo.num_disparities", "--num-disparities"}, {"stereo.block_size", "--block-size"},
        {"tracking.max_keypoints", "--max-keypoints"},   {"tracking.gftt_quality", "--gftt-quality"},
        {"filters.min_frames", "--min-track-frames"},    {"camera_height", "--camera-height"},
        {"sfm.match_radius_px", "--match-radius"},       {"sfm.lowe_ratio", "--lowe-ratio"},
        {"sfm.reprojection_threshold_px", "--reprojection-threshold"},
        {"sfm.keyframe_motion_px", "--keyframe-motion"}, {"sfm.ba_window", "--ba-window"},
        {"sfm.map_window", "--map-window"},              {"sfm.epipolar_ratio", "--epipolar-ratio"},
        {"sfm.focal", "--focal"},                        {"sfm.camera_height", "--camera-height"}};
    validate_options(kOptionOf, [&] {
      opt.front_end.validate();
      opt.sfm.validate();
      opt.features.validate();
    });
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
    if (s.sfm) {
      const SfmSummary& m = *s.sfm;
      std::snprintf(line, sizeof line,
                    "sfm (%s): focal %.1f px (%s); key frames %d; frames posed %d, still %d, bridged %d of %d; "
                    "reprojection RMS %.3f px over %ld observations; scale %.4g m/unit (ground inliers %d); "
                    "%.1f ms/frame SfM of which %.1f BA",
                    m.tracker.c_str(), m.focal, m.focal_source.c_str(), m.keyframes, m.posed_frames, m.still_frames, m.bridged_frames,
                    s.frames, m.reprojection_rms_px, m.observations, m.scale, m.ground_inliers,
                    1000 * m.seconds_sfm, 1000 * m.seconds_ba);
      std::cout << line << "\n";
    }
    return 0;
  });
}
