// The point-cloud segmenters' options, each declared once (smseg/cloud/cloud_options.hpp).
#include "smseg/cloud/cloud_options.hpp"

#include <cstdint>
#include <limits>

namespace smseg::cloud {

using options::kFile;
using options::Table;

const Table<CentroidMinCutParams>& centroid_mincut_params_table() {
  static const Table<CentroidMinCutParams> table = [] {
    Table<CentroidMinCutParams> t("centroid-mincut", kSegmentCloudSurfaces);
    option_fields::number_without_default(
        t, "radius", "--radius", "centroid-mincut: R, points within R of the centroid seed the object (required)",
        [](auto& p) -> auto& { return p.radius; }, 0.000001, 1e6);
    t.number("neighbours", "--neighbours", "centroid-mincut: k of the k-nearest-neighbour graph (mrf uses 000's 4)",
             [](auto& p) -> auto& { return p.neighbours; }, 1, 100);
    t.number("sigma", "--sigma", "smoothness scale (0: mean distance of the points to their k nearest neighbours)",
             [](auto& p) -> auto& { return p.sigma; }, 0.0, 1e6);
    t.number("lambda", "--lambda", "centroid-mincut (maxflow): weight of the smoothness term",
             [](auto& p) -> auto& { return p.lambda; }, 0.0, 1e6);
    t.number("source_weight", "--source-weight", "centroid-mincut (pcl): PCL's foreground weight",
             [](auto& p) -> auto& { return p.source_weight; }, 0.000001, 1e6);
    return t;
  }();
  return table;
}

const Table<MrfParams>& mrf_params_table() {
  static const Table<MrfParams> table = [] {
    Table<MrfParams> t("mrf", kSegmentCloudSurfaces);
    t.number("neighbours", "", "mrf: k of the k-nearest-neighbour graph (000's 4)",
             [](auto& p) -> auto& { return p.neighbours; }, 1, 100)
        .only(kFile);
    t.number("components", "--components", "mrf: Gaussians per colour model", [](auto& p) -> auto& { return p.components; },
             1, 20);
    t.number("lambda", "--mrf-lambda", "mrf: weight of the pairwise term", [](auto& p) -> auto& { return p.lambda; }, 0.0,
             1e6);
    t.number("iterations", "--iterations", "mrf: at most this many GMM re-estimation rounds",
             [](auto& p) -> auto& { return p.max_iterations; }, 1, 1000);
    t.number("tolerance", "", "mrf: stop when the energy changes by less than this fraction",
             [](auto& p) -> auto& { return p.tolerance; }, 0.0, 1.0)
        .only(kFile);
    return t;
  }();
  return table;
}

const Table<PlaneSeedParams>& plane_seed_params_table() {
  static const Table<PlaneSeedParams> table = [] {
    Table<PlaneSeedParams> t("mrf plane seeds", kSegmentCloudSurfaces);
    t.number("plane_distance", "--plane-distance",
             "RANSAC plane inlier distance, metres: mrf plane seeds (default shown); grabcut-sfm, the supporting "
             "plane's slab (default: --support table: --slab-share x the table's distance; plane: 0.05, 0: no "
             "plane removal)",
             [](auto& p) -> auto& { return p.plane_distance; }, -1.0, 1000.0);
    t.number("colour_tolerance", "--colour-tolerance", "mrf plane seeds: RGB distance within one cluster",
             [](auto& p) -> auto& { return p.colour_tolerance; }, 0.000001, 1000.0);
    t.number("min_cluster", "--min-cluster", "mrf plane seeds: smallest cluster that seeds an object",
             [](auto& p) -> auto& { return p.min_cluster; }, 1, 10000000);
    return t;
  }();
  return table;
}

const Table<SaliencyParams>& saliency_params_table() {
  static const Table<SaliencyParams> table = [] {
    Table<SaliencyParams> t("mrf saliency seeds", kSegmentCloudSurfaces);
    option_fields::one_of(t, "saliency", "--saliency",
                          "mrf saliency seeds: colour (fine-grained saliency of intensity, R-G, B-Y), fine-grained or "
                          "spectral-residual",
                          [](auto& p) -> auto& { return p.method; }, {"colour", "fine-grained", "spectral-residual"});
    t.number("saliency_threshold", "--saliency-threshold",
             "mrf saliency seeds: threshold on the 0..1 saliency map (0: Otsu)",
             [](auto& p) -> auto& { return p.threshold; }, 0.0, 0.999999);
    t.number("background", "--background", "mrf saliency seeds: background seeds where saliency < this x the threshold",
             [](auto& p) -> auto& { return p.background; }, 0.000001, 1.0);
    t.number("min_area", "--min-area", "mrf saliency seeds: smallest salient region, share of the image",
             [](auto& p) -> auto& { return p.min_area; }, 0.000001, 0.999999);
    t.number("saliency_scale", "--saliency-scale", "mrf saliency seeds: image scale at which the saliency is computed",
             [](auto& p) -> auto& { return p.scale; }, 0.05, 1.0);
    t.number("max_area", "--max-area",
             "mrf saliency seeds: a larger salient component (share of the image) is a structure, split at "
             "higher thresholds; its rest seeds the background",
             [](auto& p) -> auto& { return p.max_area; }, 0.000001, 1.0);
    t.number("saliency_step", "--saliency-step", "mrf saliency seeds: threshold step of those splits",
             [](auto& p) -> auto& { return p.step; }, 0.005, 0.999999);
    t.number("saliency_blur", "--saliency-blur", "mrf saliency seeds: box-filter radius on the map (pixels)",
             [](auto& p) -> auto& { return p.blur; }, 0, 50);
    return t;
  }();
  return table;
}

const Table<ProjectionParams>& projection_params_table() {
  static const Table<ProjectionParams> table = [] {
    Table<ProjectionParams> t("mrf saliency seeds", kSegmentCloudSurfaces);
    t.number("splat_radius", "--splat-radius",
             "mrf saliency seeds: radius of a point's disc in the z-buffer and OUT.png (pixels)",
             [](auto& p) -> auto& { return p.splat_radius; }, 0, 20);
    t.number("depth_tolerance", "",
             "mrf saliency seeds: a point is visible within max(this, 2% of its depth) behind the z-buffer (metres)",
             [](auto& p) -> auto& { return p.depth_tolerance; }, 0.0, 1000.0)
        .only(kFile);
    return t;
  }();
  return table;
}

namespace {

/// find_table()'s thresholds as a share of the scene: slab, minimum share, width, standing, depression.
void declare_table_shares(Table<TableParams>& t) {
  t.number("slab_share", "--slab-share",
           "grabcut-sfm, --support table: a point lies on a plane within this share of its distance from the camera",
           [](auto& p) -> auto& { return p.slab_share; }, 0.000001, 0.999999);
  t.number("min_width_share", "--table-min-width",
           "grabcut-sfm, --support table: a table is at least this x the camera's height above it wide",
           [](auto& p) -> auto& { return p.min_width_share; }, 0.0, 1000.0);
  t.number("min_share", "--table-min-share",
           "grabcut-sfm, --support table: a candidate plane holds at least this share of the points below the camera "
           "beyond the mean count three slabs above and below it (walls)",
           [](auto& p) -> auto& { return p.min_share; }, 0.0, 1.0);
  t.number("min_points", "--table-min-points", "grabcut-sfm, --support table: ... and at least this many points",
           [](auto& p) -> auto& { return p.min_points; }, 3, 10000000);
  t.number("min_prominence", "--table-prominence",
           "grabcut-sfm, --support table: ... and this x the mean count three slabs above and below it",
           [](auto& p) -> auto& { return p.min_prominence; }, 1.0, 1e6);
  t.number("max_refit_tilt", "--table-max-tilt",
           "grabcut-sfm, --support table: degrees; the table's least-squares plane is kept within this of up",
           [](auto& p) -> auto& { return p.max_refit_tilt; }, 0.0, 90.0);
  t.number("min_depression", "--table-min-depression",
           "grabcut-sfm, --support table: the camera's height above a table at least this x its distance",
           [](auto& p) -> auto& { return p.min_depression; }, 0.0, 1000.0);
  t.number("min_standing_share", "--table-min-standing",
           "grabcut-sfm, --support table: points standing on a table, share of its own points at least",
           [](auto& p) -> auto& { return p.min_standing_share; }, 0.0, 1.0);
}

}  // namespace

const Table<TableParams>& table_params_table() {
  static const Table<TableParams> table = [] {
    Table<TableParams> t("grabcut-sfm table", kSegmentCloudSurfaces);
    declare_table_shares(t);
    t.number("edge_margin", "--edge-margin",
             "grabcut-sfm, --support table: slabs; the points kept stand this far inside the table's outline",
             [](auto& p) -> auto& { return p.edge_margin; }, 0.0, 1000.0);
    t.number("min_rise", "--min-rise",
             "grabcut-sfm, --support table: a cluster is an object when it reaches this many slabs above the table",
             [](auto& p) -> auto& { return p.min_rise; }, 0.0, 1000.0);
    t.number("chain_rise", "--chain-rise",
             "grabcut-sfm, --support table: slabs; a cluster whose points this high above the table fall apart into "
             "two or more clusters (1.5 x the cluster tolerance apart, each of --min-cluster-size) is split into "
             "those, its lower points joining the nearest within the tolerance (stereo errors on the table chain "
             "neighbouring objects; 0: no split)",
             [](auto& p) -> auto& { return p.chain_rise; }, 0.0, 1000.0);
    t.flag("join_through_feet", "--table-join-feet",
           "grabcut-sfm, --support table: a candidate plane whose largest patch is no table is tried again with the "
           "feet of the points above it joining its pieces (a table seen from low, cut up by the objects on it; "
           "--table-join-feet=false: off)",
           [](auto& p) -> auto& { return p.join_through_feet; });
    t.number("min_image_support", "--min-image-support",
             "grabcut-sfm, --support table: the nearest cluster is taken when GrabCut's foreground holds more than "
             "this share of its 2D inliers, else the next nearest is tried (the nearest when none is; a sheet of "
             "stereo errors over a plain wall has no object under it; -1: the nearest, 001)",
             [](auto& p) -> auto& { return p.min_image_support; }, -1.0, 0.999999);
    t.flag("nearest_region", "--nearest-region",
           "grabcut-sfm, --support table: when the chosen cluster's points inside GrabCut's foreground fall apart "
           "into two or more clusters (of --min-cluster-size, at the cluster tolerance), the mask keeps only the "
           "regions of the nearest one (two objects chained by stereo errors on the wall between them, which "
           "GrabCut leaves out; --nearest-region=false: off)",
           [](auto& p) -> auto& { return p.nearest_region; });
    t.number("mask_depth_share", "--mask-depth-share",
             "grabcut-sfm, --support table: GrabCut's foreground loses the pixels whose cloud depth lies beyond (1 + "
             "this) x the 90th percentile of the chosen points' depths (a farther object or the wall; 0: none). "
             "segment-cloud: 0 unless given when the cloud is not the frame's own dense depth (tracks hold points "
             "hidden behind the object)",
             [](auto& p) -> auto& { return p.mask_depth_share; }, 0.0, 1000.0);
    return t;
  }();
  return table;
}

namespace {

/// What the summaries record but the command line does not set: fixed iteration counts, the slab as
/// resolved with --plane-distance, the seed (segment-cloud's --seed), find_table()'s rules.
void declare_recorded_only(Table<GrabCutSfmParams>& t) {
  t.number("plane_distance", "", "the supporting plane's slab, metres (-1: from the scene; --plane-distance)",
           [](auto& p) -> auto& { return p.plane_distance; }, -1.0, 1000.0)
      .only(kFile);
  t.number("plane_iterations", "", "RANSAC hypotheses for the plane", [](auto& p) -> auto& { return p.plane_iterations; },
           1, 100000000)
      .only(kFile);
  t.number("attempts", "", "k-means runs", [](auto& p) -> auto& { return p.attempts; }, 1, 1000000).only(kFile);
  t.number("kmeans_iterations", "", "Lloyd iterations per k-means run at most",
           [](auto& p) -> auto& { return p.kmeans_iterations; }, 1, 100000000)
      .only(kFile);
  t.number("ransac_iterations", "", "2D RANSAC hypotheses", [](auto& p) -> auto& { return p.ransac_iterations; }, 1,
           100000000)
      .only(kFile);
  t.number("seed", "", "seed of the random draws (--seed)", [](auto& p) -> auto& { return p.seed; }, std::uint64_t{0},
           std::numeric_limits<std::uint64_t>::max())
      .only(kFile);
  options::Field<GrabCutSfmParams> table;
  table.key = table.config_key = table.python_key = "table";
  table.help = "find_table()'s rules (--slab-share, --table-*, --edge-margin, --min-rise)";
  table.type = "object";
  table.surfaces = kFile;
  table.write = [](const GrabCutSfmParams& p) { return table_params_table().to_json(p.table); };
  table.read = [](GrabCutSfmParams& p, const JsonView& v) { table_params_table().read(p.table, v, kFile); };
  t.custom(std::move(table));
}

/// 001's steps: k-means, the 2D RANSAC, the box, GrabCut; the reach of the cloud.
void declare_paper_steps(Table<GrabCutSfmParams>& t) {
  t.number("k", "--k", "grabcut-sfm: 3D k-means clusters", [](auto& p) -> auto& { return p.k; }, 1, 100);
  t.number("outlier_threshold", "--outlier-threshold",
           "grabcut-sfm: 2D RANSAC inlier ellipse, robust standard deviations per axis",
           [](auto& p) -> auto& { return p.outlier_threshold; }, 0.000001, 1000.0);
  t.number("box_margin", "--box-margin", "grabcut-sfm: share of the box's size added on each side",
           [](auto& p) -> auto& { return p.box_margin; }, 0.0, 1.0);
  t.number("grabcut_iterations", "--grabcut-iterations", "grabcut-sfm: cv::grabCut iterations",
           [](auto& p) -> auto& { return p.grabcut_iterations; }, 1, 100);
  t.number("min_cluster_points", "--min-cluster-points",
           "grabcut-sfm: projections in the frame a cluster needs to be chosen",
           [](auto& p) -> auto& { return p.min_cluster_points; }, 1, 10000000);
  t.number("max_distance", "--max-distance",
           "grabcut-sfm: cluster only the points within this many metres of the camera (0: all; 001 uses all)",
           [](auto& p) -> auto& { return p.max_distance; }, 0.0, 1e6);
  t.flag("frustum_only", "--frustum-only",
         "grabcut-sfm: cluster only the points projecting into the frame (001 clusters the whole cloud)",
         [](auto& p) -> auto& { return p.frustum_only; });
  t.number("planes", "--planes", "grabcut-sfm: remove up to this many RANSAC planes in turn (001: 1)",
           [](auto& p) -> auto& { return p.planes; }, 1, 20);
  t.number("plane_min_share", "--plane-min-share",
           "grabcut-sfm: a second or later plane is removed only if it holds this share of the points left",
           [](auto& p) -> auto& { return p.plane_min_share; }, 0.0, 1.0);
}

/// The supporting plane's band and feet (every default relative to the scene with --support table).
void declare_support(Table<GrabCutSfmParams>& t) {
  t.number("height_band", "--height-band",
           "grabcut-sfm: metres; > 0 keeps only the points between the slab and this height above the "
           "supporting plane (--support plane: the first plane, its RANSAC hypotheses restricted to normals within "
           "--max-tilt of the up direction; 0: no band, 001). Default -1: table: the camera's height above it; "
           "plane: no band",
           [](auto& p) -> auto& { return p.height_band; }, -1.0, 1000.0);
  t.number("max_tilt", "--max-tilt",
           "grabcut-sfm, --support plane --height-band: degrees between the supporting plane's normal and the up "
           "direction (--plane-up) at most",
           [](auto& p) -> auto& { return p.max_tilt; }, 0.0, 90.0);
  t.flag("box_to_plane", "--box-to-plane",
         "grabcut-sfm: the box reaches down to the projections of the chosen points' feet on the supporting "
         "plane (an object's lower part is in the plane's slab or untracked); default: on with --support table "
         "for a cluster whose lowest point lies within --min-rise slabs of the table (--box-to-plane=false: "
         "off), off with --support plane",
         [](auto& p) -> auto& { return p.box_to_plane; });
  t.number("support_radius", "--support-radius",
           "grabcut-sfm: metres; > 0 keeps only the points standing on the supporting plane (their foot on the "
           "plane within this of a plane inlier's foot). Default -1: table: their foot inside the table's hull; "
           "plane: the whole band",
           [](auto& p) -> auto& { return p.support_radius; }, -1.0, 1000.0);
}

/// Euclidean clustering's scale and smallest cluster.
void declare_clusters(Table<GrabCutSfmParams>& t) {
  t.number("cluster_tolerance", "--cluster-tolerance",
           "grabcut-sfm, euclidean: metres between neighbours of one cluster (default -1: table: --tolerance-share x "
           "the kept points' median distance to their 4th neighbour; plane: 0.03)",
           [](auto& p) -> auto& { return p.cluster_tolerance; }, -1.0, 1000.0);
  t.number("tolerance_share", "--tolerance-share", "grabcut-sfm: see --cluster-tolerance",
           [](auto& p) -> auto& { return p.tolerance_share; }, 0.000001, 1000.0);
  t.number("min_cluster_size", "--min-cluster-size",
           "grabcut-sfm, euclidean: smaller clusters are dropped (default -1: table: --min-cluster-share of the "
           "kept points, at least 10; plane: 10)",
           [](auto& p) -> auto& { return p.min_cluster_size; }, -1, 10000000);
  t.number("min_cluster_share", "--min-cluster-share", "grabcut-sfm: see --min-cluster-size",
           [](auto& p) -> auto& { return p.min_cluster_share; }, 0.0, 1.0);
}

}  // namespace

const Table<GrabCutSfmParams>& grabcut_sfm_params_table() {
  static const Table<GrabCutSfmParams> table = [] {
    Table<GrabCutSfmParams> t("grabcut-sfm", kSegmentCloudSurfaces);
    declare_paper_steps(t);
    declare_support(t);
    declare_clusters(t);
    declare_recorded_only(t);
    return t;
  }();
  return table;
}

}  // namespace smseg::cloud
