// segment-cloud: graph-cut segmentation of a point cloud (the systems of ../shared/papers 000 and 003),
// and synthetic tabletop clouds to try them on. This file is the command line; each method runs in its
// own part (segment_cloud/*.cpp).
#include <iostream>
#include <memory>


#include "smseg/common/cli.hpp"
#include "segment_cloud/runs.hpp"

int main(int argc, char** argv) {
  using namespace smseg;
  using namespace segment_cloud;
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
  app.add_option("-o,--out", out, "output cloud (.pcd or .ply; grabcut-sfm: the mask, .png); the summary goes to the same name + .json, "
                 "written last (the old one is removed first: a summary is only beside the files of its own run)")->required();
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
  app.add_option("--make-tabletop", make_tabletop, "write a synthetic tabletop cloud of this many points (1..10000000) instead")
      ->check(CLI::Range(1, 10000000));
  app.add_option("--objects", tab.objects, "--make-tabletop: objects on the table (1..8)")->capture_default_str();
  app.add_option("--seed", tab.seed, "seed of --make-tabletop and of grabcut-sfm's random draws")->capture_default_str()
      ->check(smseg::kDecimalDigits);
  add_threads_option(app, threads);
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
  app.add_option("--dense-cloud", gc.dense_cloud,
                 "grabcut-sfm, stereo sequences: cluster the frame's own dense depth (eight-path SGBM, as extract-features "
                 "--dense), one point every this many pixels, instead of the tracked cloud")
      ->check(CLI::Range(1, 64));
  app.add_option("--window", gc.window,
                 "grabcut-sfm: cluster the tracks of WORK/tracks.json seen within this many frames of --frame "
                 "(one point per track, its mean world position there) instead of the whole cloud (-1; 001 uses "
                 "one reconstruction)")->capture_default_str();
  app.add_option("--plane-window", gc.plane_window,
                 "grabcut-sfm: fit the first (supporting) plane to the tracks seen within this many frames of --frame "
                 "(as --window) and remove its inliers from the clustered cloud, e.g. with --dense-cloud, whose "
                 "depth sees more floor than table top from above a table (-1: the clustered cloud's own plane)")
      ->capture_default_str();
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
                 "grabcut-sfm, --height-band: degrees between the supporting plane's normal and the up direction (--plane-up) at most")
      ->capture_default_str();
  app.add_option("--plane-up", gc.up,
                 "grabcut-sfm, --height-band: the up direction the supporting plane faces: camera (the frame's up "
                 "axis) | world (world +Y: for work folders made with extract-features --gravity estimate)")
      ->capture_default_str();
  app.add_flag("--box-to-plane", gc.params.box_to_plane,
               "grabcut-sfm, --height-band: the box reaches down to the projections of the chosen points' feet on the "
               "supporting plane (an object's lower part is in the plane's slab or untracked)");
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
  return run_tool(app, argc, argv, threads, [&] {
    if (make_tabletop > 0) {
      tab.points = make_tabletop;
      const features::ColouredCloud c = features::make_tabletop_cloud(tab);
      begin_output_set(out);  // one file, no summary; this cleans up after killed runs
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
      if (gc.up != "camera" && gc.up != "world")
        throw UsageError("", "--plane-up", "is \"" + gc.up + "\", expected camera or world");
      gc.params.world_up = gc.up == "world";
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
      return run_mrf_on_cloud({input, out, seeds, mrf, plane});
    }
    if (method != "centroid-mincut") throw Error("", "--method", "\"" + method + "\" is not a method (centroid-mincut, mrf or grabcut-sfm)");
    return run_centroid_mincut({input, out, solver, up, truth_object, mc});
  });
}
