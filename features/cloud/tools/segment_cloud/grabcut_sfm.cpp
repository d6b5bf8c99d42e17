// segment-cloud --method grabcut-sfm (GrabCutSFM, paper 001) and its baselines on one frame of a work folder.
#include <chrono>
#include <iostream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "runs.hpp"
#include "smseg/stacks/dense.hpp"
#include "smseg/frontend/tracks_io.hpp"
#include "smseg/sequence/image_file.hpp"

namespace segment_cloud {

namespace {

smseg::Json rect_json(const cv::Rect& r) { return {r.x, r.y, r.width, r.height}; }

}  // namespace

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
  if (int(o.window >= 0) + int(!o.cloud.empty()) + int(o.dense_cloud > 0) > 1)
    throw Error("", o.dense_cloud > 0 ? "--dense-cloud" : "--window", "give one of a CLOUD, --window and --dense-cloud");
  std::string cloud_path = o.cloud.empty() ? (fs::path(o.work) / "cloud.pcd").string() : o.cloud;
  sf::ColouredCloud cloud;
  if (o.dense_cloud > 0) {  // the frame's own dense depth, with the stereo range the work folder used
    if (seq.kind != sf::SequenceKind::Stereo)
      throw Error(seq.manifest.string(), "--dense-cloud", "needs a stereo sequence (dense depth from its pairs)");
    sf::StereoOptions stereo;
    const Json& st = tracks.options.contains("stereo") ? tracks.options["stereo"] : Json::object();
    stereo.num_disparities = st.value("num_disparities", stereo.num_disparities);
    stereo.min_disparity = st.value("min_disparity", stereo.min_disparity);
    cloud_path = seq.manifest.string();
    cloud.points = sf::dense_frame_cloud(sf::dense_depth(seq, o.frame, sf::dense_stereo_options(stereo)), seq.calibration,
                                         pose, o.dense_cloud);
    if (cloud.points.empty()) throw Error(cloud_path, "--dense-cloud", "frame " + std::to_string(o.frame) + " has no dense depth");
  } else if (o.window >= 0) {  // the tracks around the frame
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
  std::vector<Eigen::Vector3f> plane_cloud;  // --plane-window: the tracks around the frame find the plane
  if (o.plane_window >= 0) {
    if (!(o.params.plane_distance > 0))
      throw Error("", "--plane-window", "needs plane removal (--plane-distance > 0)");
    plane_cloud = sf::window_cloud(tracks.result, o.frame, o.plane_window);
    if (plane_cloud.empty())
      throw Error(tracks_path.string(), "--plane-window", "no track has a 3D point within " +
                                                              std::to_string(o.plane_window) + " frames of frame " +
                                                              std::to_string(o.frame));
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
    const cv::Mat m = sf::read_image_file(o.truth_mask, cv::IMREAD_UNCHANGED);
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
    mask = sf::grabcut_sfm(cloud.points, k, pose, image, o.params, &rep, o.plane_window >= 0 ? &plane_cloud : nullptr);
  } catch (const Error& e) {
    throw Error(e.field() == "cloud" ? cloud_path : e.file(), e.field(),
                e.reason() + " (frame " + std::to_string(o.frame) + ")");
  }
  const fs::path out(o.out);
  const fs::path stem = out.parent_path() / out.stem();
  begin_output_set(o.out);
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
                    {"dense_cloud", o.dense_cloud},
                    {"plane_window", o.plane_window},
                    {"planes", p.planes},
                    {"plane_min_share", p.plane_min_share},
                    {"height_band", p.height_band},
                    {"max_tilt", p.max_tilt},
                    {"up", p.world_up ? "world" : "camera"},
                    {"box_to_plane", p.box_to_plane},
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
                  {"feet_in_box", rep.feet_in_box},
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

}  // namespace segment_cloud
