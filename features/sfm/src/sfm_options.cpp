// The monocular SfM's options and summaries: names, JSON, validation (see sfm.hpp).
#include "smseg/sfm/sfm.hpp"
#include "smseg/sfm/sfm_options.hpp"

#include "smseg/common/names.hpp"
#include "smseg/common/options.hpp"
#include "sfm_matching.hpp"

namespace smseg::sfm {

namespace {
constexpr std::array<EnumName<FocalSource>, 4> kFocalSourceNames{{{FocalSource::Option, "option"},
                                                                 {FocalSource::Manifest, "manifest"},
                                                                 {FocalSource::Estimated, "estimated"},
                                                                 {FocalSource::Fallback, "fallback"}}};
constexpr std::array<EnumName<SfmTracker>, 3> kSfmTrackerNames{
    {{SfmTracker::Auto, "auto"}, {SfmTracker::Klt, "klt"}, {SfmTracker::Descriptors, "descriptors"}}};
}  // namespace

const char* focal_source_name(FocalSource s) { return name_of(kFocalSourceNames, s); }
const char* sfm_tracker_name(SfmTracker t) { return name_of(kSfmTrackerNames, t); }
SfmTracker parse_sfm_tracker(const std::string& name, const std::string& field) {
  return value_named(kSfmTrackerNames, name, field);
}

SfmOptions resolve_tracker(const SfmOptions& options, const sequence::Sequence& seq) {
  SfmOptions o = options;
  if (o.tracker != SfmTracker::Auto) return o;
  std::vector<double> dt;
  for (int i = 1; i < seq.frame_count(); ++i) dt.push_back(seq.frames[i].time - seq.frames[i - 1].time);
  if (!dt.empty() && sfm_matching::median(dt) > 0.25) {
    o.tracker = SfmTracker::Descriptors;
    o.match_radius_px = 0;
    if (o.lowe_ratio == 0) o.lowe_ratio = 0.8;
  } else {
    o.tracker = SfmTracker::Klt;
  }
  return o;
}

const options::Table<SfmOptions>& sfm_options_table() {
  using O = SfmOptions;
  static const options::Table<O> table = [] {
    options::Table<O> t("sfm", options::kCommandLine | options::kConfig | options::kPython);
    t.optional_number("focal", "--focal",
                      "sfm: focal length in pixels (default: the manifest's fx, else estimated by self-calibration, "
                      "else the image width)",
                      [](auto& o) -> auto& { return o.focal; }, 1.0, 1e6)
        .checked_as("sfm.focal");
    t.number("match_radius", "--match-radius",
             "sfm, descriptors: match candidates within this many pixels; 0 = the whole image (wide baselines)",
             [](auto& o) -> auto& { return o.match_radius_px; }, 0.0, 1e5)
        .checked_as("sfm.match_radius_px");
    t.number("lowe_ratio", "--lowe-ratio", "sfm, descriptors: Lowe's ratio test, e.g. 0.8 for wide baselines; 0 = off",
             [](auto& o) -> auto& { return o.lowe_ratio; }, 0.0, 0.999999)
        .checked_as("sfm.lowe_ratio");
    t.number("epipolar_ratio", "--epipolar-ratio",
             "sfm, descriptors: match each verified pair again along its epipolar lines, with this ratio test;\n"
             "0 = off",
             [](auto& o) -> auto& { return o.epipolar_ratio; }, 0.0, 0.999999)
        .checked_as("sfm.epipolar_ratio");
    t.number("map_window", "--map-window",
             "sfm, descriptors: also match each frame's keypoints to the 3D points of this many frames before\n"
             "it (joins tracks broken by a missed match); 0 = off",
             [](auto& o) -> auto& { return o.map_window; }, 0, 30)
        .checked_as("sfm.map_window");
    t.number("reprojection_threshold", "--reprojection-threshold",
             "sfm: inlier threshold of PnP, triangulation and the final filter, pixels",
             [](auto& o) -> auto& { return o.reprojection_threshold_px; }, 1e-3, 1e3)
        .checked_as("sfm.reprojection_threshold_px");
    t.number("keyframe_motion", "--keyframe-motion",
             "sfm: median track motion since the last key frame that makes a key frame, pixels",
             [](auto& o) -> auto& { return o.keyframe_motion_px; }, 1e-3, 1e4)
        .checked_as("sfm.keyframe_motion_px");
    t.number("ba_window", "--ba-window", "sfm: key frames in the local bundle adjustment",
             [](auto& o) -> auto& { return o.ba_window; }, 3, 1000)
        .checked_as("sfm.ba_window");
    t.number("sfm_seed", "--seed", "sfm: RANSAC seed", [](auto& o) -> auto& { return o.seed; },
             std::uint64_t{0}, std::numeric_limits<std::uint64_t>::max());
    return t;
  }();
  return table;
}

Json sfm_options_to_json(const SfmOptions& o) {
  Json j{{"tracker", sfm_tracker_name(o.tracker)},
         {"klt_window", o.klt.window},
         {"klt_max_backward_px", o.klt.max_backward_px},
         {"klt_min_distance_px", o.klt.min_distance_px},
         {"tracking",
          {{"detector", frontend::keypoint_method_name(o.tracking.detector)},
           {"max_keypoints", o.tracking.max_keypoints},
           {"sift_contrast_threshold", o.tracking.sift_contrast_threshold},
           {"akaze_threshold", o.tracking.akaze_threshold},
           {"gftt_quality", o.tracking.gftt_quality},
           {"max_descriptor_distance", o.tracking.max_descriptor_distance},
           {"max_pixel_motion", o.tracking.max_pixel_motion}}},
         {"filters", {{"min_frames", o.filters.min_frames}, {"require_label", o.filters.require_label}}},
         {"match_radius_px", o.match_radius_px},
         {"lowe_ratio", o.lowe_ratio},
         {"epipolar_ratio", o.epipolar_ratio},
         {"fundamental_threshold_px", o.fundamental_threshold_px},
         {"still_motion_px", o.still_motion_px},
         {"init_motion_px", o.init_motion_px},
         {"init_min_angle_deg", o.init_min_angle_deg},
         {"keyframe_motion_px", o.keyframe_motion_px},
         {"min_triangulation_angle_deg", o.min_triangulation_angle_deg},
         {"reprojection_threshold_px", o.reprojection_threshold_px},
         {"min_pnp_points", o.min_pnp_points},
         {"map_window", o.map_window},
         {"ba_window", o.ba_window},
         {"ba_iterations", o.ba_iterations},
         {"final_ba", o.final_ba},
         {"final_ba_iterations", o.final_ba_iterations},
         {"ground_min_angle_deg", o.ground_min_angle_deg},
         {"ground_min_row_share", o.ground_min_row_share},
         {"ground_threshold", o.ground_threshold},
         {"ground_max_tilt_deg", o.ground_max_tilt_deg},
         {"ground_iterations", o.ground_iterations},
         {"ground_min_inliers", o.ground_min_inliers},
         {"seed", o.seed},
         {"first_frame", o.first_frame},
         {"last_frame", o.last_frame}};
  if (o.focal) j["focal"] = *o.focal;
  if (o.camera_height) j["camera_height"] = *o.camera_height;
  return j;
}

SfmSummary sfm_summary(const SfmReport& r) {
  SfmSummary s;
  s.tracker = sfm_tracker_name(r.tracker);
  s.focal = r.focal;
  s.focal_source = focal_source_name(r.focal_source);
  s.focal_pairs = r.focal_pairs;
  s.init_frame_a = r.init_frame_a;
  s.init_frame_b = r.init_frame_b;
  s.keyframes = r.keyframes;
  s.posed_frames = r.pnp_frames + (r.init_frame_a >= 0 ? 2 : 0);
  s.still_frames = r.still_frames;
  s.bridged_frames = r.bridged_frames;
  s.points_3d = r.points_3d;
  s.map_joins = r.map_joins;
  s.observations = r.observations;
  s.reprojection_rms_px = r.reprojection_rms_px;
  s.scale = r.scale;
  s.ground_inliers = r.ground_inliers;
  s.ground_candidates = r.ground_candidates;
  s.seconds_sfm = r.seconds_sfm;
  s.seconds_ba = r.seconds_ba;
  return s;
}

void SfmOptions::validate() const {
  tracking.validate();
  filters.validate();
  auto positive = [](double v, const char* name) {
    if (!(v > 0)) throw Error("", std::string("sfm.") + name, "must be positive");
  };
  if (focal) positive(*focal, "focal");
  if (camera_height) positive(*camera_height, "camera_height");
  if (first_frame < 0) throw Error("", "sfm.first_frame", "must be >= 0");
  if (last_frame != -1 && last_frame <= first_frame)
    throw Error("", "sfm.last_frame", "must be -1 (to the end) or greater than first_frame");
  klt.validate("sfm");
  if (!(match_radius_px >= 0)) throw Error("", "sfm.match_radius_px", "must be >= 0 (0 = whole image)");
  if (!(lowe_ratio >= 0 && lowe_ratio < 1)) throw Error("", "sfm.lowe_ratio", "must be in [0, 1) (0 = off)");
  if (!(epipolar_ratio >= 0 && epipolar_ratio < 1)) throw Error("", "sfm.epipolar_ratio", "must be in [0, 1) (0 = off)");
  positive(fundamental_threshold_px, "fundamental_threshold_px");
  if (!(still_motion_px >= 0)) throw Error("", "sfm.still_motion_px", "must be >= 0");
  positive(init_motion_px, "init_motion_px");
  if (!(init_min_angle_deg >= 0 && init_min_angle_deg < 45))
    throw Error("", "sfm.init_min_angle_deg", "must be in [0, 45)");
  positive(keyframe_motion_px, "keyframe_motion_px");
  if (!(min_triangulation_angle_deg >= 0 && min_triangulation_angle_deg < 45))
    throw Error("", "sfm.min_triangulation_angle_deg", "must be in [0, 45)");
  positive(reprojection_threshold_px, "reprojection_threshold_px");
  if (min_pnp_points < 6) throw Error("", "sfm.min_pnp_points", "must be >= 6");
  if (map_window < 0 || map_window > 30) throw Error("", "sfm.map_window", "must be in [0, 30] (0 = off)");
  if (ba_window < 3) throw Error("", "sfm.ba_window", "must be >= 3");
  if (ba_iterations < 0) throw Error("", "sfm.ba_iterations", "must be >= 0");
  if (final_ba_iterations < 0) throw Error("", "sfm.final_ba_iterations", "must be >= 0");
  positive(ground_threshold, "ground_threshold");
  if (!(ground_min_angle_deg >= 0 && ground_min_angle_deg < 45))
    throw Error("", "sfm.ground_min_angle_deg", "must be in [0, 45)");
  if (!(ground_min_row_share >= 0 && ground_min_row_share < 0.5))
    throw Error("", "sfm.ground_min_row_share", "must be in [0, 0.5)");
  if (!(ground_max_tilt_deg > 0 && ground_max_tilt_deg <= 90))
    throw Error("", "sfm.ground_max_tilt_deg", "must be in (0, 90]");
  if (ground_iterations < 1) throw Error("", "sfm.ground_iterations", "must be >= 1");
  if (ground_min_inliers < 3) throw Error("", "sfm.ground_min_inliers", "must be >= 3 (a plane needs three points)");
}

}  // namespace smseg::sfm
