// segment-cloud --method grabcut-sfm (GrabCutSFM, paper 001) and its baselines on one frame of a work folder.
#include <chrono>
#include <iostream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "runs.hpp"
#include "smseg/sequence/image_file.hpp"
#include "smseg/stacks/dense.hpp"
#include "smseg/stacks/front_ends.hpp"

namespace segment_cloud {

namespace {

using namespace smseg;
using Cloud = std::vector<Eigen::Vector3f>;

Json rect_json(const cv::Rect& r) { return {r.x, r.y, r.width, r.height}; }

constexpr int kDefaultWindow = 10;  // frames either side: the tracks of a monocular frame's neighbourhood

/// The choices given as words (--support, --cluster, --nearest, --plane-up, --box-to-plane) into the
/// parameters; "auto" follows the support: table -> Euclidean clusters at the cloud's spacing, the up
/// direction estimated from the camera path, the box down to the table, the nearest cluster by the median
/// depth of its points; plane -> 001's k-means, the camera's up axis, no feet, the nearest centre.
void resolve_choices(GrabCutSfmCli& o) {
  if (o.support != "table" && o.support != "plane") throw UsageError("", "--support", "must be table or plane");
  const bool table = o.support == "table";
  o.params.support = table ? smseg::cloud::SupportChoice::Table : smseg::cloud::SupportChoice::Plane;
  if (o.cluster != "auto" && o.cluster != "kmeans" && o.cluster != "euclidean")
    throw Error("", "--cluster", "must be auto, kmeans or euclidean");
  o.params.euclidean = o.cluster == "euclidean" || (o.cluster == "auto" && table);
  if (o.nearest != "auto" && o.nearest != "centre" && o.nearest != "median" && o.nearest != "depth")
    throw Error("", "--nearest", "must be auto, centre, median or depth");
  if (o.nearest == "auto") o.nearest = table ? "depth" : "centre";
  o.params.median_distance = o.nearest == "median" || o.nearest == "depth";
  o.params.median_depth = o.nearest == "depth";
  if (o.up != "auto" && o.up != "camera" && o.up != "world" && o.up != "estimate")
    throw UsageError("", "--plane-up", "is \"" + o.up + "\", expected auto, camera, world or estimate");
  if (o.up == "auto") o.up = table ? "estimate" : "camera";
  o.params.world_up = o.up == "world";
  if (!table && !o.box_to_plane_given) o.params.box_to_plane = false;
}

/// The command line's own checks, before anything is read.
void check_options(const GrabCutSfmCli& o) {
  if (o.sequence.empty()) throw Error("", "--sequence", "grabcut-sfm needs the sequence folder");
  if (o.work.empty()) throw Error("", "--work", "grabcut-sfm needs the work folder (tracks.json, cloud.pcd)");
  if (o.frame < 0) throw Error("", "--frame", "grabcut-sfm needs the frame index (>= 0)");
  if (int(!o.truth_label.empty()) + int(!o.truth_mask.empty()) + int(!o.truth_instance.empty()) > 1)
    throw Error("", "--truth-label", "give one of --truth-label, --truth-mask and --truth-instance");
  if (o.truth_region != "largest" && o.truth_region != "all")
    throw Error("", "--truth-region", "must be largest or all");
  if (o.truth_value < 0 || o.truth_value > 255) throw Error("", "--truth-value", "must be 0..255");
  if (fs::path(o.out).extension().string() != ".png")
    throw Error(o.out, "-o", "grabcut-sfm writes a PNG mask: the output must end in .png");
  if (int(o.window >= 0) + int(!o.cloud.empty()) + int(o.dense_cloud > 0) > 1)
    throw Error("", o.dense_cloud > 0 ? "--dense-cloud" : "--window", "give one of a CLOUD, --window and --dense-cloud");
  if (o.plane_window >= 0 && o.params.plane_distance == 0)
    throw Error("", "--plane-window", "needs plane removal (--plane-distance > 0)");
  o.params.validate();
}

/// The frame: its sequence, the work folder's tracks, its pose, intrinsics and image.
struct Frame {
  smseg::sequence::Sequence seq;
  fs::path tracks_path;
  smseg::frontend::TracksFile tracks;
  smseg::sequence::Pose pose;
  smseg::cloud::PinholeIntrinsics intrinsics;
  std::string focal_source;
  cv::Mat image;
};

Frame load_frame(const GrabCutSfmCli& o) {
  Frame f{smseg::sequence::load_sequence(o.sequence), fs::path(o.work) / "tracks.json", {}, {}, {}, {}, {}};
  if (o.frame >= f.seq.frame_count())
    throw Error(f.seq.manifest.string(), "--frame",
                "frame " + std::to_string(o.frame) + " is out of range (the sequence has " +
                    std::to_string(f.seq.frame_count()) + " frames)");
  std::error_code ec;
  if (!fs::is_regular_file(f.tracks_path, ec))
    throw Error(f.tracks_path.string(), "", "no camera poses: run extract-features on the sequence first");
  f.tracks = smseg::stacks::read_tracks(f.tracks_path);
  smseg::frontend::check_made_from(f.tracks, f.tracks_path, f.seq);
  const int first = f.tracks.result.first_frame, posed = static_cast<int>(f.tracks.result.poses.size());
  if (o.frame < first || o.frame >= first + posed)
    throw Error(f.tracks_path.string(), "poses",
                "frame " + std::to_string(o.frame) + " has no pose (poses cover frames " + std::to_string(first) +
                    ".." + std::to_string(first + posed - 1) + ")");
  f.pose = f.tracks.result.poses[std::size_t(o.frame - first)];
  f.intrinsics = smseg::cloud::frame_intrinsics(f.seq, f.tracks.result, &f.focal_source);
  f.image = f.seq.load_left(o.frame);
  return f;
}

/// The scene-relative defaults that need the sequence: the up direction estimated from the camera path,
/// and without a cloud option a stereo frame's own dense depth (one point per 2 pixels of a 320-pixel-wide
/// image) or the tracks around a monocular frame.
void resolve_scene_defaults(GrabCutSfmCli& o, const Frame& f) {
  if (o.up == "estimate") {
    bool planar_path = false;
    o.params.up = smseg::cloud::scene_up(f.tracks.result, &planar_path);
    o.params.refine_up = !planar_path;
  } else if (o.up == "camera") {
    o.params.refine_up = true;  // a camera looking down at a table is tilted by its pitch
  }
  const bool default_cloud = o.cloud.empty() && o.window < 0 && o.dense_cloud == 0;
  if (default_cloud && o.params.support == smseg::cloud::SupportChoice::Table) {
    if (f.seq.kind == smseg::sequence::SequenceKind::Stereo)
      o.dense_cloud = std::max(1, int(std::lround(f.seq.size.width / 160.0)));
    else
      o.window = kDefaultWindow;
  }
  // Only the frame's own dense depth says which pixels lie behind the object: a cloud of tracks from
  // the frames around it (or a cloud file) holds points hidden behind the object in this frame, whose
  // far depths would cut the object's own pixels (CamVid's cars, docs/graphcuts.md).
  if (o.dense_cloud == 0 && !o.mask_depth_share_given) o.params.table.mask_depth_share = 0;
}

/// The cloud clustered (WORK/cloud.pcd or CLOUD, the frame's dense depth, or the tracks around it) and
/// the file it came from.
Cloud frame_cloud(const GrabCutSfmCli& o, const Frame& f, std::string* path) {
  if (o.dense_cloud > 0) {  // the frame's own dense depth, with the stereo range the work folder used
    *path = f.seq.manifest.string();
    if (f.seq.kind != smseg::sequence::SequenceKind::Stereo)
      throw Error(*path, "--dense-cloud", "needs a stereo sequence (dense depth from its pairs)");
    smseg::frontend::StereoOptions stereo;
    const Json& st = f.tracks.options.contains("stereo") ? f.tracks.options["stereo"] : Json::object();
    stereo.num_disparities = st.value("num_disparities", stereo.num_disparities);
    stereo.min_disparity = st.value("min_disparity", stereo.min_disparity);
    Cloud c = smseg::cloud::dense_frame_cloud(smseg::stacks::dense_depth(f.seq, o.frame, smseg::stacks::dense_stereo_options(stereo)), f.seq.calibration,
                                    f.pose, o.dense_cloud);
    if (c.empty()) throw Error(*path, "--dense-cloud", "frame " + std::to_string(o.frame) + " has no dense depth");
    return c;
  }
  if (o.window >= 0) {  // the tracks around the frame
    *path = f.tracks_path.string();
    Cloud c = smseg::cloud::window_cloud(f.tracks.result, o.frame, o.window);
    if (c.empty())
      throw Error(*path, "tracks", "no track has a 3D point within " + std::to_string(o.window) + " frames of frame " +
                                       std::to_string(o.frame));
    return c;
  }
  *path = o.cloud.empty() ? (fs::path(o.work) / "cloud.pcd").string() : o.cloud;
  std::error_code ec;
  if (!fs::is_regular_file(*path, ec)) throw Error(*path, "", "no cloud: run extract-features on the sequence first");
  return smseg::cloud::read_coloured_cloud(*path).points;
}

/// --plane-window: the tracks around the frame, to which the first plane is fitted (empty without it).
Cloud plane_window_cloud(const GrabCutSfmCli& o, const Frame& f) {
  if (o.plane_window < 0) return {};
  Cloud c = smseg::cloud::window_cloud(f.tracks.result, o.frame, o.plane_window);
  if (c.empty())
    throw Error(f.tracks_path.string(), "--plane-window", "no track has a 3D point within " +
                                                              std::to_string(o.plane_window) + " frames of frame " +
                                                              std::to_string(o.frame));
  return c;
}

/// The truth mask (255 object), the ignored pixels (void) and where the truth came from; empty without
/// a truth option.
struct Truth {
  cv::Mat mask, ignore;
  std::string source;
};

Truth label_truth(const GrabCutSfmCli& o, const smseg::sequence::Sequence& seq) {
  int cls = -1;
  std::string names;
  for (std::size_t c = 0; c < seq.classes.size(); ++c) {
    if (seq.classes[c].name == o.truth_label) cls = static_cast<int>(c);
    names += (c ? ", " : "") + seq.classes[c].name;
  }
  if (cls < 0)
    throw Error(seq.manifest.string(), "--truth-label", "no class \"" + o.truth_label + "\" (classes: " + names + ")");
  if (!seq.is_labelled(o.frame))
    throw Error(seq.manifest.string(), "--truth-label", "frame " + std::to_string(o.frame) + " has no label image");
  const cv::Mat labels = seq.load_labels(o.frame);
  Truth t{labels == cls, labels == smseg::sequence::kVoid, "label " + o.truth_label + " (" + o.truth_region + ")"};
  if (cv::countNonZero(t.mask) == 0)
    throw Error(seq.resolve(seq.frames[std::size_t(o.frame)].label).string(), "--truth-label",
                "frame " + std::to_string(o.frame) + " has no pixel of class " + o.truth_label);
  if (o.truth_region == "largest") t.mask = smseg::cloud::largest_region(t.mask);
  return t;
}

/// The sequence's instance image (object ids 1..K); "nearest": the object whose pixels have the
/// smallest median ground-truth depth, "all": every object, else one id.
Truth instance_truth(const GrabCutSfmCli& o, const smseg::sequence::Sequence& seq) {
  if (!seq.has_instances(o.frame))
    throw Error(seq.manifest.string(), "--truth-instance", "frame " + std::to_string(o.frame) + " has no instance image");
  const cv::Mat inst = seq.load_instances(o.frame);
  int id = 0;
  if (o.truth_instance == "nearest") {
    id = smseg::cloud::nearest_instance(inst, seq.load_gt_depth(o.frame));
    if (id == 0) throw Error(seq.manifest.string(), "--truth-instance", "frame " + std::to_string(o.frame) + " shows no object");
  } else if (o.truth_instance != "all") {
    try {
      std::size_t used = 0;
      id = std::stoi(o.truth_instance, &used);
      if (used != o.truth_instance.size() || id < 1 || id > 255) throw std::invalid_argument("id");
    } catch (const std::exception&) {
      throw Error("", "--truth-instance", "must be nearest, all or an object id 1..255");
    }
  }
  Truth t{id == 0 ? inst != 0 : inst == id, cv::Mat(),
          "instances " + o.truth_instance + (id ? " (object " + std::to_string(id) + ")" : "")};
  if (cv::countNonZero(t.mask) == 0)
    throw Error(seq.manifest.string(), "--truth-instance",
                "frame " + std::to_string(o.frame) + " shows no pixel of object " + o.truth_instance);
  return t;
}

Truth mask_truth(const GrabCutSfmCli& o, const cv::Mat& image) {
  const cv::Mat m = smseg::sequence::read_image_file(o.truth_mask, cv::IMREAD_UNCHANGED);
  if (m.type() != CV_8UC1 || m.size() != image.size())
    throw Error(o.truth_mask, "--truth-mask",
                "must be an 8-bit single-channel image of the frame's size (" + std::to_string(image.cols) + " x " +
                    std::to_string(image.rows) + ")");
  Truth t{o.truth_value == 0 ? m != 0 : m == o.truth_value, cv::Mat(),
          o.truth_mask + (o.truth_value ? " == " + std::to_string(o.truth_value) : " != 0")};
  if (cv::countNonZero(t.mask) == 0) throw Error(o.truth_mask, "--truth-mask", "the truth mask has no object pixel");
  return t;
}

Truth load_truth(const GrabCutSfmCli& o, const Frame& f) {
  if (!o.truth_label.empty()) return label_truth(o, f.seq);
  if (!o.truth_instance.empty()) return instance_truth(o, f.seq);
  if (!o.truth_mask.empty()) return mask_truth(o, f.image);
  return {};
}

/// What GrabCutSFM found, step by step (planes or table, clusters, boxes, seconds).
Json report_json(const GrabCutSfmCli& o, const smseg::cloud::GrabCutSfmReport& rep) {
  Json clusters = Json::array();
  for (std::size_t c = 0; c < rep.cluster_sizes.size(); ++c)
    clusters.push_back({{"points", rep.cluster_sizes[c]}, {"in_frame", rep.cluster_in_frame[c]},
                        {"distance", rep.cluster_distances[c]}});
  Json planes = Json::array();
  for (std::size_t i = 0; i < rep.planes.size(); ++i)
    planes.push_back({{"plane", {rep.planes[i][0], rep.planes[i][1], rep.planes[i][2], rep.planes[i][3]}},
                      {"inliers", rep.planes_inliers[i]}});
  const smseg::cloud::TablePlane& t = rep.table;
  return {{"points", rep.points},
          {"considered", rep.considered},
          {"up", {o.params.up.x(), o.params.up.y(), o.params.up.z()}},
          {"plane_inliers", rep.plane_inliers},
          {"plane", {rep.plane[0], rep.plane[1], rep.plane[2], rep.plane[3]}},
          {"planes", planes},
          {"support", rep.support},
          {"table",
           {{"found", t.found}, {"thickness", t.thickness}, {"camera_height", t.camera_height}, {"width", t.width},
            {"inliers", t.inliers}, {"standing", t.standing}, {"candidates", t.candidates}}},
          {"plane_distance_used", rep.plane_distance},
          {"height_band_used", rep.height_band},
          {"cluster_tolerance_used", rep.cluster_tolerance},
          {"min_cluster_size_used", rep.min_cluster_size},
          {"in_band", rep.in_band},
          {"feet_in_box", rep.feet_in_box},
          {"clusters", clusters},
          {"chosen", rep.chosen},
          {"unsupported", rep.unsupported},
          {"regions_dropped", rep.regions_dropped},
          {"farther_pixels", rep.farther_pixels},
          {"chosen_projections", rep.chosen_points.size()},
          {"inliers_2d", rep.inliers_2d},
          {"inlier_box", rect_json(rep.inlier_box)},
          {"box", rect_json(rep.box)},
          {"seconds",
           {{"plane", rep.seconds_plane},
            {"kmeans", rep.seconds_kmeans},
            {"projection_ransac_box", rep.seconds_projection},
            {"grabcut", rep.seconds_grabcut},
            {"total", rep.seconds_total}}}};
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// The baselines (2D k-means, k = 2, on colour; GrabCut on the truth mask's bounding box when there is
/// one), their masks written beside OUT, and with a truth every F1 into the summary and the line.
void score(const cv::Mat& image, const cv::Mat& mask, const Truth& truth, std::uint64_t seed, int iterations,
           const fs::path& stem, Json& summary, std::string& line) {
  auto t0 = std::chrono::steady_clock::now();
  cv::Mat clusters2;
  const cv::Mat km = smseg::cloud::kmeans2_colour(image, seed, &clusters2);
  summary["kmeans2"] = {{"seconds", seconds_since(t0)}, {"foreground_pixels", cv::countNonZero(km)}};
  smseg::sequence::write_image_atomic(stem.string() + ".kmeans2.png", km);
  if (truth.mask.empty()) return;
  std::vector<cv::Point> pts;
  cv::findNonZero(truth.mask, pts);
  const cv::Rect tbox = cv::boundingRect(pts);
  t0 = std::chrono::steady_clock::now();
  const cv::Mat gb = smseg::cloud::grabcut_box(image, tbox, iterations, seed);
  summary["grabcut_box"] = {{"box", rect_json(tbox)}, {"seconds", seconds_since(t0)}};
  smseg::sequence::write_image_atomic(stem.string() + ".box.png", gb);
  const double f1 = smseg::cloud::mask_f1(mask, truth.mask, truth.ignore), f1_km = smseg::cloud::mask_f1(km, truth.mask, truth.ignore);
  const double f1_km_other = smseg::cloud::mask_f1(km == 0, truth.mask, truth.ignore);
  const double f1_box = smseg::cloud::mask_f1(gb, truth.mask, truth.ignore);
  summary["truth"] = {{"source", truth.source}, {"pixels", cv::countNonZero(truth.mask)}, {"box", rect_json(tbox)},
                      {"ignored_pixels", truth.ignore.empty() ? 0 : cv::countNonZero(truth.ignore)}};
  summary["f1"] = {{"grabcut_sfm", nan_null(f1)},
                   {"kmeans2", nan_null(f1_km)},
                   {"kmeans2_other_cluster", nan_null(f1_km_other)},
                   {"kmeans2_best_of_both", nan_null(std::max(f1_km, f1_km_other))},
                   {"grabcut_truth_box", nan_null(f1_box)}};
  line += ", F1 grabcut-sfm " + fmt(f1, "%.3f") + ", kmeans2 " + fmt(f1_km, "%.3f") + " (best of both " +
          fmt(std::max(f1_km, f1_km_other), "%.3f") + "), grabcut on the truth box " + fmt(f1_box, "%.3f");
}

std::string summary_line(int frame, const smseg::cloud::GrabCutSfmReport& rep) {
  return "frame " + std::to_string(frame) + ": cluster " + std::to_string(rep.chosen) + " of " +
         std::to_string(rep.cluster_sizes.size()) + " (" + fmt(rep.cluster_distances[std::size_t(rep.chosen)], "%.2f") +
         " m, " + std::to_string(rep.inliers_2d) + "/" + std::to_string(rep.chosen_points.size()) +
         " projections kept), box " + std::to_string(rep.box.width) + "x" + std::to_string(rep.box.height) + " at (" +
         std::to_string(rep.box.x) + ", " + std::to_string(rep.box.y) + "), " + fmt(rep.seconds_total * 1000, "%.0f") +
         " ms";
}

}  // namespace

namespace {

/// The truth to score against (the command line's only: the summary says what it was as "truth").
void declare_truth(options::Table<GrabCutSfmCli>& t) {
  using smseg::cloud::option_fields::one_of;
  t.text("truth_label", "--truth-label", "grabcut-sfm: F1 against the frame's pixels of this class (void ignored)",
         [](auto& o) -> auto& { return o.truth_label; })
      .only(options::kCommandLine);
  one_of(t, "truth_region", "--truth-region",
         "grabcut-sfm, --truth-label: largest (the class's largest 8-connected region; its other pixels "
         "count as background) or all",
         [](auto& o) -> auto& { return o.truth_region; }, {"largest", "all"}, options::kCommandLine);
  t.text("truth_instance", "--truth-instance",
         "grabcut-sfm: F1 against an object of the frame's instance image (synthetic tabletop): nearest "
         "(smallest median ground-truth depth), all, or an object id",
         [](auto& o) -> auto& { return o.truth_instance; })
      .only(options::kCommandLine);
  t.text("truth_mask", "--truth-mask", "grabcut-sfm: F1 against this 8-bit mask image (non-zero = object)",
         [](auto& o) -> auto& { return o.truth_mask; })
      .only(options::kCommandLine);
  t.number("truth_value", "--truth-value", "grabcut-sfm, --truth-mask: object = pixels of this value (0: any non-zero)",
           [](auto& o) -> auto& { return o.truth_value; }, 0, 255)
      .only(options::kCommandLine);
}

/// The cloud clustered: the frame's dense depth, the tracks around it, or the whole cloud.
void declare_cloud(options::Table<GrabCutSfmCli>& t) {
  smseg::cloud::option_fields::number_without_default(
      t, "dense_cloud", "--dense-cloud",
      "grabcut-sfm, stereo sequences: cluster the frame's own dense depth (eight-path SGBM, as extract-features "
      "--dense), one point every this many pixels, instead of the tracked cloud",
      [](auto& o) -> auto& { return o.dense_cloud; }, 1, 64);
  t.number("window", "--window",
           "grabcut-sfm: cluster the tracks of WORK/tracks.json seen within this many frames of --frame "
           "(one point per track, its mean world position there) instead of the whole cloud (-1; 001 uses "
           "one reconstruction)",
           [](auto& o) -> auto& { return o.window; }, -1, 100000);
  t.number("plane_window", "--plane-window",
           "grabcut-sfm: fit the first (supporting) plane to the tracks seen within this many frames of --frame "
           "(as --window) and remove its inliers from the clustered cloud, e.g. with --dense-cloud, whose "
           "depth sees more floor than table top from above a table (-1: the clustered cloud's own plane)",
           [](auto& o) -> auto& { return o.plane_window; }, -1, 100000);
}

/// The words that choose: the support, the up direction, the clustering, the nearest cluster (the
/// summary records them resolved: "auto" as what it stood for).
void declare_choices(options::Table<GrabCutSfmCli>& t) {
  using smseg::cloud::option_fields::one_of;
  one_of(t, "support", "--support",
         "grabcut-sfm: table (the highest horizontal patch with points standing on it, every distance relative "
         "to the scene; keeps the points standing on it) or plane (001: the dominant RANSAC plane, distances in "
         "metres)",
         [](auto& o) -> auto& { return o.support; }, {"table", "plane"});
  one_of(t, "up", "--plane-up",
         "grabcut-sfm: the up direction the supporting plane faces: estimate (from the work folder's camera "
         "path and tracks, as extract-features --gravity estimate), camera (the frame's up axis), world (world "
         "+Y: work folders made with --gravity estimate), auto (table: estimate; plane: camera)",
         [](auto& o) -> auto& { return o.up; }, {"auto", "camera", "world", "estimate"});
  one_of(t, "cluster", "--cluster",
         "grabcut-sfm: kmeans (001, --k clusters), euclidean (--cluster-tolerance) or auto (table: euclidean, "
         "plane: kmeans)",
         [](auto& o) -> auto& { return o.cluster; }, {"auto", "kmeans", "euclidean"})
      .written_as([](const GrabCutSfmCli& o) { return Json(o.params.euclidean ? "euclidean" : "kmeans"); });
  one_of(t, "nearest", "--nearest",
         "grabcut-sfm: the nearest cluster by its centre's distance (centre, 001), its points' median "
         "distance (median) or median depth along the optical axis (depth); auto: table: depth, plane: centre",
         [](auto& o) -> auto& { return o.nearest; }, {"auto", "centre", "median", "depth"});
}

}  // namespace

const options::Table<GrabCutSfmCli>& grabcut_sfm_cli_table() {
  static const options::Table<GrabCutSfmCli> table = [] {
    options::Table<GrabCutSfmCli> t("grabcut-sfm", smseg::cloud::kSegmentCloudSurfaces);
    declare_truth(t);
    declare_cloud(t);
    declare_choices(t);
    t.include(smseg::cloud::grabcut_sfm_params_table(), [](auto& o) -> auto& { return o.params; });
    return t;
  }();
  return table;
}

/// GrabCutSFM on one frame of a work folder, its two baselines, F1 against a truth mask when given;
/// writes the mask (out), OUT-stem.overlay.png, the baselines' masks and out + ".json".
int run_grabcut_sfm(const GrabCutSfmCli& cli) {
  GrabCutSfmCli o = cli;
  smseg::as_usage([&] {  // the options alone, before anything is read: bad usage (exit status 2)
    resolve_choices(o);
    check_options(o);
  });
  const Frame f = load_frame(o);
  resolve_scene_defaults(o, f);
  std::string cloud_path;
  const auto t_cloud = std::chrono::steady_clock::now();
  const Cloud cloud = frame_cloud(o, f, &cloud_path);
  const double cloud_seconds = seconds_since(t_cloud);
  const Cloud plane_cloud = plane_window_cloud(o, f);
  const Truth truth = load_truth(o, f);
  smseg::cloud::GrabCutSfmReport rep;
  cv::Mat mask;
  try {
    mask = smseg::cloud::grabcut_sfm(cloud, f.intrinsics, f.pose, f.image, o.params, &rep, o.plane_window >= 0 ? &plane_cloud : nullptr);
  } catch (const Error& e) {
    throw Error(e.field() == "cloud" ? cloud_path : e.file(), e.field(), e.reason() + " (frame " + std::to_string(o.frame) + ")");
  }
  const fs::path out(o.out);
  const fs::path stem = out.parent_path() / out.stem();
  begin_output_set(o.out);
  smseg::sequence::write_image_atomic(out, mask);
  smseg::sequence::write_image_atomic(stem.string() + ".overlay.png", smseg::cloud::grabcut_sfm_overlay(f.image, mask, rep));
  const auto& k = f.intrinsics;
  Json summary = {{"format", "smseg-segment-cloud"}, {"version", 1}, {"method", "grabcut-sfm"},
                  {"sequence", o.sequence}, {"work", o.work}, {"cloud", cloud_path}, {"frame", o.frame},
                  {"intrinsics", {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}, {"focal_source", f.focal_source}}},
                  {"params", grabcut_sfm_cli_table().to_json(o)}, {"mask_pixels", cv::countNonZero(mask)}};
  summary.update(report_json(o, rep));
  summary["seconds"]["cloud"] = cloud_seconds;  // reading or computing the cloud (the dense depth), before "total"
  std::string line = summary_line(o.frame, rep);
  score(f.image, mask, truth, o.params.seed, o.params.grabcut_iterations, stem, summary, line);
  write_json_atomic(o.out + ".json", summary);
  std::cout << line << " -> " << o.out << "\n";
  return 0;
}

}  // namespace segment_cloud
