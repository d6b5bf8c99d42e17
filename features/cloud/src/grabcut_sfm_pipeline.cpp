// GrabCutSFM on one frame (paper 001), one function per step: the points in reach, the supporting plane
// (a table found relative to the scene, or 001's dominant plane), the clusters, the nearest one, its box,
// GrabCut. The building blocks are in grabcut_sfm.cpp, the table in grabcut_sfm_table.cpp.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <string>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "grabcut_sfm_detail.hpp"
#include "smseg/cloud/grabcut_sfm.hpp"
#include "smseg/common/error.hpp"

namespace smseg::cloud {

namespace {

using Clock = std::chrono::steady_clock;
using Cloud = std::vector<Eigen::Vector3f>;
using detail::median;
using detail::stage_seed;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr double kPaperPlaneDistance = 0.05;  // metres, the support Plane default
constexpr double kPaperClusterTolerance = 0.03;
constexpr int kPaperMinClusterSize = 10;
constexpr int kSpacingNeighbour = 4;  // the cloud's spacing: distance to the 4th nearest neighbour
constexpr double kHighPartGap = 1.5;  // tolerances: a cluster's higher parts this far apart are different objects

/// The frame: its pose, intrinsics and size, and what the steps read off them.
struct View {
  const sequence::Pose& pose;
  const PinholeIntrinsics& intrinsics;
  cv::Size size;
  Eigen::Vector3d camera;
  Eigen::Matrix3d R;  ///< camera-to-world rotation
  Eigen::Vector3d up;  ///< the supporting plane's up direction

  /// Projects p; true when it lies in front of the camera inside the frame.
  bool in_frame(const Eigen::Vector3f& p, cv::Point2f* px) const {
    cv::Point2f q;
    if (!project_point(p, pose, intrinsics, &q)) return false;
    if (px) *px = q;
    return q.x >= 0 && q.y >= 0 && q.x < float(size.width) && q.y < float(size.height);
  }
};

/// The camera's up axis in the world (camera y points down), world +Y for a work folder levelled by
/// gravity estimation, or the given up direction. Not world +Y of a level-first-camera work folder: that
/// world is tilted by the first camera's pitch (13.6 degrees on the tabletop sequence).
Eigen::Vector3d up_direction(const GrabCutSfmParams& p, const Eigen::Matrix3d& R) {
  if (p.up.squaredNorm() > 0) return p.up.normalized();
  return p.world_up ? Eigen::Vector3d::UnitY() : Eigen::Vector3d(-R.col(1));
}

/// Step 0 (not in 001): the points within max_distance and / or projecting into the frame.
Cloud within_reach(const Cloud& cloud, const View& view, const GrabCutSfmParams& p) {
  Cloud out;
  out.reserve(cloud.size());
  for (const auto& q : cloud) {
    if (p.max_distance > 0 && (q.cast<double>() - view.camera).norm() > p.max_distance) continue;
    if (!p.frustum_only || view.in_frame(q, nullptr)) out.push_back(q);
  }
  return out;
}

/// Of `points`, those whose foot on the plane lies within `radius` of a foot of `support` (PCL's
/// polygonal prism without the hull).
bool foot_near(const Eigen::Vector3d& p, const Eigen::Vector4d& plane, const Cloud& support, double radius) {
  const Eigen::Vector3d n = plane.head<3>();
  const Eigen::Vector3d foot = p - (n.dot(p) + plane[3]) * n;
  for (const auto& q : support) {
    const Eigen::Vector3d qd = q.cast<double>();
    if ((qd - (n.dot(qd) + plane[3]) * n - foot).squaredNorm() <= radius * radius) return true;
  }
  return false;
}

/// The normal of the dominant plane below the camera within 20 degrees of `up` (RANSAC, the slab a share
/// of the median distance), or `up` itself when no plane holds a tenth of those points.
Eigen::Vector3d dominant_up(const Cloud& cloud, const View& view, const GrabCutSfmParams& p) {
  Cloud below;
  std::vector<double> ranges;
  for (const auto& q : cloud)
    if (view.up.dot(q.cast<double>() - view.camera) < 0) {
      below.push_back(q);
      ranges.push_back((q.cast<double>() - view.camera).norm());
    }
  Eigen::Vector4d plane;
  const std::vector<char> in = ransac_plane(below, p.table.slab_share * median(ranges), p.plane_iterations,
                                            stage_seed(p.seed, 5), &plane, view.up, std::cos(20 * 3.14159265358979323846 / 180));
  if (double(std::count(in.begin(), in.end(), char(1))) < 0.1 * double(below.size())) return view.up;
  const Eigen::Vector3d n = plane.head<3>().normalized();
  return n.dot(view.up) < 0 ? Eigen::Vector3d(-n) : n;
}

/// Support Table: the table (find_table) and, of `rest`, the points standing on it below the band's top.
void keep_on_table(Cloud& rest, const View& view, const GrabCutSfmParams& p, GrabCutSfmReport& rep) {
  const Eigen::Vector3d up = p.refine_up ? dominant_up(rest, view, p) : view.up;
  TablePlane t = find_table(rest, view.camera, up, p.table);
  if (t.inliers == 0)
    throw Error("", "cloud", "no horizontal plane below the camera holds enough of the " + std::to_string(rest.size()) +
                                 " points for a table");
  if (p.plane_distance > 0) t.thickness = p.plane_distance;
  const double top = p.height_band > 0 ? p.height_band : t.camera_height;
  const double inset = p.table.edge_margin * t.thickness;
  Cloud slab, kept;
  for (const auto& q : rest)
    if (std::abs(t.height_of(q.cast<double>())) <= t.thickness) slab.push_back(q);
  for (const auto& q : rest) {
    const Eigen::Vector3d qd = q.cast<double>();
    const double h = t.height_of(qd);
    if (h <= t.thickness || h > top) continue;
    if (p.support_radius > 0 ? foot_near(qd, t.plane, slab, p.support_radius) : t.under(qd, inset)) kept.push_back(q);
  }
  rep.plane = t.plane;
  rep.planes = {t.plane};
  rep.planes_inliers = {int(slab.size())};
  rep.plane_inliers = int(slab.size());
  rep.support = 0;
  rep.plane_distance = t.thickness;
  rep.height_band = top;
  rep.table = std::move(t);
  rep.in_band = int(kept.size());
  rest.swap(kept);
}

/// Support Plane: RANSAC planes in turn (001: one); the first's inliers go to `support_points`. With a
/// plane cloud the first plane is fitted to it (scored by both clouds) and its inliers removed from `rest`.
void remove_planes(Cloud& rest, const Cloud* plane_cloud, const View& view, double min_cos, double distance,
                   const GrabCutSfmParams& p, GrabCutSfmReport& rep, Cloud& support_points) {
  const std::size_t considered = rest.size();
  const bool band = p.height_band > 0;
  for (int pi = 0; pi < p.planes; ++pi) {
    Eigen::Vector4d pl;
    const bool own_cloud = pi == 0 && plane_cloud;
    std::vector<char> on_plane =
        ransac_plane(own_cloud ? *plane_cloud : rest, distance, p.plane_iterations,
                     stage_seed(p.seed, pi == 0 ? 1 : 100 + std::uint64_t(pi)), &pl, view.up, pi == 0 ? min_cos : -1,
                     pi == 0 && p.world_up && band, own_cloud ? &rest : nullptr);
    if (own_cloud) {  // the plane found in its own cloud; its inliers are those of the segmented one
      on_plane.assign(rest.size(), 0);
      if (pl.head<3>().squaredNorm() > 0)
        for (std::size_t i = 0; i < rest.size(); ++i)
          on_plane[i] = std::abs(pl.head<3>().dot(rest[i].cast<double>()) + pl[3]) <= distance ? 1 : 0;
    }
    const int count = int(std::count(on_plane.begin(), on_plane.end(), char(1)));
    if (count < 3 || (pi > 0 && double(count) < p.plane_min_share * double(rest.size()))) break;
    if (pi == 0) rep.plane = pl;
    if (pl.head<3>().dot(view.camera) + pl[3] < 0) pl = -pl;  // normal towards the camera
    rep.planes.push_back(pl);
    rep.planes_inliers.push_back(count);
    Cloud kept;
    kept.reserve(rest.size() - std::size_t(count));
    for (std::size_t i = 0; i < rest.size(); ++i)
      if (!on_plane[i])
        kept.push_back(rest[i]);
      else if (pi == 0)
        support_points.push_back(rest[i]);
    rest.swap(kept);
  }
  rep.plane_inliers = int(considered - rest.size());
}

/// Support Plane with a height band: the first plane is the supporting one; keep the points in the band
/// above it (and standing on it, with support_radius).
void keep_band(Cloud& rest, const Cloud& support_points, const View& view, double min_cos, double distance,
               const GrabCutSfmParams& p, GrabCutSfmReport& rep) {
  if (rep.planes.empty() || rep.planes[0].head<3>().dot(view.up) < min_cos)
    throw Error("", "cloud",
                "no plane facing up within --max-tilt " + std::to_string(p.max_tilt) +
                    " degrees below the camera, so --height-band has no supporting plane");
  rep.support = 0;
  const Eigen::Vector4d& sp = rep.planes[0];
  Cloud kept;
  for (const auto& q : rest) {
    const Eigen::Vector3d qd = q.cast<double>();
    const double h = sp.head<3>().dot(qd) + sp[3];
    if (h > distance && h <= p.height_band && (p.support_radius <= 0 || foot_near(qd, sp, support_points, p.support_radius)))
      kept.push_back(q);
  }
  rest.swap(kept);
  rep.in_band = int(rest.size());
  rep.height_band = p.height_band;
}

/// Step 1, support Plane (001's plane removal, and the options beyond it).
void plane_step(Cloud& rest, const Cloud* plane_cloud, const View& view, const GrabCutSfmParams& p,
                GrabCutSfmReport& rep) {
  const double distance = p.plane_distance < 0 ? kPaperPlaneDistance : p.plane_distance;
  rep.plane_distance = distance;
  const bool band = p.height_band > 0;
  if (band && !(distance > 0))
    throw Error("", "--height-band", "needs plane removal (--plane-distance > 0): the band lies above a removed plane");
  if (band && !(p.height_band > distance))
    throw Error("", "--height-band", "must exceed --plane-distance (the band starts there)");
  if (!(distance > 0)) return;
  // The first plane's own cloud, within the same reach; a supporting plane lies below the camera.
  Cloud own;
  if (plane_cloud) {
    own = within_reach(*plane_cloud, view, p);
    if (p.world_up && band)
      own.erase(std::remove_if(own.begin(), own.end(), [&](const Eigen::Vector3f& q) { return q.y() >= view.camera.y(); }),
                own.end());
    if (own.size() < 3)
      throw Error("", "cloud", "the plane cloud has " + std::to_string(own.size()) + " points in reach (" +
                                   std::to_string(plane_cloud->size()) + " in all), too few for a plane");
  }
  const double min_cos = band ? std::cos(p.max_tilt * 3.14159265358979323846 / 180) : -1;
  Cloud support_points;
  remove_planes(rest, plane_cloud ? &own : nullptr, view, min_cos, distance, p, rep, support_points);
  if (band) keep_band(rest, support_points, view, min_cos, distance, p, rep);
}

/// Clusters of the kept points: labels (-1: dropped), their count and centres.
struct Clusters {
  std::vector<int> label;
  std::size_t count = 0;
  std::vector<float> centres;  ///< count x 3
};

/// Labels renumbered 0..m-1 in the order of each label's first point (-1 stays).
void number_by_first_point(std::vector<int>& label) {
  std::map<int, int> id;
  for (int& l : label)
    if (l >= 0) l = id.emplace(l, int(id.size())).first->second;
}

/// The parts of one Euclidean cluster (the points `members`) by height alone: its points at least `lift` above `plane`
/// (n . X + d, n up) clustered alone at kHighPartGap x `tolerance` (a single object's higher points, sparse,
/// fall apart at the tolerance itself: a box's top from its faces), the parts those of `min_size` or more
/// points; with two or more,
/// every other point of the cluster joins the part of its nearest part point within `tolerance`, or
/// none (-1). Per member its part; one part (all 0) when the higher points make fewer than two.
std::vector<int> high_parts(const Cloud& points, const std::vector<std::size_t>& members, const Eigen::Vector4d& plane,
                               double lift, double tolerance, int min_size) {
  Cloud high;
  std::vector<std::size_t> high_member;
  for (std::size_t m = 0; m < members.size(); ++m)
    if (plane.head<3>().dot(points[members[m]].cast<double>()) + plane[3] >= lift) {
      high.push_back(points[members[m]]);
      high_member.push_back(m);
    }
  const std::vector<int> high_part = euclidean_clusters(high, kHighPartGap * tolerance, min_size);
  if (high.empty() || *std::max_element(high_part.begin(), high_part.end()) < 1) return std::vector<int>(members.size(), 0);
  std::vector<int> part(members.size(), -1);
  Cloud anchors;
  std::vector<int> anchor_part;
  for (std::size_t h = 0; h < high.size(); ++h)
    if (high_part[h] >= 0) {
      part[high_member[h]] = high_part[h];
      anchors.push_back(high[h]);
      anchor_part.push_back(high_part[h]);
    }
  const detail::VoxelGrid grid(anchors, tolerance);
  for (std::size_t m = 0; m < members.size(); ++m) {
    if (part[m] >= 0) continue;
    const Eigen::Vector3f& q = points[members[m]];
    double best = std::numeric_limits<double>::infinity();
    grid.for_each_near(q, [&](std::size_t a) {
      const double d2 = (q - anchors[a]).squaredNorm();
      if (d2 < best) best = d2, part[m] = anchor_part[a];
    });
  }
  return part;
}

/// Euclidean clusters, each split where its points at least `lift` above `plane` fall apart into two or
/// more clusters of `min_size` (high_parts): the lower points, the table's stereo errors around the
/// objects, chain two neighbouring objects into one cluster, but do not join them. Labels as
/// euclidean_clusters.
std::vector<int> unchained_clusters(const Cloud& points, const Eigen::Vector4d& plane, double lift, double tolerance,
                                    int min_size) {
  const std::vector<int> whole = euclidean_clusters(points, tolerance, min_size);
  std::vector<std::vector<std::size_t>> members;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (whole[i] < 0) continue;
    if (std::size_t(whole[i]) >= members.size()) members.resize(std::size_t(whole[i]) + 1);
    members[std::size_t(whole[i])].push_back(i);
  }
  std::vector<int> label(points.size(), -1);
  int first = 0;  // parts of cluster k are first + 0, 1, ...
  for (const auto& m : members) {
    const std::vector<int> part = high_parts(points, m, plane, lift, tolerance, min_size);
    for (std::size_t j = 0; j < m.size(); ++j) label[m[j]] = part[j] < 0 ? -1 : first + part[j];
    first += *std::max_element(part.begin(), part.end()) + 1;
  }
  number_by_first_point(label);
  return label;
}

/// Step 2: Euclidean clusters at the cloud's own spacing (or the given tolerance), or 001's 3D k-means.
Clusters cluster_step(const Cloud& rest, const GrabCutSfmParams& p, GrabCutSfmReport& rep) {
  Clusters c;
  if (!p.euclidean) {
    std::vector<float> data(rest.size() * 3);
    for (std::size_t i = 0; i < rest.size(); ++i)
      for (int j = 0; j < 3; ++j) data[i * 3 + std::size_t(j)] = rest[i][j];
    c.label = kmeans(data, 3, p.k, p.attempts, p.kmeans_iterations, stage_seed(p.seed, 2), &c.centres);
    c.count = std::size_t(p.k);
    return c;
  }
  const bool relative = p.support == SupportChoice::Table;
  const double spacing = relative && p.cluster_tolerance < 0 ? cloud_spacing(rest, kSpacingNeighbour) : 0;
  rep.cluster_tolerance = p.cluster_tolerance > 0 ? p.cluster_tolerance
                          : relative && spacing > 0 ? p.tolerance_share * spacing
                                                    : kPaperClusterTolerance;
  rep.min_cluster_size = p.min_cluster_size > 0 ? p.min_cluster_size
                         : relative ? std::max(kPaperMinClusterSize, int(p.min_cluster_share * double(rest.size())))
                                    : kPaperMinClusterSize;
  c.label = relative && p.table.chain_rise > 0 && !rep.planes.empty()
                ? unchained_clusters(rest, rep.planes[0], p.table.chain_rise * rep.plane_distance, rep.cluster_tolerance,
                                     rep.min_cluster_size)
                : euclidean_clusters(rest, rep.cluster_tolerance, rep.min_cluster_size);
  for (int l : c.label) c.count = std::max(c.count, std::size_t(l + 1));
  if (c.count == 0)
    throw Error("", "cloud", "no Euclidean cluster of " + std::to_string(rep.min_cluster_size) + " or more points among the " +
                                 std::to_string(rest.size()) + " points left");
  c.centres.assign(c.count * 3, 0.f);
  std::vector<double> sum(c.count * 3, 0.0);
  std::vector<int> members(c.count, 0);
  for (std::size_t i = 0; i < rest.size(); ++i) {
    if (c.label[i] < 0) continue;
    const std::size_t k = std::size_t(c.label[i]);
    for (int j = 0; j < 3; ++j) sum[k * 3 + std::size_t(j)] += rest[i][j];
    ++members[k];
  }
  for (std::size_t k = 0; k < c.count; ++k)
    for (std::size_t j = 0; j < 3; ++j) c.centres[k * 3 + j] = float(sum[k * 3 + j] / members[k]);
  return c;
}

/// Support Table: per cluster, whether it rises above the table by min_rise slabs (an object does; a
/// strip of table-edge noise just above the slab does not). Every cluster rises otherwise.
std::vector<char> rising_clusters(const Cloud& rest, const Clusters& c, const GrabCutSfmParams& p,
                                  const GrabCutSfmReport& rep) {
  std::vector<char> rises(c.count, 1);
  if (p.support != SupportChoice::Table || rep.planes.empty()) return rises;
  std::vector<double> top(c.count, 0);
  for (std::size_t i = 0; i < rest.size(); ++i)
    if (c.label[i] >= 0)
      top[std::size_t(c.label[i])] =
          std::max(top[std::size_t(c.label[i])], rep.planes[0].head<3>().dot(rest[i].cast<double>()) + rep.planes[0][3]);
  for (std::size_t k = 0; k < c.count; ++k) rises[k] = top[k] >= p.table.min_rise * rep.plane_distance ? 1 : 0;
  return rises;
}

/// The clusters that may be chosen, nearest first, and per projection in the report its point in `rest`.
struct Candidates { std::vector<int> order; std::vector<std::size_t> projected_point; };

/// Step 3: every cluster's projections and distance; the candidates, those with enough projections,
/// nearest first (001: by its centre's distance; 001 takes the nearest).
Candidates nearest_step(const Cloud& rest, const Clusters& c, const View& view, const GrabCutSfmParams& p,
                        GrabCutSfmReport& rep) {
  rep.cluster_sizes.assign(c.count, 0);
  rep.cluster_in_frame.assign(c.count, 0);
  rep.cluster_distances.assign(c.count, 0);
  std::vector<std::vector<double>> point_distances(p.median_distance ? c.count : 0);
  Candidates out;
  for (std::size_t i = 0; i < rest.size(); ++i) {
    if (c.label[i] < 0) continue;
    const std::size_t k = std::size_t(c.label[i]);
    ++rep.cluster_sizes[k];
    const Eigen::Vector3d d = rest[i].cast<double>() - view.camera;
    if (p.median_distance) point_distances[k].push_back(p.median_depth ? d.dot(view.R.col(2)) : d.norm());
    cv::Point2f q;
    if (!view.in_frame(rest[i], &q)) continue;
    ++rep.cluster_in_frame[k];
    rep.projected.push_back(q);
    rep.projected_cluster.push_back(c.label[i]);
    out.projected_point.push_back(i);
  }
  const std::vector<char> rises = rising_clusters(rest, c, p, rep);
  for (std::size_t k = 0; k < c.count; ++k) {
    if (!rises[k]) continue;
    const Eigen::Vector3d centre(c.centres[k * 3], c.centres[k * 3 + 1], c.centres[k * 3 + 2]);
    rep.cluster_distances[k] = p.median_distance ? median(point_distances[k]) : (centre - view.camera).norm();
    if (rep.cluster_in_frame[k] >= p.min_cluster_points) out.order.push_back(int(k));
  }
  if (out.order.empty())
    throw Error("", "cloud",
                "no cluster has " + std::to_string(p.min_cluster_points) +
                    " or more points in front of the camera inside the frame (is the pose right?)");
  std::stable_sort(out.order.begin(), out.order.end(),
                   [&](int a, int b) { return rep.cluster_distances[std::size_t(a)] < rep.cluster_distances[std::size_t(b)]; });
  return out;
}

/// Cluster k chosen: its projections into the report; returns, per chosen projection, its point in `rest`.
std::vector<std::size_t> choose_cluster(const Candidates& cand, int k, GrabCutSfmReport& rep) {
  rep.chosen = k;
  rep.chosen_points.clear();
  std::vector<std::size_t> chosen_point;
  for (std::size_t i = 0; i < rep.projected.size(); ++i)
    if (rep.projected_cluster[i] == k) {
      rep.chosen_points.push_back(rep.projected[i]);
      chosen_point.push_back(cand.projected_point[i]);
    }
  return chosen_point;
}

/// Whether the chosen cluster's 2D inliers reach down to the supporting plane: with support Table, its
/// lowest point within min_rise slabs of the table (a car beside a road's patch, at another level, does
/// not stand on it, and its feet there would stretch the box far below it); always with support Plane.
bool stands_on_plane(const Cloud& rest, const std::vector<std::size_t>& chosen_point, const GrabCutSfmParams& p,
                     const GrabCutSfmReport& rep) {
  if (p.support != SupportChoice::Table) return true;
  double lowest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < chosen_point.size(); ++i)
    if (rep.chosen_inlier[i])
      lowest = std::min(lowest, rep.planes[0].head<3>().dot(rest[chosen_point[i]].cast<double>()) + rep.planes[0][3]);
  return lowest <= p.table.min_rise * rep.plane_distance;
}

/// Steps 4 and 5: 2D RANSAC, the inliers' box (with their feet on the supporting plane, box_to_plane),
/// grown by the margin and clipped to the image leaving a one-pixel frame.
void box_step(const Cloud& rest, const std::vector<std::size_t>& chosen_point, const View& view,
              const GrabCutSfmParams& p, GrabCutSfmReport& rep) {
  rep.chosen_inlier = compact_inliers_2d(rep.chosen_points, p.outlier_threshold, p.ransac_iterations, stage_seed(p.seed, 3));
  rep.inliers_2d = rep.feet_in_box = 0;
  float x0 = std::numeric_limits<float>::max(), y0 = x0, x1 = -x0, y1 = -x0;
  const auto grow = [&](const cv::Point2f& q) {
    x0 = std::min(x0, q.x), y0 = std::min(y0, q.y), x1 = std::max(x1, q.x), y1 = std::max(y1, q.y);
  };
  for (std::size_t i = 0; i < rep.chosen_points.size(); ++i)
    if (rep.chosen_inlier[i]) {
      ++rep.inliers_2d;
      grow(rep.chosen_points[i]);
    }
  if (rep.inliers_2d == 0) throw Error("", "cloud", "the 2D RANSAC kept no projection of the nearest cluster");
  if (p.box_to_plane && rep.support == 0 && stands_on_plane(rest, chosen_point, p, rep)) {
    // The object stands on the supporting plane, but its lower part lies in the plane's slab or has no
    // tracked point: the box reaches down to where the kept points' feet on the plane project.
    const Eigen::Vector3d n = rep.planes[0].head<3>();
    for (std::size_t i = 0; i < rep.chosen_points.size(); ++i) {
      if (!rep.chosen_inlier[i]) continue;
      const Eigen::Vector3d q = rest[chosen_point[i]].cast<double>();
      cv::Point2f px;
      if (!view.in_frame((q - (n.dot(q) + rep.planes[0][3]) * n).cast<float>(), &px)) continue;
      ++rep.feet_in_box;
      grow(px);
    }
  }
  const cv::Rect frame(0, 0, view.size.width, view.size.height);
  const int ix0 = int(std::floor(x0)), iy0 = int(std::floor(y0));
  rep.inlier_box = cv::Rect(ix0, iy0, int(std::ceil(x1)) + 1 - ix0, int(std::ceil(y1)) + 1 - iy0) & frame;
  const double mx = p.box_margin * rep.inlier_box.width, my = p.box_margin * rep.inlier_box.height;
  const int bx0 = std::max(1, int(std::floor(rep.inlier_box.x - mx)));
  const int by0 = std::max(1, int(std::floor(rep.inlier_box.y - my)));
  const int bx1 = std::min(view.size.width - 1, int(std::ceil(rep.inlier_box.br().x + mx)));
  const int by1 = std::min(view.size.height - 1, int(std::ceil(rep.inlier_box.br().y + my)));
  rep.box = cv::Rect(bx0, by0, std::max(0, bx1 - bx0), std::max(0, by1 - by0));
}

/// The pixel a projection inside the frame falls in (pixel centres at whole coordinates; one within half a
/// pixel of the right or bottom edge rounds to the last column or row).
cv::Point pixel_of(const cv::Point2f& p, cv::Size size) {
  return {std::min(cvRound(p.x), size.width - 1), std::min(cvRound(p.y), size.height - 1)};
}

/// Whether GrabCut's foreground `mask` holds more than `min_share` of the chosen cluster's 2D inliers: a
/// cluster of stereo errors (a plain wall given a nearer surface's depth) has no object under it, and
/// GrabCut, finding nothing in its box unlike the pixels around it, keeps none of its pixels.
bool image_supports(const cv::Mat& mask, const GrabCutSfmReport& rep, double min_share) {
  if (min_share < 0) return true;
  int kept = 0;
  for (std::size_t i = 0; i < rep.chosen_points.size(); ++i)
    if (rep.chosen_inlier[i] && mask.at<std::uint8_t>(pixel_of(rep.chosen_points[i], mask.size())) != 0) ++kept;
  return kept > min_share * rep.inliers_2d;
}

/// GrabCut's foreground left with the nearest object only: the chosen cluster's projections inside it are
/// clustered again at the tolerance (the stereo errors on the plain wall between two objects, which
/// chained them, lie outside it); when they fall into two or more clusters of the smallest cluster's
/// size, the mask's regions (8-connected) holding the farther ones' points and none of the nearest's
/// (by the median of their depths) are dropped. Returns how many.
int keep_nearest_region(cv::Mat& mask, const Cloud& rest, const std::vector<std::size_t>& chosen_point, const View& view,
                        const GrabCutSfmReport& rep) {
  cv::Mat regions;
  const int count = cv::connectedComponents(mask, regions, 8, CV_32S);
  Cloud inside;
  std::vector<int> region;
  for (std::size_t i = 0; i < rep.chosen_points.size(); ++i)
    if (const int r = regions.at<int>(pixel_of(rep.chosen_points[i], mask.size())); r > 0)
      inside.push_back(rest[chosen_point[i]]), region.push_back(r);
  const std::vector<int> part = euclidean_clusters(inside, rep.cluster_tolerance, rep.min_cluster_size);
  const int parts = inside.empty() ? 0 : *std::max_element(part.begin(), part.end()) + 1;
  if (parts < 2) return 0;
  std::vector<std::vector<double>> depth(static_cast<std::size_t>(parts));
  for (std::size_t i = 0; i < inside.size(); ++i)
    if (part[i] >= 0) depth[std::size_t(part[i])].push_back((inside[i].cast<double>() - view.camera).dot(view.R.col(2)));
  int nearest = 0;
  for (int q = 1; q < parts; ++q)
    if (median(depth[std::size_t(q)]) < median(depth[std::size_t(nearest)])) nearest = q;
  std::vector<int> holds(std::size_t(count), 0);  // bit 1: the nearest part's points, bit 2: another's
  for (std::size_t i = 0; i < inside.size(); ++i)
    if (part[i] >= 0) holds[std::size_t(region[i])] |= part[i] == nearest ? 1 : 2;
  int dropped = 0;
  for (int r = 1; r < count; ++r)
    if (holds[std::size_t(r)] == 2) mask.setTo(0, regions == r), ++dropped;
  return dropped;
}

/// GrabCut's foreground without the pixels whose cloud depth (the nearest point projecting within a pixel)
/// lies beyond (1 + `share`) x the 90th percentile of the chosen points' depths: a farther object or the wall
/// seen inside the box around the object. Returns how many.
int drop_farther_pixels(cv::Mat& mask, const Cloud& points, const Cloud& rest, const std::vector<std::size_t>& chosen_point,
                        const View& view, double share) {
  std::vector<double> depth;
  for (std::size_t i : chosen_point) depth.push_back((rest[i].cast<double>() - view.camera).dot(view.R.col(2)));
  const auto p90 = depth.begin() + std::ptrdiff_t(depth.size() * 9 / 10);
  std::nth_element(depth.begin(), p90, depth.end());
  cv::Mat nearest(mask.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::max()));
  for (const auto& q : points) {
    cv::Point2f px;
    if (!view.in_frame(q, &px)) continue;
    float& z = nearest.at<float>(pixel_of(px, mask.size()));
    z = std::min(z, float((q.cast<double>() - view.camera).dot(view.R.col(2))));
  }
  cv::erode(nearest, nearest, cv::Mat());  // the nearest within a pixel
  const cv::Mat farther = mask & (nearest > (1 + share) * *p90) & (nearest < std::numeric_limits<float>::max());
  mask.setTo(0, farther);
  return cv::countNonZero(farther);
}

/// The supporting plane step of either kind, timed; an error when too few points are left for k-means.
void support_step(Cloud& rest, const Cloud* plane_cloud, const View& view, const GrabCutSfmParams& p,
                  GrabCutSfmReport& rep) {
  const auto t0 = Clock::now();
  if (p.support == SupportChoice::Table)
    keep_on_table(rest, view, p, rep);
  else
    plane_step(rest, plane_cloud, view, p, rep);
  rep.seconds_plane = seconds_since(t0);
  if (!p.euclidean && int(rest.size()) < p.k)
    throw Error("", "cloud",
                std::to_string(rest.size()) + " points are left " + (p.frustum_only ? "in the frame " : "") +
                    (p.max_distance > 0 ? "within --max-distance " : "") + "after plane removal" +
                    (rep.support == 0 ? " and the height band" : "") + " (of " + std::to_string(rep.points) +
                    "), fewer than k = " + std::to_string(p.k) + " clusters");
}

}  // namespace

void GrabCutSfmParams::validate() const {
  table.validate();
  if (!std::isfinite(plane_distance) || (plane_distance < 0 && plane_distance != -1))
    throw Error("", "--plane-distance", "must be >= 0 metres (0: no plane removal), or -1: from the scene");
  if (support == SupportChoice::Table && plane_distance == 0)
    throw Error("", "--plane-distance", "must be > 0 with --support table (the table's slab)");
  if (plane_iterations < 1) throw Error("", "--plane-iterations", "must be >= 1");
  if (k < 1 || k > 100) throw Error("", "--k", "must be 1..100");
  if (attempts < 1) throw Error("", "--attempts", "must be >= 1");
  if (kmeans_iterations < 1) throw Error("", "--kmeans-iterations", "must be >= 1");
  if (min_cluster_points < 1) throw Error("", "--min-cluster-points", "must be >= 1");
  if (!(outlier_threshold > 0) || !std::isfinite(outlier_threshold))
    throw Error("", "--outlier-threshold", "must be > 0 (robust standard deviations)");
  if (ransac_iterations < 1) throw Error("", "--ransac-iterations", "must be >= 1");
  if (!(box_margin >= 0 && box_margin <= 1)) throw Error("", "--box-margin", "must be in [0, 1]");
  if (!(max_distance >= 0) || !std::isfinite(max_distance))
    throw Error("", "--max-distance", "must be >= 0 metres (0: no limit)");
  if (grabcut_iterations < 1 || grabcut_iterations > 100) throw Error("", "--grabcut-iterations", "must be 1..100");
  if (planes < 1 || planes > 20) throw Error("", "--planes", "must be 1..20");
  if (!(plane_min_share >= 0 && plane_min_share <= 1)) throw Error("", "--plane-min-share", "must be in [0, 1]");
  if (!std::isfinite(height_band) || (height_band < 0 && height_band != -1))
    throw Error("", "--height-band", "must be >= 0 metres (0: no band), or -1: from the scene");
  if (!std::isfinite(support_radius) || (support_radius < 0 && support_radius != -1))
    throw Error("", "--support-radius", "must be >= 0 metres (0: any point in the band), or -1: from the scene");
  if (!(max_tilt >= 0 && max_tilt <= 90)) throw Error("", "--max-tilt", "must be 0..90 degrees");
  if (!std::isfinite(cluster_tolerance) || cluster_tolerance == 0 || (cluster_tolerance < 0 && cluster_tolerance != -1))
    throw Error("", "--cluster-tolerance", "must be > 0 metres, or -1: from the cloud's spacing");
  if (!(tolerance_share > 0) || !std::isfinite(tolerance_share)) throw Error("", "--tolerance-share", "must be > 0");
  if (min_cluster_size == 0 || min_cluster_size < -1)
    throw Error("", "--min-cluster-size", "must be >= 1, or -1: from the cloud's size");
  if (!(min_cluster_share >= 0 && min_cluster_share <= 1)) throw Error("", "--min-cluster-share", "must be in [0, 1]");
  if (!std::isfinite(up.x()) || !std::isfinite(up.y()) || !std::isfinite(up.z()))
    throw Error("", "up", "the up direction must be finite");
}

GrabCutSfmParams GrabCutSfmParams::paper() {
  GrabCutSfmParams p;
  p.support = SupportChoice::Plane;
  p.euclidean = false;
  p.box_to_plane = false;
  return p;
}

cv::Mat grabcut_sfm(const Cloud& points, const PinholeIntrinsics& intrinsics, const sequence::Pose& pose, const cv::Mat& image,
                    const GrabCutSfmParams& params, GrabCutSfmReport* report_out, const Cloud* plane_cloud) {
  params.validate();
  intrinsics.validate();
  if (points.empty()) throw Error("", "cloud", "the cloud is empty");
  if (image.empty() || image.type() != CV_8UC3) throw Error("", "image", "GrabCutSFM needs an 8-bit colour image");
  const auto t_start = Clock::now();
  const Eigen::Matrix3d R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(pose.R.data());
  const View view{pose, intrinsics, image.size(), Eigen::Vector3d(pose.t[0], pose.t[1], pose.t[2]), R,
                  up_direction(params, R)};
  GrabCutSfmReport rep;
  rep.points = int(points.size());
  Cloud rest = within_reach(points, view, params);
  rep.considered = int(rest.size());
  support_step(rest, plane_cloud, view, params, rep);
  auto t0 = Clock::now();
  const Clusters clusters = cluster_step(rest, params, rep);
  rep.seconds_kmeans = seconds_since(t0);
  t0 = Clock::now();
  const Candidates cand = nearest_step(rest, clusters, view, params, rep);
  rep.chosen = cand.order[0];
  // The nearest candidate, or (image support) the nearest whose GrabCut keeps its projections.
  rep.seconds_projection = seconds_since(t0);
  cv::Mat mask;
  GrabCutSfmReport nearest;
  for (std::size_t c = 0; c < cand.order.size(); ++c) {
    t0 = Clock::now();
    const std::vector<std::size_t> chosen_point = choose_cluster(cand, cand.order[c], rep);
    box_step(rest, chosen_point, view, params, rep);
    rep.seconds_projection += seconds_since(t0);
    t0 = Clock::now();
    cv::Mat m = grabcut_box(image, rep.box, params.grabcut_iterations, stage_seed(params.seed, 4));
    rep.seconds_grabcut += seconds_since(t0);
    if (c == 0) mask = m, nearest = rep;
    if (image_supports(m, rep, params.support == SupportChoice::Table ? params.table.min_image_support : -1)) {
      if (params.support == SupportChoice::Table && params.table.nearest_region)
        rep.regions_dropped = keep_nearest_region(m, rest, chosen_point, view, rep);
      if (params.support == SupportChoice::Table && params.table.mask_depth_share > 0)
        rep.farther_pixels = drop_farther_pixels(m, points, rest, chosen_point, view, params.table.mask_depth_share);
      mask = m;
      break;
    }
    rep.unsupported.push_back(rep.chosen);
    if (c + 1 == cand.order.size()) {  // none is supported: the nearest, as without the rule
      nearest.unsupported = rep.unsupported;
      nearest.seconds_projection = rep.seconds_projection, nearest.seconds_grabcut = rep.seconds_grabcut;
      rep = std::move(nearest);
    }
  }
  rep.seconds_total = seconds_since(t_start);
  if (report_out) *report_out = std::move(rep);
  return mask;
}

}  // namespace smseg::cloud
