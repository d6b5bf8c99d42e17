// segment-cloud --method mrf --seeds saliency: the cloud of a work folder seen from one frame (paper 000).
#include <chrono>
#include <iostream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "runs.hpp"
#include "smseg/stacks/front_ends.hpp"

namespace segment_cloud {

namespace {

using namespace smseg;
using namespace smseg::sequence;
using namespace smseg::frontend;
using namespace smseg::cloud;

/// The sequence, work folder, cloud and frame of a --seeds saliency run, checked.
struct SaliencyInput {
  Sequence seq;
  fs::path work;
  TracksFile tracks;
  std::string input;  ///< the cloud's file
  ColouredCloud cloud;
  int pose_index = 0;
};

SaliencyInput load_saliency_input(const SaliencyRun& run) {
  as_usage([&] {  // the options alone, before anything is read: bad usage (exit status 2)
    if (run.sequence.empty() || run.work.empty() || run.frame < 0)
      throw Error("", run.sequence.empty() ? "--sequence" : run.work.empty() ? "--work" : "--frame",
                  "--seeds saliency needs --sequence SEQ, --work WORK and --frame N (N >= 0)");
    run.saliency.validate();
    run.projection.validate();
    if (run.min_seed_points < 1) throw Error("", "--min-seed-points", "must be at least 1");
    if (!(run.split_distance >= 0)) throw Error("", "--seed-split", "must be >= 0 metres (0: no split)");
    if (!(run.split_colour > 0)) throw Error("", "--seed-split-colour", "must be positive");
  });
  SaliencyInput in{load_sequence(run.sequence), fs::path(run.work), {}, {}, {}, 0};
  const Sequence& seq = in.seq;
  if (run.frame >= seq.frame_count())
    throw Error(seq.manifest.string(), "--frame",
                "frame " + std::to_string(run.frame) + " is outside the sequence's frames 0.." +
                    std::to_string(seq.frame_count() - 1));
  if (!seq.calibration.fx || !seq.calibration.fy)
    throw Error(seq.manifest.string(), "calibration", "projecting a cloud needs the focal length (fx, fy)");
  if (!fs::is_directory(in.work)) throw Error(in.work.string(), "--work", "no such work folder (run extract-features first)");
  in.tracks = stacks::read_tracks(in.work / "tracks.json");
  check_made_from(in.tracks, in.work / "tracks.json", seq);
  const FrontEndResult& fe = in.tracks.result;
  in.pose_index = run.frame - fe.first_frame;
  if (in.pose_index < 0 || in.pose_index >= static_cast<int>(fe.poses.size()))
    throw Error((in.work / "tracks.json").string(), "--frame",
                "frame " + std::to_string(run.frame) + " has no camera pose: the work folder holds frames " +
                    std::to_string(fe.first_frame) + ".." + std::to_string(fe.first_frame + int(fe.poses.size()) - 1));
  if (in.tracks.image_size != seq.size)
    throw Error((in.work / "tracks.json").string(), "image_size", "differs from the sequence's image size");
  in.input = run.input.empty() ? (in.work / "cloud.pcd").string() : run.input;
  in.cloud = read_coloured_cloud(in.input);
  return in;
}

/// The saliency map with the salient regions outlined in red.
cv::Mat saliency_picture(const SalientRegions& sr) {
  cv::Mat s8, vis;
  sr.saliency.convertTo(s8, CV_8U, 255.0);
  cv::cvtColor(s8, vis, cv::COLOR_GRAY2BGR);
  for (int y = 0; y < vis.rows; ++y)
    for (int x = 0; x < vis.cols; ++x) {
      const int r = sr.regions.at<int>(y, x);
      if (r == 0) continue;
      const bool edge = x == 0 || y == 0 || x == vis.cols - 1 || y == vis.rows - 1 ||
                        sr.regions.at<int>(y, x - 1) != r || sr.regions.at<int>(y - 1, x) != r ||
                        sr.regions.at<int>(y, x + 1) != r || sr.regions.at<int>(y + 1, x) != r;
      if (edge) vis.at<cv::Vec3b>(y, x) = cv::Vec3b(0, 0, 255);
    }
  return vis;
}

Json saliency_params_json(const SaliencyRun& run, const MrfParams& mrf) {
  Json params = saliency_run_table().to_json(run);
  params.update(mrf_params_table().to_json(mrf));
  params["seeds"] = "saliency";
  return params;
}

/// Per seed label its salient region, points and position; the labels' picture colours.
Json seeds_json(const MrfSeeds& sd, const std::vector<int>& region_of_label) {
  Json out = Json::array();
  for (std::size_t l = 0; l < sd.regions.size(); ++l)
    out.push_back({{"label", l},
                   {"salient_region", region_of_label[l]},
                   {"points", sd.regions[l].size()},
                   {"position", {sd.positions[l].x(), sd.positions[l].y(), sd.positions[l].z()}}});
  return out;
}

Json label_colours_json(int labels) {
  Json colours = Json::array();
  for (int l = 0; l < labels; ++l) {
    const cv::Vec3b c = label_colour(l);
    colours.push_back({c[2], c[1], c[0]});
  }
  return colours;
}

/// Ground truth per visible point: the object id at its pixel, or the cloud's own (class) labels; F1
/// per truth id into the summary and the line.
void score_view(const SaliencyRun& run, const SaliencyInput& in, const CloudProjection& proj,
                const std::vector<cv::Point>& pixels, const std::vector<int>& view_labels, int labels, Json& summary,
                std::string& line) {
  std::vector<int> truth;
  int truth_ids = 0;
  std::string truth_source;
  if (in.seq.has_instances(run.frame)) {
    const cv::Mat inst = in.seq.load_instances(run.frame);
    double hi = 0;
    cv::minMaxLoc(inst, nullptr, &hi);
    truth_ids = static_cast<int>(hi) + 1;
    if (in.seq.extra.contains("objects") && in.seq.extra["objects"].is_array())
      truth_ids = std::max(truth_ids, static_cast<int>(in.seq.extra["objects"].size()) + 1);
    for (const cv::Point& p : pixels) truth.push_back(inst.at<std::uint8_t>(p));
    truth_source = "instances";
  } else if (in.cloud.has_labels()) {
    for (int i : proj.visible) truth.push_back(in.cloud.labels[static_cast<std::size_t>(i)]);
    for (int t : truth) truth_ids = std::max(truth_ids, t + 1);
    truth_source = "cloud labels";
  }
  if (truth_ids == 0) return;
  const InstanceScore sc = score_instances(truth, view_labels, truth_ids, labels);
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

/// The frame's camera: the sequence's intrinsics, the work folder's pose.
ViewCamera frame_camera(const SaliencyInput& in) {
  ViewCamera cam;
  cam.fx = *in.seq.calibration.fx;
  cam.fy = *in.seq.calibration.fy;
  cam.cx = in.seq.calibration.cx;
  cam.cy = in.seq.calibration.cy;
  cam.size = in.seq.size;
  cam.pose = in.tracks.result.poses[static_cast<std::size_t>(in.pose_index)];
  return cam;
}

}  // namespace

const options::Table<SaliencyRun>& saliency_run_table() {
  static const options::Table<SaliencyRun> table = [] {
    options::Table<SaliencyRun> t("mrf saliency seeds", kSegmentCloudSurfaces);
    t.include(saliency_params_table(), [](auto& r) -> auto& { return r.saliency; });
    t.number("min_seed_points", "--min-seed-points",
             "mrf saliency seeds: a salient region seeds a label when it holds this many visible points",
             [](auto& r) -> auto& { return r.min_seed_points; }, 1, 1000000);
    t.number("seed_split", "--seed-split",
             "mrf saliency seeds: split each region's points into groups linked within this distance (metres) "
             "and --seed-split-colour; each group seeds a label (0: one label per region)",
             [](auto& r) -> auto& { return r.split_distance; }, 0.0, 1000.0);
    t.number("seed_split_colour", "--seed-split-colour", "mrf saliency seeds: RGB distance within one group",
             [](auto& r) -> auto& { return r.split_colour; }, 0.000001, 1000.0);
    t.include(projection_params_table(), [](auto& r) -> auto& { return r.projection; });
    return t;
  }();
  return table;
}

/// segment-cloud --method mrf --seeds saliency: the cloud seen from one frame, seeded by the frame's
/// salient regions (paper 000), scored against the frame's instance image (or the cloud's labels).
int run_saliency_mrf(const SaliencyRun& run, const MrfParams& mrf) {
  const SaliencyInput in = load_saliency_input(run);
  const ColouredCloud& cloud = in.cloud;
  const auto t0 = std::chrono::steady_clock::now();
  const CloudProjection proj = project_cloud(cloud, frame_camera(in), run.projection);
  const fs::path image_path = in.seq.resolve(in.seq.frames[static_cast<std::size_t>(run.frame)].left);
  if (proj.visible.size() < 10)
    throw Error(in.input, "--frame",
                "only " + std::to_string(proj.visible.size()) + " of the cloud's points are visible in frame " +
                    std::to_string(run.frame) + " (is the cloud from this work folder?)");
  // The visible points, coloured from the frame's image (cloud.pcd carries class colours, not image colours).
  const cv::Mat image = in.seq.load_left(run.frame);
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
  std::vector<int> region_of_label, view_labels;
  MrfReport rep;
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
  begin_output_set(run.out);
  write_labelled_cloud(run.out, cloud, labels);
  const std::string picture = run.out + ".png", saliency_file = run.out + ".saliency.png";
  write_image_atomic(picture, splat_labels(proj, labels, in.seq.size, run.projection.splat_radius));
  write_image_atomic(saliency_file, saliency_picture(sr));
  Json summary = {{"format", "smseg-segment-cloud"}, {"version", 1}, {"input", in.input}, {"method", "mrf"},
                  {"sequence", in.seq.manifest.string()}, {"work", in.work.string()}, {"frame", run.frame},
                  {"image", image_path.string()}, {"params", saliency_params_json(run, mrf)},
                  {"points", cloud.size()}, {"visible_points", proj.visible.size()},
                  {"colours", "the visible points' pixels in the frame's left image"},
                  {"saliency_threshold_used", sr.threshold}, {"salient_regions", sr.count}, {"labels", rep.labels},
                  {"seeds", seeds_json(sd, region_of_label)}, {"iterations", rep.iterations},
                  {"energies", rep.energies}, {"beta", rep.beta}, {"projection", picture},
                  {"projection_colours", label_colours_json(rep.labels)}, {"saliency_map", saliency_file},
                  {"seconds_mrf", rep.seconds}, {"seconds_total", seconds}};
  std::string line = in.seq.name + " frame " + std::to_string(run.frame) + ": " + std::to_string(proj.visible.size()) +
                     " of " + std::to_string(cloud.size()) + " points visible, " + std::to_string(sr.count) +
                     " salient regions, " + std::to_string(rep.labels) + " labels, " + std::to_string(rep.iterations) +
                     " rounds";
  score_view(run, in, proj, pixels, view_labels, rep.labels, summary, line);
  write_json_atomic(run.out + ".json", summary);
  std::cout << line << " -> " << run.out << "\n";
  return 0;
}

}  // namespace segment_cloud
