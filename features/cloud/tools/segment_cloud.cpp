// segment-cloud: graph-cut segmentation of a point cloud (the systems of ../shared/papers 000 and 003),
// and synthetic tabletop clouds to try them on.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>

#include <tbb/global_control.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "smseg/common/cli.hpp"
#include "smseg/cloud/cloud_segment.hpp"
#include "smseg/cloud/cloud_view.hpp"
#include "smseg/cloud/grabcut_sfm.hpp"
#include "smseg/frontend/tracks_io.hpp"

namespace {

std::string fmt(double v, const char* f = "%.4f") {
  if (std::isnan(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

smseg::Json nan_null(double v) { return std::isnan(v) ? smseg::Json(nullptr) : smseg::Json(v); }

/// What --seeds saliency needs besides the MRF parameters.
struct SaliencyRun {
  std::string input;  ///< cloud file; empty: WORK/cloud.pcd
  std::string out, sequence, work;
  int frame = -1;
  int min_seed_points = 3;
  double split_distance = 0.05;  ///< split seed regions by 3D distance and colour (0: no split)
  double split_colour = 80;
  smseg::features::SaliencyParams saliency;
  smseg::features::ProjectionParams projection;
};

/// segment-cloud --method mrf --seeds saliency: the cloud seen from one frame, seeded by the frame's
/// salient regions (paper 000), scored against the frame's instance image (or the cloud's labels).
int run_saliency_mrf(const SaliencyRun& run, const smseg::features::MrfParams& mrf) {
  using namespace smseg;
  using namespace smseg::features;
  if (run.sequence.empty() || run.work.empty() || run.frame < 0)
    throw Error("", run.sequence.empty() ? "--sequence" : run.work.empty() ? "--work" : "--frame",
                "--seeds saliency needs --sequence SEQ, --work WORK and --frame N (N >= 0)");
  run.saliency.validate();
  run.projection.validate();
  if (run.min_seed_points < 1) throw Error("", "--min-seed-points", "must be at least 1");
  if (!(run.split_distance >= 0)) throw Error("", "--seed-split", "must be >= 0 metres (0: no split)");
  if (!(run.split_colour > 0)) throw Error("", "--seed-split-colour", "must be positive");
  const Sequence seq = load_sequence(run.sequence);
  if (run.frame >= seq.frame_count())
    throw Error(seq.manifest.string(), "--frame",
                "frame " + std::to_string(run.frame) + " is outside the sequence's frames 0.." +
                    std::to_string(seq.frame_count() - 1));
  if (!seq.calibration.fx || !seq.calibration.fy)
    throw Error(seq.manifest.string(), "calibration", "projecting a cloud needs the focal length (fx, fy)");
  const fs::path work(run.work);
  if (!fs::is_directory(work)) throw Error(work.string(), "--work", "no such work folder (run extract-features first)");
  const TracksFile tracks = read_tracks(work / "tracks.json");
  const FrontEndResult& fe = tracks.result;
  const int pose_index = run.frame - fe.first_frame;
  if (pose_index < 0 || pose_index >= static_cast<int>(fe.poses.size()))
    throw Error((work / "tracks.json").string(), "--frame",
                "frame " + std::to_string(run.frame) + " has no camera pose: the work folder holds frames " +
                    std::to_string(fe.first_frame) + ".." + std::to_string(fe.first_frame + int(fe.poses.size()) - 1));
  if (tracks.image_size != seq.size)
    throw Error((work / "tracks.json").string(), "image_size", "differs from the sequence's image size");
  const std::string input = run.input.empty() ? (work / "cloud.pcd").string() : run.input;
  const ColouredCloud cloud = read_coloured_cloud(input);
  const auto t0 = std::chrono::steady_clock::now();

  ViewCamera cam;
  cam.fx = *seq.calibration.fx;
  cam.fy = *seq.calibration.fy;
  cam.cx = seq.calibration.cx;
  cam.cy = seq.calibration.cy;
  cam.size = seq.size;
  cam.pose = fe.poses[static_cast<std::size_t>(pose_index)];
  const CloudProjection proj = project_cloud(cloud, cam, run.projection);
  const fs::path image_path = seq.resolve(seq.frames[static_cast<std::size_t>(run.frame)].left);
  if (proj.visible.size() < 10)
    throw Error(input, "--frame",
                "only " + std::to_string(proj.visible.size()) + " of the cloud's points are visible in frame " +
                    std::to_string(run.frame) + " (is the cloud from this work folder?)");

  // The visible points, coloured from the frame's image (cloud.pcd carries class colours, not image colours).
  const cv::Mat image = seq.load_left(run.frame);
  ColouredCloud view;
  std::vector<cv::Point> pixels;
  for (int i : proj.visible) {
    const cv::Point p = proj.pixel[static_cast<std::size_t>(i)];
    const cv::Vec3b c = image.at<cv::Vec3b>(p);
    view.points.push_back(cloud.points[static_cast<std::size_t>(i)]);
    view.colours.push_back({c[2], c[1], c[0]});
    pixels.push_back(p);
  }
  const SalientRegions sr = salient_regions(image, run.saliency);
  MrfSeeds sd;
  std::vector<int> region_of_label;
  MrfReport rep;
  std::vector<int> view_labels;
  try {
    sd = saliency_seeds(pixels, view.points, sr, run.saliency.background, run.min_seed_points, &region_of_label);
    if (run.split_distance > 0)
      split_seed_regions(view, sd, run.split_distance, run.split_colour, run.min_seed_points, &region_of_label);
    view_labels = mrf_segment(view, sd, mrf, &rep);
  } catch (const Error& e) {
    throw Error(e.file().empty() ? image_path.string() : e.file(), e.field(), e.reason());
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  std::vector<int> labels(cloud.size(), -1);
  for (std::size_t k = 0; k < proj.visible.size(); ++k) labels[static_cast<std::size_t>(proj.visible[k])] = view_labels[k];
  write_labelled_cloud(run.out, cloud, labels);
  const std::string picture = run.out + ".png", saliency_picture = run.out + ".saliency.png";
  write_image_atomic(picture, splat_labels(proj, labels, seq.size, run.projection.splat_radius));
  {
    cv::Mat s8, vis;
    sr.saliency.convertTo(s8, CV_8U, 255.0);
    cv::cvtColor(s8, vis, cv::COLOR_GRAY2BGR);
    for (int y = 0; y < vis.rows; ++y)  // outline the salient regions in red
      for (int x = 0; x < vis.cols; ++x) {
        const int r = sr.regions.at<int>(y, x);
        if (r == 0) continue;
        const bool edge = x == 0 || y == 0 || x == vis.cols - 1 || y == vis.rows - 1 ||
                          sr.regions.at<int>(y, x - 1) != r || sr.regions.at<int>(y - 1, x) != r ||
                          sr.regions.at<int>(y, x + 1) != r || sr.regions.at<int>(y + 1, x) != r;
        if (edge) vis.at<cv::Vec3b>(y, x) = cv::Vec3b(0, 0, 255);
      }
    write_image_atomic(saliency_picture, vis);
  }

  Json seeds_json = Json::array();
  for (std::size_t l = 0; l < sd.regions.size(); ++l)
    seeds_json.push_back({{"label", l},
                          {"salient_region", region_of_label[l]},
                          {"points", sd.regions[l].size()},
                          {"position", {sd.positions[l].x(), sd.positions[l].y(), sd.positions[l].z()}}});
  Json colours = Json::array();
  for (int l = 0; l < rep.labels; ++l) {
    const cv::Vec3b c = label_colour(l);
    colours.push_back({c[2], c[1], c[0]});
  }
  Json summary = {{"format", "smseg-segment-cloud"},
                  {"version", 1},
                  {"input", input},
                  {"method", "mrf"},
                  {"sequence", seq.manifest.string()},
                  {"work", work.string()},
                  {"frame", run.frame},
                  {"image", image_path.string()},
                  {"params",
                   {{"seeds", "saliency"},
                    {"saliency", run.saliency.method},
                    {"saliency_threshold", run.saliency.threshold},
                    {"background", run.saliency.background},
                    {"min_area", run.saliency.min_area},
                    {"max_area", run.saliency.max_area},
                    {"saliency_step", run.saliency.step},
                    {"saliency_blur", run.saliency.blur},
                    {"saliency_scale", run.saliency.scale},
                    {"min_seed_points", run.min_seed_points},
                    {"seed_split", run.split_distance},
                    {"seed_split_colour", run.split_colour},
                    {"splat_radius", run.projection.splat_radius},
                    {"depth_tolerance", run.projection.depth_tolerance},
                    {"neighbours", mrf.neighbours},
                    {"components", mrf.components},
                    {"lambda", mrf.lambda},
                    {"iterations", mrf.max_iterations},
                    {"tolerance", mrf.tolerance}}},
                  {"points", cloud.size()},
                  {"visible_points", proj.visible.size()},
                  {"colours", "the visible points' pixels in the frame's left image"},
                  {"saliency_threshold_used", sr.threshold},
                  {"salient_regions", sr.count},
                  {"labels", rep.labels},
                  {"seeds", seeds_json},
                  {"iterations", rep.iterations},
                  {"energies", rep.energies},
                  {"beta", rep.beta},
                  {"projection", picture},
                  {"projection_colours", colours},
                  {"saliency_map", saliency_picture},
                  {"seconds_mrf", rep.seconds},
                  {"seconds_total", seconds}};
  std::string line = seq.name + " frame " + std::to_string(run.frame) + ": " + std::to_string(proj.visible.size()) +
                     " of " + std::to_string(cloud.size()) + " points visible, " + std::to_string(sr.count) +
                     " salient regions, " + std::to_string(rep.labels) + " labels, " + std::to_string(rep.iterations) +
                     " rounds";

  // Ground truth per visible point: the object id at its pixel, or the cloud's own (class) labels.
  std::vector<int> truth;
  int truth_ids = 0;
  std::string truth_source;
  if (seq.has_instances(run.frame)) {
    const cv::Mat inst = seq.load_instances(run.frame);
    double hi = 0;
    cv::minMaxLoc(inst, nullptr, &hi);
    truth_ids = static_cast<int>(hi) + 1;
    if (seq.extra.contains("objects") && seq.extra["objects"].is_array())
      truth_ids = std::max(truth_ids, static_cast<int>(seq.extra["objects"].size()) + 1);
    for (const cv::Point& p : pixels) truth.push_back(inst.at<std::uint8_t>(p));
    truth_source = "instances";
  } else if (cloud.has_labels()) {
    for (int i : proj.visible) truth.push_back(cloud.labels[static_cast<std::size_t>(i)]);
    for (int t : truth) truth_ids = std::max(truth_ids, t + 1);
    truth_source = "cloud labels";
  }
  if (truth_ids > 0) {
    const InstanceScore sc = score_instances(truth, view_labels, truth_ids, rep.labels);
    Json f1 = Json::array();
    line += ", F1 (" + truth_source + ")";
    for (int t = 0; t < truth_ids; ++t) {
      f1.push_back({{"truth", t}, {"points", sc.truth_points[static_cast<std::size_t>(t)]},
                    {"f1", nan_null(sc.f1[static_cast<std::size_t>(t)])}});
      line += " " + std::to_string(t) + ":" + fmt(sc.f1[static_cast<std::size_t>(t)], "%.3f");
    }
    summary["truth"] = truth_source;
    summary["label_to_truth"] = sc.label_to_truth;
    summary["f1"] = f1;
    summary["confusion"] = sc.confusion;
  }
  write_json_atomic(run.out + ".json", summary);
  std::cout << line << " -> " << run.out << "\n";
  return 0;
}

// ---- --method grabcut-sfm (paper 001) -------------------------------------------------------------

struct GrabCutSfmCli {
  std::string sequence, work, cloud, out;  // cloud: empty = WORK/cloud.pcd
  int frame = -1;
  std::string truth_label, truth_region = "largest", truth_mask, truth_instance;
  int truth_value = 0;  // --truth-mask: 0 = any non-zero pixel is the object, else pixels == value
  int window = -1;      // >= 0: the cloud of the tracks seen within this many frames (tracks.json)
  std::string cluster = "kmeans", nearest = "centre";
  smseg::features::GrabCutSfmParams params;
};

smseg::Json rect_json(const cv::Rect& r) { return {r.x, r.y, r.width, r.height}; }

/// GrabCutSFM on one frame of a work folder, its two baselines, F1 against a truth mask when given;
/// writes the mask (out), OUT-stem.overlay.png, the baselines' masks and out + ".json".
int run_grabcut_sfm(const GrabCutSfmCli& o) {
  using namespace smseg;
  namespace sf = smseg::features;
  if (o.sequence.empty()) throw Error("", "--sequence", "grabcut-sfm needs the sequence folder");
  if (o.work.empty()) throw Error("", "--work", "grabcut-sfm needs the work folder (tracks.json, cloud.pcd)");
  if (o.frame < 0) throw Error("", "--frame", "grabcut-sfm needs the frame index (>= 0)");
  if (int(!o.truth_label.empty()) + int(!o.truth_mask.empty()) + int(!o.truth_instance.empty()) > 1)
    throw Error("", "--truth-label", "give one of --truth-label, --truth-mask and --truth-instance");
  if (o.truth_region != "largest" && o.truth_region != "all")
    throw Error("", "--truth-region", "must be largest or all");
  if (o.cluster != "kmeans" && o.cluster != "euclidean") throw Error("", "--cluster", "must be kmeans or euclidean");
  if (o.nearest != "centre" && o.nearest != "median" && o.nearest != "depth")
    throw Error("", "--nearest", "must be centre, median or depth");
  if (o.truth_value < 0 || o.truth_value > 255) throw Error("", "--truth-value", "must be 0..255");
  const std::string ext = fs::path(o.out).extension().string();
  if (ext != ".png") throw Error(o.out, "-o", "grabcut-sfm writes a PNG mask: the output must end in .png");
  o.params.validate();
  const sf::Sequence seq = sf::load_sequence(o.sequence);
  if (o.frame >= seq.frame_count())
    throw Error(seq.manifest.string(), "--frame",
                "frame " + std::to_string(o.frame) + " is out of range (the sequence has " +
                    std::to_string(seq.frame_count()) + " frames)");
  const fs::path tracks_path = fs::path(o.work) / "tracks.json";
  std::error_code ec;
  if (!fs::is_regular_file(tracks_path, ec))
    throw Error(tracks_path.string(), "", "no camera poses: run extract-features on the sequence first");
  const sf::TracksFile tracks = sf::read_tracks(tracks_path);
  if (tracks.sequence_name != seq.name)
    throw Error(tracks_path.string(), "sequence",
                "is for sequence \"" + tracks.sequence_name + "\", not \"" + seq.name + "\"");
  const int first = tracks.result.first_frame, posed = static_cast<int>(tracks.result.poses.size());
  if (o.frame < first || o.frame >= first + posed)
    throw Error(tracks_path.string(), "poses",
                "frame " + std::to_string(o.frame) + " has no pose (poses cover frames " + std::to_string(first) +
                    ".." + std::to_string(first + posed - 1) + ")");
  const sf::Pose pose = tracks.result.poses[std::size_t(o.frame - first)];
  sf::PinholeIntrinsics k;
  k.cx = seq.calibration.cx;
  k.cy = seq.calibration.cy;
  std::string focal_source;
  if (tracks.result.summary.sfm && tracks.result.summary.sfm->focal > 0) {
    k.fx = k.fy = tracks.result.summary.sfm->focal;
    focal_source = "tracks.json summary.sfm.focal_px (" + tracks.result.summary.sfm->focal_source + ")";
  } else if (seq.calibration.fx && seq.calibration.fy) {
    k.fx = *seq.calibration.fx;
    k.fy = *seq.calibration.fy;
    focal_source = "sequence calibration";
  } else {
    throw Error(seq.manifest.string(), "calibration", "no focal length (neither fx/fy nor an SfM focal in tracks.json)");
  }
  if (o.window >= 0 && !o.cloud.empty()) throw Error("", "--window", "give a CLOUD or --window, not both");
  std::string cloud_path = o.cloud.empty() ? (fs::path(o.work) / "cloud.pcd").string() : o.cloud;
  sf::ColouredCloud cloud;
  if (o.window >= 0) {  // the tracks around the frame
    cloud_path = tracks_path.string();
    cloud.points = sf::window_cloud(tracks.result, o.frame, o.window);
    if (cloud.points.empty())
      throw Error(cloud_path, "tracks", "no track has a 3D point within " + std::to_string(o.window) +
                                            " frames of frame " + std::to_string(o.frame));
  } else {
    if (!fs::is_regular_file(cloud_path, ec))
      throw Error(cloud_path, "", "no cloud: run extract-features on the sequence first");
    cloud = sf::read_coloured_cloud(cloud_path);
  }
  const cv::Mat image = seq.load_left(o.frame);

  // Truth mask (255 object) and ignored pixels (void).
  cv::Mat truth, ignore;
  std::string truth_source;
  if (!o.truth_label.empty()) {
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
    truth = labels == cls;
    ignore = labels == sf::kVoid;
    if (cv::countNonZero(truth) == 0)
      throw Error(seq.resolve(seq.frames[std::size_t(o.frame)].label).string(), "--truth-label",
                  "frame " + std::to_string(o.frame) + " has no pixel of class " + o.truth_label);
    truth_source = "label " + o.truth_label + " (" + o.truth_region + ")";
    if (o.truth_region == "largest") {  // the largest 8-connected region of the class
      cv::Mat comp, stats, centroids;
      const int n = cv::connectedComponentsWithStats(truth, comp, stats, centroids, 8, CV_32S);
      int best = 1;
      for (int c = 2; c < n; ++c)
        if (stats.at<int>(c, cv::CC_STAT_AREA) > stats.at<int>(best, cv::CC_STAT_AREA)) best = c;
      truth = comp == best;
    }
  } else if (!o.truth_instance.empty()) {
    // The sequence's instance image (object ids 1..K); "nearest": the object whose pixels have the
    // smallest median ground-truth depth, "all": every object, else one id.
    if (!seq.has_instances(o.frame))
      throw Error(seq.manifest.string(), "--truth-instance",
                  "frame " + std::to_string(o.frame) + " has no instance image");
    const cv::Mat inst = seq.load_instances(o.frame);
    int id = 0;
    if (o.truth_instance == "nearest") {
      const cv::Mat depth = seq.load_gt_depth(o.frame);
      std::vector<std::vector<float>> d(256);
      for (int y = 0; y < inst.rows; ++y)
        for (int x = 0; x < inst.cols; ++x) {
          const std::uint8_t v = inst.at<std::uint8_t>(y, x);
          const float z = depth.at<float>(y, x);
          if (v && z > 0) d[v].push_back(z);
        }
      float best = std::numeric_limits<float>::infinity();
      for (int v = 1; v < 256; ++v) {
        if (d[std::size_t(v)].empty()) continue;
        auto& dv = d[std::size_t(v)];
        std::nth_element(dv.begin(), dv.begin() + std::ptrdiff_t(dv.size() / 2), dv.end());
        if (dv[dv.size() / 2] < best) {
          best = dv[dv.size() / 2];
          id = v;
        }
      }
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
    truth = id == 0 ? inst != 0 : inst == id;
    if (cv::countNonZero(truth) == 0)
      throw Error(seq.manifest.string(), "--truth-instance",
                  "frame " + std::to_string(o.frame) + " shows no pixel of object " + o.truth_instance);
    truth_source = "instances " + o.truth_instance + (id ? " (object " + std::to_string(id) + ")" : "");
  } else if (!o.truth_mask.empty()) {
    const cv::Mat m = cv::imread(o.truth_mask, cv::IMREAD_UNCHANGED);
    if (m.empty()) throw Error(o.truth_mask, "--truth-mask", "cannot be read as an image");
    if (m.type() != CV_8UC1 || m.size() != image.size())
      throw Error(o.truth_mask, "--truth-mask",
                  "must be an 8-bit single-channel image of the frame's size (" + std::to_string(image.cols) + " x " +
                      std::to_string(image.rows) + ")");
    truth = o.truth_value == 0 ? m != 0 : m == o.truth_value;
    if (cv::countNonZero(truth) == 0)
      throw Error(o.truth_mask, "--truth-mask", "the truth mask has no object pixel");
    truth_source = o.truth_mask + (o.truth_value ? " == " + std::to_string(o.truth_value) : " != 0");
  }

  sf::GrabCutSfmReport rep;
  cv::Mat mask;
  try {
    mask = sf::grabcut_sfm(cloud.points, k, pose, image, o.params, &rep);
  } catch (const Error& e) {
    throw Error(e.field() == "cloud" ? cloud_path : e.file(), e.field(),
                e.reason() + " (frame " + std::to_string(o.frame) + ")");
  }
  const fs::path out(o.out);
  const fs::path stem = out.parent_path() / out.stem();
  sf::write_image_atomic(out, mask);
  sf::write_image_atomic(stem.string() + ".overlay.png", sf::grabcut_sfm_overlay(image, mask, rep));

  Json clusters = Json::array();
  for (std::size_t c = 0; c < rep.cluster_sizes.size(); ++c)
    clusters.push_back({{"points", rep.cluster_sizes[c]},
                        {"in_frame", rep.cluster_in_frame[c]},
                        {"distance", rep.cluster_distances[c]}});
  Json planes = Json::array();
  for (std::size_t i = 0; i < rep.planes.size(); ++i)
    planes.push_back({{"plane", {rep.planes[i][0], rep.planes[i][1], rep.planes[i][2], rep.planes[i][3]}},
                      {"inliers", rep.planes_inliers[i]}});
  const auto& p = o.params;
  Json summary = {{"format", "smseg-segment-cloud"},
                  {"version", 1},
                  {"method", "grabcut-sfm"},
                  {"sequence", o.sequence},
                  {"work", o.work},
                  {"cloud", cloud_path},
                  {"frame", o.frame},
                  {"intrinsics", {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}, {"focal_source", focal_source}}},
                  {"params",
                   {{"plane_distance", p.plane_distance},
                    {"plane_iterations", p.plane_iterations},
                    {"k", p.k},
                    {"attempts", p.attempts},
                    {"kmeans_iterations", p.kmeans_iterations},
                    {"min_cluster_points", p.min_cluster_points},
                    {"outlier_threshold", p.outlier_threshold},
                    {"ransac_iterations", p.ransac_iterations},
                    {"box_margin", p.box_margin},
                    {"grabcut_iterations", p.grabcut_iterations},
                    {"frustum_only", p.frustum_only},
                    {"max_distance", p.max_distance},
                    {"window", o.window},
                    {"planes", p.planes},
                    {"plane_min_share", p.plane_min_share},
                    {"height_band", p.height_band},
                    {"max_tilt", p.max_tilt},
                    {"support_radius", p.support_radius},
                    {"cluster", o.cluster},
                    {"cluster_tolerance", p.cluster_tolerance},
                    {"min_cluster_size", p.min_cluster_size},
                    {"nearest", o.nearest},
                    {"seed", p.seed}}},
                  {"points", rep.points},
                  {"considered", rep.considered},
                  {"plane_inliers", rep.plane_inliers},
                  {"plane", {rep.plane[0], rep.plane[1], rep.plane[2], rep.plane[3]}},
                  {"planes", planes},
                  {"support", rep.support},
                  {"in_band", rep.in_band},
                  {"clusters", clusters},
                  {"chosen", rep.chosen},
                  {"chosen_projections", rep.chosen_points.size()},
                  {"inliers_2d", rep.inliers_2d},
                  {"inlier_box", rect_json(rep.inlier_box)},
                  {"box", rect_json(rep.box)},
                  {"mask_pixels", cv::countNonZero(mask)},
                  {"seconds",
                   {{"plane", rep.seconds_plane},
                    {"kmeans", rep.seconds_kmeans},
                    {"projection_ransac_box", rep.seconds_projection},
                    {"grabcut", rep.seconds_grabcut},
                    {"total", rep.seconds_total}}}};
  std::string line = "frame " + std::to_string(o.frame) + ": cluster " + std::to_string(rep.chosen) + " of " +
                     std::to_string(rep.cluster_sizes.size()) + " (" + fmt(rep.cluster_distances[std::size_t(rep.chosen)], "%.2f") +
                     " m, " + std::to_string(rep.inliers_2d) + "/" + std::to_string(rep.chosen_points.size()) +
                     " projections kept), box " + std::to_string(rep.box.width) + "x" +
                     std::to_string(rep.box.height) + " at (" + std::to_string(rep.box.x) + ", " +
                     std::to_string(rep.box.y) + "), " + fmt(rep.seconds_total * 1000, "%.0f") + " ms";

  // Baselines: 2D k-means (k = 2) on colour; GrabCut on the truth mask's bounding box (when there is one).
  auto t0 = std::chrono::steady_clock::now();
  cv::Mat clusters2;
  const cv::Mat km = sf::kmeans2_colour(image, p.seed, &clusters2);
  const double km_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  sf::write_image_atomic(stem.string() + ".kmeans2.png", km);
  summary["kmeans2"] = {{"seconds", km_seconds}, {"foreground_pixels", cv::countNonZero(km)}};
  if (!truth.empty()) {
    std::vector<cv::Point> pts;
    cv::findNonZero(truth, pts);
    const cv::Rect tbox = cv::boundingRect(pts);
    t0 = std::chrono::steady_clock::now();
    const cv::Mat gb = sf::grabcut_box(image, tbox, p.grabcut_iterations, p.seed);
    const double gb_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    sf::write_image_atomic(stem.string() + ".box.png", gb);
    const double f1 = sf::mask_f1(mask, truth, ignore), f1_km = sf::mask_f1(km, truth, ignore);
    const double f1_km_other = sf::mask_f1(km == 0, truth, ignore), f1_box = sf::mask_f1(gb, truth, ignore);
    summary["truth"] = {{"source", truth_source}, {"pixels", cv::countNonZero(truth)}, {"box", rect_json(tbox)},
                        {"ignored_pixels", ignore.empty() ? 0 : cv::countNonZero(ignore)}};
    summary["grabcut_box"] = {{"box", rect_json(tbox)}, {"seconds", gb_seconds}};
    summary["f1"] = {{"grabcut_sfm", nan_null(f1)},
                     {"kmeans2", nan_null(f1_km)},
                     {"kmeans2_other_cluster", nan_null(f1_km_other)},
                     {"kmeans2_best_of_both", nan_null(std::max(f1_km, f1_km_other))},
                     {"grabcut_truth_box", nan_null(f1_box)}};
    line += ", F1 grabcut-sfm " + fmt(f1, "%.3f") + ", kmeans2 " + fmt(f1_km, "%.3f") + " (best of both " +
            fmt(std::max(f1_km, f1_km_other), "%.3f") + "), grabcut on the truth box " + fmt(f1_box, "%.3f");
  }
  write_json_atomic(o.out + ".json", summary);
  std::cout << line << " -> " << o.out << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Segment a point cloud (PCD or PLY) by graph cuts and write it labelled (pcl::PointXYZRGBL) with a\n"
      "summary OUT.json next to it (parameters, time, and F1 per label when the input carries ground-truth\n"
      "labels).\n"
      "  --method centroid-mincut (Aung & Thein, paper 003): object = min cut seeded by the points within\n"
      "    --radius of the cloud's centroid over a k-NN graph with smoothness exp(-d / sigma); label 1 object,\n"
      "    0 background. --solver maxflow (the paper's energy, libmaxflow) or pcl (pcl::MinCutSegmentation).\n"
      "  --method mrf (paper 000): multi-class MRF; seeds from the supporting plane (--seeds plane: RANSAC plane\n"
      "    = label 0, clusters above it by colour and distance = labels 1..) or a seed file (--seeds FILE.json);\n"
      "    a colour GMM per label, contrast-sensitive Potts on the 4-NN graph, alpha-expansion, GMMs re-fitted\n"
      "    until the energy settles. With ground truth: F1 per object and the confusion matrix.\n"
      "    --seeds saliency --sequence SEQ --work WORK --frame N: the cloud of an extract-features work folder\n"
      "    (WORK/cloud.pcd unless CLOUD is given) seen from frame N (WORK's camera pose, z-buffered), coloured\n"
      "    from its left image; object seeds = the salient regions of the image (OpenCV saliency, thresholded,\n"
      "    connected components; a region larger than --max-area is split at higher thresholds; each region's\n"
      "    points split by 3D distance and colour), background seeds = its non-salient area (and the rest of\n"
      "    the large regions). Only the visible points are labelled. Writes OUT, OUT.json, the labels\n"
      "    splatted into the frame (OUT.png) and the saliency map (OUT.saliency.png); F1 per object and the\n"
      "    confusion matrix against the frame's instance image (make-sequence --scene tabletop) when it has one.\n"
      "  --method grabcut-sfm (GrabCutSFM, paper 001): the object nearest the camera in one frame of a work\n"
      "    folder (--sequence SEQ --work WORK --frame N; cloud WORK/cloud.pcd or CLOUD, poses and focal from\n"
      "    WORK/tracks.json): RANSAC plane removal, 3D k-means (--k), the cluster nearest the camera projected\n"
      "    into the frame, 2D RANSAC outlier removal, its bounding box, OpenCV grabCut. -o MASK.png; also\n"
      "    MASK.overlay.png, the baselines' masks MASK.kmeans2.png (2D k-means, k = 2, on colour) and MASK.box.png\n"
      "    (grabCut on the truth's bounding box), and MASK.png.json with F1 of all three against --truth-label\n"
      "    NAME (the frame's label image), --truth-instance nearest|all|ID (instance images) or --truth-mask FILE.\n"
      "With --make-tabletop N, writes a synthetic tabletop cloud of N points instead (label 0 table,\n"
      "1..--objects objects) to -o.",
      "segment-cloud"};
  std::string input, out, method = "centroid-mincut", solver = "maxflow", up = "y";
  features::CentroidMinCutParams mc;
  features::TabletopCloudOptions tab;
  features::MrfParams mrf;
  features::PlaneSeedParams plane;
  std::string seeds = "plane";
  double mrf_lambda = mrf.lambda;
  int make_tabletop = 0, threads = 0, truth_object = 1;
  app.add_option("CLOUD", input, "input cloud (.pcd or .ply; fields x y z, optional rgb and label; grabcut-sfm: "
                 "default WORK/cloud.pcd)");
  app.add_option("-o,--out", out, "output cloud (.pcd or .ply; grabcut-sfm: the mask, .png); the summary goes to the same name + .json")->required();
  app.add_option("--method", method, "centroid-mincut, mrf or grabcut-sfm")->capture_default_str();
  app.add_option("--seeds", seeds, "mrf: plane, saliency, or a seed file {\"format\": \"smseg-seeds\", \"version\": 1, \"radius\": r, "
                 "\"seeds\": [{\"label\": 0, \"position\": [x, y, z]}, ...]}")->capture_default_str();
  SaliencyRun sal;
  app.add_option("--saliency", sal.saliency.method, "mrf saliency seeds: colour (fine-grained saliency of intensity, R-G, B-Y), fine-grained or "
                 "spectral-residual")
      ->capture_default_str();
  app.add_option("--saliency-threshold", sal.saliency.threshold,
                 "mrf saliency seeds: threshold on the 0..1 saliency map (0: Otsu)")->capture_default_str();
  app.add_option("--background", sal.saliency.background,
                 "mrf saliency seeds: background seeds where saliency < this x the threshold")->capture_default_str();
  app.add_option("--min-area", sal.saliency.min_area, "mrf saliency seeds: smallest salient region, share of the image")
      ->capture_default_str();
  app.add_option("--saliency-scale", sal.saliency.scale,
                 "mrf saliency seeds: image scale at which the saliency is computed")->capture_default_str();
  app.add_option("--max-area", sal.saliency.max_area,
                 "mrf saliency seeds: a larger salient component (share of the image) is a structure, split at "
                 "higher thresholds; its rest seeds the background")->capture_default_str();
  app.add_option("--saliency-step", sal.saliency.step, "mrf saliency seeds: threshold step of those splits")
      ->capture_default_str();
  app.add_option("--saliency-blur", sal.saliency.blur, "mrf saliency seeds: box-filter radius on the map (pixels)")
      ->capture_default_str();
  app.add_option("--min-seed-points", sal.min_seed_points,
                 "mrf saliency seeds: a salient region seeds a label when it holds this many visible points")
      ->capture_default_str();
  app.add_option("--seed-split", sal.split_distance,
                 "mrf saliency seeds: split each region's points into groups linked within this distance (metres) "
                 "and --seed-split-colour; each group seeds a label (0: one label per region)")->capture_default_str();
  app.add_option("--seed-split-colour", sal.split_colour, "mrf saliency seeds: RGB distance within one group")
      ->capture_default_str();
  app.add_option("--splat-radius", sal.projection.splat_radius,
                 "mrf saliency seeds: radius of a point's disc in the z-buffer and OUT.png (pixels)")
      ->capture_default_str();
  app.add_option("--components", mrf.components, "mrf: Gaussians per colour model")->capture_default_str();
  app.add_option("--mrf-lambda", mrf_lambda, "mrf: weight of the pairwise term")->capture_default_str();
  app.add_option("--iterations", mrf.max_iterations, "mrf: at most this many GMM re-estimation rounds")->capture_default_str();
  app.add_option("--plane-distance", plane.plane_distance,
                 "RANSAC plane inlier distance, metres: mrf plane seeds (default shown); grabcut-sfm plane removal "
                 "(default 0.05; 0: no plane removal)")->capture_default_str();
  app.add_option("--colour-tolerance", plane.colour_tolerance, "mrf plane seeds: RGB distance within one cluster")
      ->capture_default_str();
  app.add_option("--min-cluster", plane.min_cluster, "mrf plane seeds: smallest cluster that seeds an object")
      ->capture_default_str();
  app.add_option("--radius", mc.radius, "centroid-mincut: R, points within R of the centroid seed the object (required)");
  app.add_option("--neighbours", mc.neighbours, "centroid-mincut: k of the k-nearest-neighbour graph (mrf uses 000's 4)")
      ->capture_default_str();
  app.add_option("--sigma", mc.sigma, "smoothness scale (0: mean distance of the points to their k nearest neighbours)")
      ->capture_default_str();
  app.add_option("--lambda", mc.lambda, "centroid-mincut (maxflow): weight of the smoothness term")->capture_default_str();
  app.add_option("--solver", solver, "centroid-mincut: maxflow or pcl")->capture_default_str();
  app.add_option("--source-weight", mc.source_weight, "centroid-mincut (pcl): PCL's foreground weight")
      ->capture_default_str();
  app.add_option("--up", up, "centroid-mincut (pcl): the cloud's up axis, x, y or z")->capture_default_str();
  app.add_option("--truth-object", truth_object,
                 "centroid-mincut: the ground-truth label of the object, for F1 (when the cloud has labels)")
      ->capture_default_str();
  app.add_option("--make-tabletop", make_tabletop, "write a synthetic tabletop cloud of this many points instead");
  app.add_option("--objects", tab.objects, "--make-tabletop: objects on the table (1..8)")->capture_default_str();
  app.add_option("--seed", tab.seed, "seed of --make-tabletop and of grabcut-sfm's random draws")->capture_default_str();
  app.add_option("--threads", threads, "worker threads (0: all cores)")->capture_default_str();
  GrabCutSfmCli gc;
  app.add_option("--sequence", sal.sequence,
                 "grabcut-sfm and mrf saliency seeds: the sequence (folder or sequence.json)");
  app.add_option("--work", sal.work,
                 "grabcut-sfm and mrf saliency seeds: the extract-features work folder (tracks.json, cloud.pcd)");
  app.add_option("--frame", sal.frame,
                 "grabcut-sfm: the frame to segment; mrf saliency seeds: the frame whose image seeds and views the "
                 "cloud (sequence index)");
  app.add_option("--truth-label", gc.truth_label, "grabcut-sfm: F1 against the frame's pixels of this class (void ignored)");
  app.add_option("--truth-region", gc.truth_region,
                 "grabcut-sfm, --truth-label: largest (the class's largest 8-connected region; its other pixels "
                 "count as background) or all")->capture_default_str();
  app.add_option("--truth-instance", gc.truth_instance,
                 "grabcut-sfm: F1 against an object of the frame's instance image (synthetic tabletop): nearest "
                 "(smallest median ground-truth depth), all, or an object id");
  app.add_option("--truth-mask", gc.truth_mask, "grabcut-sfm: F1 against this 8-bit mask image (non-zero = object)");
  app.add_option("--truth-value", gc.truth_value, "grabcut-sfm, --truth-mask: object = pixels of this value (0: any non-zero)")
      ->capture_default_str();
  app.add_option("--k", gc.params.k, "grabcut-sfm: 3D k-means clusters")->capture_default_str();
  app.add_option("--outlier-threshold", gc.params.outlier_threshold,
                 "grabcut-sfm: 2D RANSAC inlier ellipse, robust standard deviations per axis")->capture_default_str();
  app.add_option("--box-margin", gc.params.box_margin, "grabcut-sfm: share of the box's size added on each side")
      ->capture_default_str();
  app.add_option("--grabcut-iterations", gc.params.grabcut_iterations, "grabcut-sfm: cv::grabCut iterations")
      ->capture_default_str();
  app.add_option("--min-cluster-points", gc.params.min_cluster_points,
                 "grabcut-sfm: projections in the frame a cluster needs to be chosen")->capture_default_str();
  app.add_option("--max-distance", gc.params.max_distance,
                 "grabcut-sfm: cluster only the points within this many metres of the camera (0: all; 001 uses all)")
      ->capture_default_str();
  app.add_option("--window", gc.window,
                 "grabcut-sfm: cluster the tracks of WORK/tracks.json seen within this many frames of --frame "
                 "(one point per track, its mean world position there) instead of the whole cloud (-1; 001 uses "
                 "one reconstruction)")->capture_default_str();
  app.add_flag("--frustum-only", gc.params.frustum_only,
               "grabcut-sfm: cluster only the points projecting into the frame (001 clusters the whole cloud)");
  app.add_option("--planes", gc.params.planes,
                 "grabcut-sfm: remove up to this many RANSAC planes in turn (001: 1)")->capture_default_str();
  app.add_option("--plane-min-share", gc.params.plane_min_share,
                 "grabcut-sfm: a second or later plane is removed only if it holds this share of the points left")
      ->capture_default_str();
  app.add_option("--height-band", gc.params.height_band,
                 "grabcut-sfm: metres; > 0 keeps only the points between --plane-distance and this height above the "
                 "supporting plane (the first plane, its RANSAC hypotheses restricted to normals within --max-tilt of "
                 "the camera's up axis; 0: no band, 001)")->capture_default_str();
  app.add_option("--max-tilt", gc.params.max_tilt,
                 "grabcut-sfm, --height-band: degrees between the supporting plane's normal and the camera's up at most")
      ->capture_default_str();
  app.add_option("--support-radius", gc.params.support_radius,
                 "grabcut-sfm, --height-band: metres; > 0 keeps only the points standing on the supporting plane (their "
                 "foot on the plane within this of a plane inlier's foot; 0: the whole band)")->capture_default_str();
  app.add_option("--cluster", gc.cluster, "grabcut-sfm: kmeans (001, --k clusters) or euclidean (--cluster-tolerance)")
      ->capture_default_str();
  app.add_option("--cluster-tolerance", gc.params.cluster_tolerance,
                 "grabcut-sfm, --cluster euclidean: metres between neighbours of one cluster")->capture_default_str();
  app.add_option("--min-cluster-size", gc.params.min_cluster_size,
                 "grabcut-sfm, --cluster euclidean: smaller clusters are dropped")->capture_default_str();
  app.add_option("--nearest", gc.nearest,
                 "grabcut-sfm: the nearest cluster by its centre's distance (centre, 001) or its points' median "
                 "distance (median) or median depth along the optical axis (depth)")->capture_default_str();
  return run_tool(app, argc, argv, [&] {
    if (threads < 0) throw Error("", "--threads", "must be 0 (all cores) or a number of threads");
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0)
      limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
    if (make_tabletop > 0) {
      tab.points = make_tabletop;
      const features::ColouredCloud c = features::make_tabletop_cloud(tab);
      features::write_labelled_cloud(out, c, c.labels);
      std::cout << "tabletop cloud: " << c.size() << " points, " << tab.objects << " objects -> " << out << "\n";
      return 0;
    }
    if (method == "mrf" && seeds == "saliency") {
      mrf.lambda = mrf_lambda;
      mrf.neighbours = 4;
      mrf.validate();
      sal.input = input;
      sal.out = out;
      return run_saliency_mrf(sal, mrf);
    }
    if (method == "grabcut-sfm") {
      if (app.count("--plane-distance")) gc.params.plane_distance = plane.plane_distance;
      gc.params.seed = tab.seed;
      gc.params.euclidean = gc.cluster == "euclidean";
      gc.params.median_distance = gc.nearest == "median" || gc.nearest == "depth";
      gc.params.median_depth = gc.nearest == "depth";
      gc.sequence = sal.sequence;
      gc.work = sal.work;
      gc.frame = sal.frame;
      gc.cloud = input;
      gc.out = out;
      return run_grabcut_sfm(gc);
    }
    if (input.empty()) throw Error("", "CLOUD", "an input cloud is required (or --make-tabletop N)");
    if (method == "mrf") {
      mrf.lambda = mrf_lambda;
      mrf.neighbours = 4;
      mrf.validate();
      plane.validate();
      const features::ColouredCloud cloud = features::read_coloured_cloud(input);
      const auto t0 = std::chrono::steady_clock::now();
      features::MrfSeeds sd;
      features::MrfReport rep;
      std::vector<int> labels;
      try {
        sd = seeds == "plane" ? features::plane_seeds(cloud, plane) : features::file_seeds(cloud, seeds);
        labels = features::mrf_segment(cloud, sd, mrf, &rep);
      } catch (const Error& e) {
        throw Error(e.file().empty() ? input : e.file(), e.field(), e.reason());
      }
      const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      features::write_labelled_cloud(out, cloud, labels);
      Json seeds_json = Json::array();
      for (std::size_t l = 0; l < sd.regions.size(); ++l)
        seeds_json.push_back({{"label", l},
                              {"points", sd.regions[l].size()},
                              {"position", {sd.positions[l].x(), sd.positions[l].y(), sd.positions[l].z()}}});
      Json summary = {{"format", "smseg-segment-cloud"},
                      {"version", 1},
                      {"input", input},
                      {"method", method},
                      {"params",
                       {{"seeds", seeds},
                        {"neighbours", mrf.neighbours},
                        {"components", mrf.components},
                        {"lambda", mrf.lambda},
                        {"iterations", mrf.max_iterations},
                        {"tolerance", mrf.tolerance},
                        {"plane_distance", plane.plane_distance},
                        {"colour_tolerance", plane.colour_tolerance},
                        {"min_cluster", plane.min_cluster}}},
                      {"points", cloud.size()},
                      {"labels", rep.labels},
                      {"seeds", seeds_json},
                      {"iterations", rep.iterations},
                      {"energies", rep.energies},
                      {"beta", rep.beta},
                      {"seconds_mrf", rep.seconds},
                      {"seconds_total", total}};
      std::string line = input + ": " + std::to_string(cloud.size()) + " points, " + std::to_string(rep.labels) +
                         " labels (" + sd.method + " seeds), " + std::to_string(rep.iterations) + " rounds, " +
                         fmt(total * 1000, "%.1f") + " ms";
      if (cloud.has_labels()) {
        // Each predicted label stands for the ground-truth label most of its seed carries.
        const std::vector<int> map = features::seed_truth(cloud, sd);
        std::vector<int> mapped(labels.size());
        for (std::size_t i = 0; i < labels.size(); ++i) mapped[i] = map[std::size_t(labels[i])];
        int truth_max = 0;
        for (int t : cloud.labels) truth_max = std::max(truth_max, t);
        Json f1 = Json::array();
        line += ", F1";
        for (int t = 0; t <= truth_max; ++t) {
          const double v = features::f1_score(cloud.labels, mapped, t);
          f1.push_back({{"truth_label", t}, {"f1", nan_null(v)}});
          line += " " + std::to_string(t) + ":" + fmt(v, "%.3f");
        }
        Json confusion = Json::array();  // rows: truth labels 0..max; columns: predicted labels 0..L-1
        for (int t = 0; t <= truth_max; ++t) {
          std::vector<long> row(std::size_t(rep.labels), 0);
          for (std::size_t i = 0; i < labels.size(); ++i)
            if (cloud.labels[i] == t) ++row[std::size_t(labels[i])];
          confusion.push_back(row);
        }
        summary["seed_truth"] = map;
        summary["f1"] = f1;
        summary["confusion"] = confusion;
      }
      write_json_atomic(out + ".json", summary);
      std::cout << line << " -> " << out << "\n";
      return 0;
    }
    if (method != "centroid-mincut") throw Error("", "--method", "\"" + method + "\" is not a method (centroid-mincut, mrf or grabcut-sfm)");
    if (solver == "maxflow") mc.solver = features::MinCutSolver::MaxFlow;
    else if (solver == "pcl") mc.solver = features::MinCutSolver::Pcl;
    else throw Error("", "--solver", "\"" + solver + "\" is not a solver (maxflow or pcl)");
    if (up == "x" || up == "y" || up == "z") mc.up = up[0] - 'x';
    else throw Error("", "--up", "must be x, y or z");
    mc.validate();
    const features::ColouredCloud cloud = features::read_coloured_cloud(input);
    features::CentroidMinCutReport rep;
    std::vector<int> labels;
    try {
      labels = features::centroid_mincut(cloud, mc, &rep);
    } catch (const Error& e) {
      throw Error(input, e.field(), e.reason());
    }
    features::write_labelled_cloud(out, cloud, labels);
    Json summary = {{"format", "smseg-segment-cloud"},
                    {"version", 1},
                    {"input", input},
                    {"method", method},
                    {"params",
                     {{"radius", mc.radius},
                      {"neighbours", mc.neighbours},
                      {"sigma", mc.sigma},
                      {"sigma_used", rep.sigma},
                      {"lambda", mc.lambda},
                      {"solver", solver},
                      {"source_weight", mc.source_weight},
                      {"up", up}}},
                    {"points", cloud.size()},
                    {"centroid", {rep.centroid.x(), rep.centroid.y(), rep.centroid.z()}},
                    {"seeds", rep.seeds},
                    {"object_points", std::count(labels.begin(), labels.end(), 1)},
                    {"max_flow", rep.flow},
                    {"seconds", rep.seconds}};
    std::string line = input + ": " + std::to_string(cloud.size()) + " points, " + std::to_string(rep.seeds) +
                       " seeds within R, " + std::to_string(std::count(labels.begin(), labels.end(), 1)) +
                       " object points, sigma " + fmt(rep.sigma, "%.5f") + ", " + fmt(rep.seconds * 1000, "%.1f") +
                       " ms";
    if (cloud.has_labels()) {
      std::vector<int> truth(cloud.size());
      for (std::size_t i = 0; i < truth.size(); ++i)
        truth[i] = cloud.labels[i] < 0 ? -1 : (cloud.labels[i] == truth_object ? 1 : 0);
      const double f1 = features::f1_score(truth, labels, 1);
      summary["truth_object"] = truth_object;
      summary["f1_object"] = nan_null(f1);
      summary["f1_background"] = nan_null(features::f1_score(truth, labels, 0));
      line += ", F1 (object) " + fmt(f1);
    }
    write_json_atomic(out + ".json", summary);
    std::cout << line << " -> " << out << "\n";
    return 0;
  });
}
