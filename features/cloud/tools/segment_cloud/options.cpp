// segment-cloud's options, one function per group, and the choice of the method they ask for.
#include <initializer_list>
#include <iostream>
#include <tuple>
#include <utility>
#include <vector>

#include "runs.hpp"
#include "smseg/common/options.hpp"

namespace segment_cloud {

using namespace smseg;

void add_io_options(CLI::App& app, SegmentCloudOptions& o) {
  app.add_option("CLOUD", o.input, "input cloud (.pcd or .ply; fields x y z, optional rgb and label; grabcut-sfm: "
                 "default WORK/cloud.pcd)");
  app.add_option("-o,--out", o.out, "output cloud (.pcd or .ply; grabcut-sfm: the mask, .png); the summary goes to the same name + .json, "
                 "written last (the old one is removed first: a summary is only beside the files of its own run)")->required();
  app.add_option("--method", o.method, "centroid-mincut, mrf or grabcut-sfm")->capture_default_str();
  app.add_option("--seeds", o.seeds, "mrf: plane, saliency, or a seed file {\"format\": \"smseg-seeds\", \"version\": 1, \"radius\": r, "
                 "\"seeds\": [{\"label\": 0, \"position\": [x, y, z]}, ...]}")->capture_default_str();
  app.add_option("--make-tabletop", o.make_tabletop, "write a synthetic tabletop cloud of this many points (1..10000000) instead")
      ->check(options::in_range(1, 10000000));
  app.add_option("--objects", o.tab.objects, "--make-tabletop: objects on the table (1..8)")->capture_default_str()
      ->check(options::in_range(1, 8));
  app.add_option("--seed", o.tab.seed, "seed of --make-tabletop and of grabcut-sfm's random draws")->capture_default_str()
      ->check(options::any_seed())->check(CLI::Validator(kDecimalDigits).description(""));
  add_threads_option(app, o.threads);
}

void add_mrf_options(CLI::App& app, SegmentCloudOptions& o) {
  app.add_option("--saliency", o.sal.saliency.method, "mrf saliency seeds: colour (fine-grained saliency of intensity, R-G, B-Y), fine-grained or "
                 "spectral-residual")
      ->capture_default_str();
  app.add_option("--saliency-threshold", o.sal.saliency.threshold,
                 "mrf saliency seeds: threshold on the 0..1 saliency map (0: Otsu)")->capture_default_str()
      ->check(options::in_range(0.0, 0.999999));
  app.add_option("--background", o.sal.saliency.background,
                 "mrf saliency seeds: background seeds where saliency < this x the threshold")->capture_default_str()
      ->check(options::in_range(0.000001, 1.0));
  app.add_option("--min-area", o.sal.saliency.min_area, "mrf saliency seeds: smallest salient region, share of the image")
      ->capture_default_str()
      ->check(options::in_range(0.000001, 0.999999));
  app.add_option("--saliency-scale", o.sal.saliency.scale,
                 "mrf saliency seeds: image scale at which the saliency is computed")->capture_default_str()
      ->check(options::in_range(0.05, 1.0));
  app.add_option("--max-area", o.sal.saliency.max_area,
                 "mrf saliency seeds: a larger salient component (share of the image) is a structure, split at "
                 "higher thresholds; its rest seeds the background")->capture_default_str()
      ->check(options::in_range(0.000001, 1.0));
  app.add_option("--saliency-step", o.sal.saliency.step, "mrf saliency seeds: threshold step of those splits")
      ->capture_default_str()
      ->check(options::in_range(0.005, 0.999999));
  app.add_option("--saliency-blur", o.sal.saliency.blur, "mrf saliency seeds: box-filter radius on the map (pixels)")
      ->capture_default_str()
      ->check(options::in_range(0, 50));
  app.add_option("--min-seed-points", o.sal.min_seed_points,
                 "mrf saliency seeds: a salient region seeds a label when it holds this many visible points")
      ->capture_default_str()
      ->check(options::in_range(1, 1000000));
  app.add_option("--seed-split", o.sal.split_distance,
                 "mrf saliency seeds: split each region's points into groups linked within this distance (metres) "
                 "and --seed-split-colour; each group seeds a label (0: one label per region)")->capture_default_str()
      ->check(options::in_range(0.0, 1000.0));
  app.add_option("--seed-split-colour", o.sal.split_colour, "mrf saliency seeds: RGB distance within one group")
      ->capture_default_str()
      ->check(options::in_range(0.000001, 1000.0));
  app.add_option("--splat-radius", o.sal.projection.splat_radius,
                 "mrf saliency seeds: radius of a point's disc in the z-buffer and OUT.png (pixels)")
      ->capture_default_str()
      ->check(options::in_range(0, 20));
  app.add_option("--components", o.mrf.components, "mrf: Gaussians per colour model")->capture_default_str()
      ->check(options::in_range(1, 20));
  app.add_option("--mrf-lambda", o.mrf_lambda, "mrf: weight of the pairwise term")->capture_default_str()
      ->check(options::in_range(0.0, 1e6));
  app.add_option("--iterations", o.mrf.max_iterations, "mrf: at most this many GMM re-estimation rounds")->capture_default_str()
      ->check(options::in_range(1, 1000));
  app.add_option("--plane-distance", o.plane.plane_distance,
                 "RANSAC plane inlier distance, metres: mrf plane seeds (default shown); grabcut-sfm, the supporting "
                 "plane's slab (default: --support table: --slab-share x the table's distance; plane: 0.05, 0: no "
                 "plane removal)")->capture_default_str()
      ->check(options::in_range(-1.0, 1000.0));
  app.add_option("--colour-tolerance", o.plane.colour_tolerance, "mrf plane seeds: RGB distance within one cluster")
      ->capture_default_str()
      ->check(options::in_range(0.000001, 1000.0));
  app.add_option("--min-cluster", o.plane.min_cluster, "mrf plane seeds: smallest cluster that seeds an object")
      ->capture_default_str()
      ->check(options::in_range(1, 10000000));
}

void add_centroid_options(CLI::App& app, SegmentCloudOptions& o) {
  app.add_option("--radius", o.mc.radius, "centroid-mincut: R, points within R of the centroid seed the object (required)")
      ->check(options::in_range(0.000001, 1e6));
  app.add_option("--neighbours", o.mc.neighbours, "centroid-mincut: k of the k-nearest-neighbour graph (mrf uses 000's 4)")
      ->capture_default_str()
      ->check(options::in_range(1, 100));
  app.add_option("--sigma", o.mc.sigma, "smoothness scale (0: mean distance of the points to their k nearest neighbours)")
      ->capture_default_str()
      ->check(options::in_range(0.0, 1e6));
  app.add_option("--lambda", o.mc.lambda, "centroid-mincut (maxflow): weight of the smoothness term")->capture_default_str()
      ->check(options::in_range(0.0, 1e6));
  app.add_option("--solver", o.solver, "centroid-mincut: maxflow or pcl")->capture_default_str();
  app.add_option("--source-weight", o.mc.source_weight, "centroid-mincut (pcl): PCL's foreground weight")
      ->capture_default_str()
      ->check(options::in_range(0.000001, 1e6));
  app.add_option("--up", o.up, "centroid-mincut (pcl): the cloud's up axis, x, y or z")->capture_default_str();
  app.add_option("--truth-object", o.truth_object,
                 "centroid-mincut: the ground-truth label of the object, for F1 (when the cloud has labels)")
      ->capture_default_str()
      ->check(options::in_range(0, 1000000));
}

void add_grabcut_sfm_options(CLI::App& app, SegmentCloudOptions& o) {
  app.add_option("--sequence", o.sal.sequence,
                 "grabcut-sfm and mrf saliency seeds: the sequence (folder or sequence.json)");
  app.add_option("--work", o.sal.work,
                 "grabcut-sfm and mrf saliency seeds: the extract-features work folder (tracks.json, cloud.pcd)");
  app.add_option("--frame", o.sal.frame,
                 "grabcut-sfm: the frame to segment; mrf saliency seeds: the frame whose image seeds and views the "
                 "cloud (sequence index)");
  app.add_option("--truth-label", o.gc.truth_label, "grabcut-sfm: F1 against the frame's pixels of this class (void ignored)");
  app.add_option("--truth-region", o.gc.truth_region,
                 "grabcut-sfm, --truth-label: largest (the class's largest 8-connected region; its other pixels "
                 "count as background) or all")->capture_default_str();
  app.add_option("--truth-instance", o.gc.truth_instance,
                 "grabcut-sfm: F1 against an object of the frame's instance image (synthetic tabletop): nearest "
                 "(smallest median ground-truth depth), all, or an object id");
  app.add_option("--truth-mask", o.gc.truth_mask, "grabcut-sfm: F1 against this 8-bit mask image (non-zero = object)");
  app.add_option("--truth-value", o.gc.truth_value, "grabcut-sfm, --truth-mask: object = pixels of this value (0: any non-zero)")
      ->capture_default_str();
  app.add_option("--k", o.gc.params.k, "grabcut-sfm: 3D k-means clusters")->capture_default_str();
  app.add_option("--outlier-threshold", o.gc.params.outlier_threshold,
                 "grabcut-sfm: 2D RANSAC inlier ellipse, robust standard deviations per axis")->capture_default_str();
  app.add_option("--box-margin", o.gc.params.box_margin, "grabcut-sfm: share of the box's size added on each side")
      ->capture_default_str();
  app.add_option("--grabcut-iterations", o.gc.params.grabcut_iterations, "grabcut-sfm: cv::grabCut iterations")
      ->capture_default_str();
  app.add_option("--min-cluster-points", o.gc.params.min_cluster_points,
                 "grabcut-sfm: projections in the frame a cluster needs to be chosen")->capture_default_str();
  app.add_option("--max-distance", o.gc.params.max_distance,
                 "grabcut-sfm: cluster only the points within this many metres of the camera (0: all; 001 uses all)")
      ->capture_default_str();
  app.add_option("--dense-cloud", o.gc.dense_cloud,
                 "grabcut-sfm, stereo sequences: cluster the frame's own dense depth (eight-path SGBM, as extract-features "
                 "--dense), one point every this many pixels, instead of the tracked cloud")
      ->check(options::in_range(1, 64));
  app.add_option("--window", o.gc.window,
                 "grabcut-sfm: cluster the tracks of WORK/tracks.json seen within this many frames of --frame "
                 "(one point per track, its mean world position there) instead of the whole cloud (-1; 001 uses "
                 "one reconstruction)")->capture_default_str();
  app.add_option("--plane-window", o.gc.plane_window,
                 "grabcut-sfm: fit the first (supporting) plane to the tracks seen within this many frames of --frame "
                 "(as --window) and remove its inliers from the clustered cloud, e.g. with --dense-cloud, whose "
                 "depth sees more floor than table top from above a table (-1: the clustered cloud's own plane)")
      ->capture_default_str();
  app.add_flag("--frustum-only", o.gc.params.frustum_only,
               "grabcut-sfm: cluster only the points projecting into the frame (001 clusters the whole cloud)");
  app.add_option("--planes", o.gc.params.planes,
                 "grabcut-sfm: remove up to this many RANSAC planes in turn (001: 1)")->capture_default_str();
  app.add_option("--plane-min-share", o.gc.params.plane_min_share,
                 "grabcut-sfm: a second or later plane is removed only if it holds this share of the points left")
      ->capture_default_str();
}

/// The tuning of --method grabcut-sfm: every default is relative to the scene (or 001's with --support
/// plane); each option overrides one.
void add_grabcut_sfm_overrides(CLI::App& app, SegmentCloudOptions& o) {
  app.add_option("--support", o.gc.support,
                 "grabcut-sfm: table (the highest horizontal patch with points standing on it, every distance relative "
                 "to the scene; keeps the points standing on it) or plane (001: the dominant RANSAC plane, distances in "
                 "metres)")->capture_default_str();
  app.add_option("--slab-share", o.gc.params.table.slab_share,
                 "grabcut-sfm, --support table: a point lies on a plane within this share of its distance from the camera")
      ->capture_default_str();
  app.add_option("--table-min-width", o.gc.params.table.min_width_share,
                 "grabcut-sfm, --support table: a table is at least this x the camera's height above it wide")
      ->capture_default_str();
  app.add_option("--table-min-share", o.gc.params.table.min_share,
                 "grabcut-sfm, --support table: a candidate plane holds at least this share of the points below the camera "
                 "beyond the mean count three slabs above and below it (walls)")
      ->capture_default_str();
  app.add_option("--table-min-points", o.gc.params.table.min_points,
                 "grabcut-sfm, --support table: ... and at least this many points")->capture_default_str();
  app.add_option("--table-prominence", o.gc.params.table.min_prominence,
                 "grabcut-sfm, --support table: ... and this x the mean count three slabs above and below it")
      ->capture_default_str();
  app.add_option("--table-max-tilt", o.gc.params.table.max_refit_tilt,
                 "grabcut-sfm, --support table: degrees; the table's least-squares plane is kept within this of up")
      ->capture_default_str();
  app.add_option("--table-min-depression", o.gc.params.table.min_depression,
                 "grabcut-sfm, --support table: the camera's height above a table at least this x its distance")
      ->capture_default_str();
  app.add_option("--table-min-standing", o.gc.params.table.min_standing_share,
                 "grabcut-sfm, --support table: points standing on a table, share of its own points at least")
      ->capture_default_str();
  app.add_option("--height-band", o.gc.params.height_band,
                 "grabcut-sfm: metres; > 0 keeps only the points between the slab and this height above the "
                 "supporting plane (--support plane: the first plane, its RANSAC hypotheses restricted to normals within "
                 "--max-tilt of the up direction; 0: no band, 001). Default -1: table: the camera's height above it; "
                 "plane: no band")->capture_default_str();
  app.add_option("--max-tilt", o.gc.params.max_tilt,
                 "grabcut-sfm, --support plane --height-band: degrees between the supporting plane's normal and the up "
                 "direction (--plane-up) at most")->capture_default_str();
  app.add_option("--plane-up", o.gc.up,
                 "grabcut-sfm: the up direction the supporting plane faces: estimate (from the work folder's camera "
                 "path and tracks, as extract-features --gravity estimate), camera (the frame's up axis), world (world "
                 "+Y: work folders made with --gravity estimate), auto (table: estimate; plane: camera)")
      ->capture_default_str();
  app.add_flag("--box-to-plane", o.gc.params.box_to_plane,
               "grabcut-sfm: the box reaches down to the projections of the chosen points' feet on the supporting "
               "plane (an object's lower part is in the plane's slab or untracked); default: on with --support table "
               "for a cluster whose lowest point lies within --min-rise slabs of the table (--box-to-plane=false: "
               "off), off with --support plane");
  app.add_option("--support-radius", o.gc.params.support_radius,
                 "grabcut-sfm: metres; > 0 keeps only the points standing on the supporting plane (their foot on the "
                 "plane within this of a plane inlier's foot). Default -1: table: their foot inside the table's hull; "
                 "plane: the whole band")->capture_default_str();
  app.add_option("--cluster", o.gc.cluster,
                 "grabcut-sfm: kmeans (001, --k clusters), euclidean (--cluster-tolerance) or auto (table: euclidean, "
                 "plane: kmeans)")->capture_default_str();
  app.add_option("--cluster-tolerance", o.gc.params.cluster_tolerance,
                 "grabcut-sfm, euclidean: metres between neighbours of one cluster (default -1: table: --tolerance-share x "
                 "the kept points' median distance to their 4th neighbour; plane: 0.03)")->capture_default_str();
  app.add_option("--tolerance-share", o.gc.params.tolerance_share, "grabcut-sfm: see --cluster-tolerance")
      ->capture_default_str();
  app.add_option("--min-cluster-size", o.gc.params.min_cluster_size,
                 "grabcut-sfm, euclidean: smaller clusters are dropped (default -1: table: --min-cluster-share of the "
                 "kept points, at least 10; plane: 10)")->capture_default_str();
  app.add_option("--min-cluster-share", o.gc.params.min_cluster_share, "grabcut-sfm: see --min-cluster-size")
      ->capture_default_str();
  app.add_option("--edge-margin", o.gc.params.table.edge_margin,
                 "grabcut-sfm, --support table: slabs; the points kept stand this far inside the table's outline")
      ->capture_default_str();
  app.add_option("--min-rise", o.gc.params.table.min_rise,
                 "grabcut-sfm, --support table: a cluster is an object when it reaches this many slabs above the table")
      ->capture_default_str();
  app.add_option("--nearest", o.gc.nearest,
                 "grabcut-sfm: the nearest cluster by its centre's distance (centre, 001), its points' median "
                 "distance (median) or median depth along the optical axis (depth); auto: table: depth, plane: centre")->capture_default_str();
}

void add_grabcut_sfm_ranges(CLI::App& app) {
  // -1 is "from the scene" where the help says so; an option renamed meanwhile is skipped here and shows
  // in the option-range sweep as unranged.
  const auto check = [&app](const char* name, const CLI::Validator& range) {
    if (CLI::Option* option = app.get_option_no_throw(name)) option->check(range);
  };
  for (const auto& [name, lo, hi] : std::initializer_list<std::tuple<const char*, int, int>>{
           {"--frame", 0, 10000000}, {"--truth-value", 0, 255}, {"--k", 1, 100}, {"--grabcut-iterations", 1, 100},
           {"--min-cluster-points", 1, 10000000}, {"--window", -1, 100000}, {"--plane-window", -1, 100000},
           {"--planes", 1, 20}, {"--table-min-points", 3, 10000000}, {"--min-cluster-size", -1, 10000000}})
    check(name, options::in_range(lo, hi));
  for (const auto& [name, lo, hi] : std::initializer_list<std::tuple<const char*, double, double>>{
           {"--outlier-threshold", 0.000001, 1000}, {"--box-margin", 0, 1}, {"--max-distance", 0, 1e6},
           {"--plane-min-share", 0, 1}, {"--slab-share", 0.000001, 0.999999}, {"--table-min-width", 0, 1000},
           {"--table-min-share", 0, 1}, {"--table-prominence", 1, 1e6}, {"--table-max-tilt", 0, 90},
           {"--table-min-depression", 0, 1000}, {"--table-min-standing", 0, 1}, {"--height-band", -1, 1000},
           {"--max-tilt", 0, 90}, {"--support-radius", -1, 1000}, {"--cluster-tolerance", -1, 1000},
           {"--tolerance-share", 0.000001, 1000}, {"--min-cluster-share", 0, 1}, {"--edge-margin", 0, 1000},
           {"--min-rise", 0, 1000}})
    check(name, options::in_range(lo, hi));
}

void add_choices(CLI::App& app) {
  // Checked by the parser (exit status 2, as every option's bad value); the methods' own checks stay
  // for callers of the library.
  const std::initializer_list<std::pair<const char*, std::vector<std::string>>> choices = {
      {"--method", {"centroid-mincut", "mrf", "grabcut-sfm"}}, {"--solver", {"maxflow", "pcl"}},
      {"--up", {"x", "y", "z"}}, {"--saliency", {"colour", "fine-grained", "spectral-residual"}},
      {"--support", {"table", "plane"}}, {"--plane-up", {"auto", "camera", "world", "estimate"}},
      {"--cluster", {"auto", "kmeans", "euclidean"}}, {"--nearest", {"auto", "centre", "median", "depth"}},
      {"--truth-region", {"largest", "all"}}};
  for (const auto& [name, names] : choices)
    if (CLI::Option* option = app.get_option_no_throw(name)) option->check(CLI::IsMember(names));
}

int run_method(const CLI::App& app, SegmentCloudOptions& o) {
  const OutputLock one_writer(o.out, {o.input, o.sal.sequence, o.sal.work, o.gc.truth_mask});
  if (o.make_tabletop > 0) {
    o.tab.points = o.make_tabletop;
    const cloud::ColouredCloud c = cloud::make_tabletop_cloud(o.tab);
    begin_output_set(o.out);  // one file, no summary; this cleans up after killed runs
    cloud::write_labelled_cloud(o.out, c, c.labels);
    std::cout << "tabletop cloud: " << c.size() << " points, " << o.tab.objects << " objects -> " << o.out << "\n";
    return 0;
  }
  if (o.method == "mrf" && o.seeds == "saliency") {
    o.mrf.lambda = o.mrf_lambda;
    o.mrf.neighbours = 4;
    as_usage([&] { o.mrf.validate(); });
    o.sal.input = o.input;
    o.sal.out = o.out;
    return run_saliency_mrf(o.sal, o.mrf);
  }
  if (o.method == "grabcut-sfm") {
    if (app.count("--plane-distance")) o.gc.params.plane_distance = o.plane.plane_distance;
    o.gc.params.seed = o.tab.seed;
    o.gc.box_to_plane_given = app.count("--box-to-plane") > 0;
    o.gc.sequence = o.sal.sequence;
    o.gc.work = o.sal.work;
    o.gc.frame = o.sal.frame;
    o.gc.cloud = o.input;
    o.gc.out = o.out;
    return run_grabcut_sfm(o.gc);
  }
  if (o.input.empty()) throw Error("", "CLOUD", "an input cloud is required (or --make-tabletop N)");
  if (o.method == "mrf") {
    o.mrf.lambda = o.mrf_lambda;
    o.mrf.neighbours = 4;
    return run_mrf_on_cloud({o.input, o.out, o.seeds, o.mrf, o.plane});
  }
  if (o.method != "centroid-mincut") throw Error("", "--method", "\"" + o.method + "\" is not a method (centroid-mincut, mrf or grabcut-sfm)");
  return run_centroid_mincut({o.input, o.out, o.solver, o.up, o.truth_object, o.mc});
}

}  // namespace segment_cloud
