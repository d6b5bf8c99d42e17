// ExtractOptions declared once (options.hpp): the options of extract-features, the keywords of Python's
// extract_features, run-experiment's extraction keys; and the one place that turns what the user chose
// (a tracker, keypoints, "auto") into the two front ends' options.
#include "smseg/common/options.hpp"
#include "smseg/sfm/sfm_options.hpp"
#include "smseg/stacks/extract.hpp"
#include "smseg/stacks/front_ends.hpp"

namespace smseg::stacks {

namespace {

using E = ExtractOptions;
using options::kCommandLine;
using options::kConfig;
using options::kPython;


// Names checked here and resolved by ExtractOptions::resolve (which front end, which tracker).
std::string motion_name(const std::string& name, const std::string& field) {
  check_motion_name(name, field);
  return name;
}
std::string tracker_name(const std::string& name, const std::string& field) {
  if (name != "auto") frontend::parse_stereo_tracker(name, field);  // klt | descriptors, as the SfM's
  return name;
}
std::string keypoints_name(const std::string& name, const std::string& field) {
  if (name != "auto") frontend::parse_keypoint_method(name, field);
  return name;
}

void declare_choices(options::Table<E>& t) {
  // Configs have their own motion, stereo and tracker keys (train_/test_ sides, other defaults).
  t.named("motion", "--motion",
          "the front end tracks and camera motion come from (auto: stereo for stereo sequences, sfm, monocular\n"
          "structure from motion on the left images, for mono ones; vo: causal monocular visual odometry, what\n"
          "label-stream runs on a mono sequence: with --causal its labels)",
          [](auto& o) -> auto& { return o.motion; }, front_end_choices(), &motion_name, &options::as_written)
      .only(kCommandLine | kPython);
  t.named("stereo", "--stereo",
          "disparity (bm: block matching, sgbm: semi-global, given: from the sequence, sparse: bm's matching and\n"
          "checks at the tracked points only, without bm's speckle filter; no dense pass)",
          [](auto& o) -> auto& { return o.front_end.stereo.method; }, "bm | sgbm | given | sparse",
          +[](const std::string& s, const std::string& f) { return frontend::parse_stereo_method(s, f); },
          +[](const frontend::StereoMethod& m) { return std::string(frontend::stereo_method_name(m)); })
      .only(kCommandLine | kPython);
  t.number("num_disparities", "--num-disparities", "disparity search range, multiple of 16",
           [](auto& o) -> auto& { return o.front_end.stereo.num_disparities; }, 16, 1024)
      .checked_as("stereo.num_disparities");
  t.number("block_size", "--block-size", "matching window side (odd)",
           [](auto& o) -> auto& { return o.front_end.stereo.block_size; }, 1, 255)
      .checked_as("stereo.block_size");
  t.named("lr_check", "--lr-check",
          "bm's left-right check: mirrored (a second match on the mirrored pair; the stricter) | matcher\n"
          "(OpenCV's own from the left match's costs: half the matching time, more pixels and more wrong ones;\n"
          "with --stereo bm only)",
          [](auto& o) -> auto& { return o.front_end.stereo.lr_check; }, "mirrored | matcher",
          +[](const std::string& s, const std::string& f) { return frontend::parse_left_right_check(s, f); },
          +[](const frontend::LeftRightCheck& c) { return std::string(frontend::left_right_check_name(c)); })
      .checked_as("stereo.lr_check");
  t.named("keypoints", "--keypoints",
          "keypoint detector (auto: stereo gftt with the klt tracker, sift with descriptors; sfm: sift; gftt:\n"
          "Shi-Tomasi corners, no descriptors: --tracker klt only)",
          [](auto& o) -> auto& { return o.keypoints; }, "auto | sift | orb | akaze | gftt", &keypoints_name,
          &options::as_written)
      .checked_as("tracking.detector");
  t.optional_number("max_keypoints", "--max-keypoints",
                    "strongest keypoints kept per frame (default: " + std::to_string(frontend::TrackingOptions{}.max_keypoints) +
                        " stereo, " + std::to_string(sfm::SfmOptions{}.tracking.max_keypoints) + " sfm)",
                    [](auto& o) -> auto& { return o.max_keypoints; }, 1, 100000)
      .checked_as("tracking.max_keypoints");
  t.number("gftt_quality", "--gftt-quality", "gftt: corners weaker than this share of the strongest are dropped",
           [](auto& o) -> auto& { return o.front_end.tracking.gftt_quality; }, 1e-6, 0.999999)
      .checked_as("tracking.gftt_quality");
  t.named("tracker", "--tracker",
          "how keypoints are followed from frame to frame: descriptors (symmetric nearest-neighbour matching of\n"
          "the keypoints' descriptors; sfm: for wide baselines such as CamVid's 1 Hz runs) | klt (pyramidal\n"
          "Lucas-Kanade from each point, forward-backward checked, new keypoints filling gaps; for video) | auto\n"
          "(stereo: klt, which drifts less than the thesis's descriptor matching; sfm: descriptors with\n"
          "whole-image matching and Lowe ratio 0.8 when frames are more than 0.25 s apart, else klt)",
          [](auto& o) -> auto& { return o.tracker; }, "auto | klt | descriptors", &tracker_name, &options::as_written)
      .only(kCommandLine | kPython);
}

void declare_tracks_and_motion(options::Table<E>& t) {
  t.number("min_track_frames", "--min-track-frames", "a track must live in this many frames",
           [](auto& o) -> auto& { return o.front_end.filters.min_frames; }, 1, 100000)
      .checked_as("filters.min_frames");
  t.flag("require_label", "--require-label",
         "training only: drop tracks that never pass through a labelled frame and tracks whose labels\n"
         "disagree (the thesis's training filters; they read the ground truth, so never use them on\n"
         "frames you score)",
         [](auto& o) -> auto& { return o.front_end.filters.require_label; });
  t.flag("no_refine", "--no-refine",
         "motion from RANSAC + Arun SVD alone (the thesis method), without the reprojection refinement",
         [](auto& o) -> auto& { return o.no_refine; });
  t.named("gravity", "--gravity",
          "stereo: world Y up along the first camera's up axis (level: the thesis assumes it level) | along\n"
          "gravity estimated from the camera path and a RANSAC ground plane (estimate; docs/stereo.md)",
          [](auto& o) -> auto& { return o.front_end.gravity.method; }, "level | estimate",
          +[](const std::string& s, const std::string& f) { return frontend::parse_gravity_method(s, f); },
          +[](const frontend::GravityMethod& m) { return std::string(frontend::gravity_method_name(m)); });
  t.named("disparity_offset", "--disparity-offset",
          "stereo: pixels added to every computed disparity, for a right image offset against its calibration\n"
          "(auto: the calibration's plus what the first 11 frames' tracks ask for, held for the rest and kept\n"
          "only when it lowers their median reprojection error by 5 %; calibration: the sequence's as it is)",
          [](auto& o) -> auto& { return o.front_end.disparity_offset; },
          "auto | calibration | PX",
          +[](const std::string& s, const std::string& f) { return frontend::parse_disparity_offset(s, f); },
          +[](const frontend::DisparityOffsetChoice& c) { return frontend::disparity_offset_name(c); });
  t.optional_number("camera_height", "--camera-height",
                    "camera height above the ground in metres (default: the sequence's)",
                    [](auto& o) -> auto& { return o.front_end.camera_height; }, 1e-3, 1e4)
      .checked_as("sfm.camera_height");
}

}  // namespace

const options::Table<ExtractOptions>& extract_options_table() {
  static const options::Table<E> table = [] {
    // stacks.json records what the front ends and the features make of these (FrontEnd::options_json,
    // feature_options_json), so only the features' own fields are on files.
    options::Table<E> t("extract_features", kCommandLine | kConfig | kPython);
    declare_choices(t);
    declare_tracks_and_motion(t);
    t.include(sfm::sfm_options_table(), [](auto& o) -> auto& { return o.sfm; });
    t.include(feature_options_table(), [](auto& o) -> auto& { return o.features; });
    // What a run does, not how its stacks are made: neither recorded nor in configs.
    t.flag("force", "--force", "rewrite frames already done (and a work folder made with other options)",
           [](auto& o) -> auto& { return o.force; })
        .only(kCommandLine | kPython);
    return t;
  }();
  return table;
}

void ExtractOptions::resolve() {
  front_end.tracker = frontend::parse_stereo_tracker(stereo_tracker != "auto" ? stereo_tracker : tracker, "tracker");
  front_end.tracking.detector = frontend::parse_keypoint_method(keypoints, front_end.tracker, "keypoints");
  front_end.refine.enabled = !no_refine;
  sfm.tracker = sfm::parse_sfm_tracker(tracker, "tracker");
  sfm.tracking.detector = keypoints == "auto" ? frontend::KeypointMethod::Sift : frontend::parse_keypoint_method(keypoints, "keypoints");
  sfm.tracking.gftt_quality = front_end.tracking.gftt_quality;
  if (max_keypoints) front_end.tracking.max_keypoints = sfm.tracking.max_keypoints = *max_keypoints;
  sfm.filters = front_end.filters;
}

void ExtractOptions::validate() const {
  front_end.validate();
  sfm.validate();
  features.validate();
}

}  // namespace smseg::stacks
