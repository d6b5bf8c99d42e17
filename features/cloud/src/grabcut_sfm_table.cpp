// GrabCutSFM's scene-relative defaults (not in 001): the supporting plane chosen as a table is, and the
// clustering scale read off the cloud's own spacing, so that no distance is given in metres.
#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "knn_graph.hpp"
#include "smseg/cloud/grabcut_sfm.hpp"
#include "smseg/common/error.hpp"

namespace smseg::cloud {

namespace {

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// Two unit vectors spanning the plane normal to `up`.
void plane_basis(const Eigen::Vector3d& up, Eigen::Vector3d* e1, Eigen::Vector3d* e2) {
  const Eigen::Vector3d helper = std::abs(up.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitZ();
  *e1 = up.cross(helper).normalized();
  *e2 = up.cross(*e1).normalized();
}

/// The cloud below the camera, as heights along `up` and distances from the camera.
struct HeightProfile {
  std::vector<std::size_t> index;  ///< point in the cloud
  std::vector<double> height, range;
};

HeightProfile below_camera(const std::vector<Eigen::Vector3f>& cloud, const Eigen::Vector3d& camera,
                           const Eigen::Vector3d& up) {
  HeightProfile hp;
  const double camera_height = up.dot(camera);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d p = cloud[i].cast<double>();
    const double h = up.dot(p);
    if (!(h < camera_height)) continue;
    hp.index.push_back(i);
    hp.height.push_back(h);
    hp.range.push_back((p - camera).norm());
  }
  return hp;
}

/// The cloud's angular spacing seen from the camera: the median angle (radians) from a point below the
/// camera to its 4th nearest neighbour in direction (a dense depth's pixel step, a sparse cloud's wider).
double angular_spacing_of(const std::vector<Eigen::Vector3f>& cloud, const HeightProfile& hp,
                          const Eigen::Vector3d& camera) {
  std::vector<Eigen::Vector3f> directions;
  directions.reserve(hp.index.size());
  for (std::size_t i = 0; i < hp.index.size(); ++i)
    directions.push_back(((cloud[hp.index[i]].cast<double>() - camera) / hp.range[i]).cast<float>());
  return cloud_spacing(directions, 4);
}

/// Heights at which many points lie within their own slab (a share of their distance from the camera):
/// local maxima of that count over a scan of heights, strongest first, each at least two slabs from a
/// stronger one.
std::vector<std::pair<double, int>> height_peaks(const HeightProfile& hp, double slab_share, int min_count,
                                                 double min_prominence) {
  std::vector<std::pair<double, int>> peaks;
  if (hp.height.empty()) return peaks;
  const double lo = *std::min_element(hp.height.begin(), hp.height.end());
  const double hi = *std::max_element(hp.height.begin(), hp.height.end());
  const double step = std::max(1e-4, 0.5 * slab_share * median_of(hp.range));
  const int bins = std::min(20000, int((hi - lo) / step) + 1);
  std::vector<int> count(std::size_t(bins), 0);
  for (std::size_t i = 0; i < hp.height.size(); ++i) {
    const double slab = slab_share * hp.range[i];
    const int b0 = std::max(0, int(std::ceil((hp.height[i] - slab - lo) / step)));
    const int b1 = std::min(bins - 1, int(std::floor((hp.height[i] + slab - lo) / step)));
    for (int b = b0; b <= b1; ++b) ++count[std::size_t(b)];
  }
  for (int b = 0; b < bins; ++b) {
    const int c = count[std::size_t(b)];
    if (c < min_count) continue;
    if ((b > 0 && count[std::size_t(b - 1)] > c) || (b + 1 < bins && count[std::size_t(b + 1)] >= c)) continue;
    // A plane stands out of what lies three slabs above and below it (a wall adds the same count at
    // every height): its own points, the count less that background, hold min_count, and the count is
    // min_prominence x the background. Not the ratio alone: a table seen far off, below walls that
    // fill most of the frame, is half its slab's count.
    const int reach = 6;  // bins: three slabs of the median point
    const auto count_at = [&](int i) { return i < 0 || i >= bins ? 0 : count[std::size_t(i)]; };
    const double around = 0.5 * (count_at(b - reach) + count_at(b + reach));
    if (c < min_prominence * around || c - around < min_count) continue;
    peaks.emplace_back(lo + b * step, c);
  }
  std::sort(peaks.begin(), peaks.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  std::vector<std::pair<double, int>> kept;
  for (const auto& p : peaks) {
    const bool near_stronger = std::any_of(kept.begin(), kept.end(), [&](const auto& k) {
      return std::abs(k.first - p.first) < 4 * step;  // two slabs of the median point
    });
    if (!near_stronger) kept.push_back(p);
  }
  return kept;
}

/// The points of `hp` within their slab of `height`: their indices into hp.
std::vector<std::size_t> inliers_of(const HeightProfile& hp, double height, double slab_share) {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < hp.height.size(); ++i)
    if (std::abs(hp.height[i] - height) <= slab_share * hp.range[i]) out.push_back(i);
  return out;
}

/// The plane through the patch (inliers[patch[j]] of hp) by least squares, its normal kept within
/// max_tilt degrees of `up` (an up direction estimated from the camera path is a degree or so off,
/// which across a table is more than its slab); else normal to `up` through the patch's median height.
Eigen::Vector4d refit_plane(const std::vector<Eigen::Vector3f>& cloud, const HeightProfile& hp,
                            const std::vector<std::size_t>& inliers, const std::vector<std::size_t>& patch,
                            const Eigen::Vector3d& up, double max_tilt) {
  std::vector<double> heights;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t j : patch) {
    heights.push_back(hp.height[inliers[j]]);
    mean += cloud[hp.index[inliers[j]]].cast<double>();
  }
  const Eigen::Vector4d level(up.x(), up.y(), up.z(), -median_of(heights));
  if (patch.size() < 3) return level;
  mean /= double(patch.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t j : patch) {
    const Eigen::Vector3d d = cloud[hp.index[inliers[j]]].cast<double>() - mean;
    cov += d * d.transpose();
  }
  Eigen::Vector3d n = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(0).normalized();
  if (n.dot(up) < 0) n = -n;
  if (n.dot(up) < std::cos(max_tilt * 3.14159265358979323846 / 180)) return level;
  return Eigen::Vector4d(n.x(), n.y(), n.z(), -n.dot(mean));
}

/// The largest 8-connected patch of `feet` on a grid of `cell`, counting only the first `counted` feet
/// (a plane's own points; the others, feet of points standing above it, only join its cells): the
/// indices of its counted feet.
std::vector<std::size_t> largest_patch(const std::vector<cv::Point2f>& feet, std::size_t counted, double cell) {
  if (counted == 0) return {};
  float x0 = feet[0].x, y0 = feet[0].y, x1 = x0, y1 = y0;
  for (const auto& f : feet) {
    x0 = std::min(x0, f.x), y0 = std::min(y0, f.y), x1 = std::max(x1, f.x), y1 = std::max(y1, f.y);
  }
  const int w = std::min(4000, int((x1 - x0) / cell) + 1), h = std::min(4000, int((y1 - y0) / cell) + 1);
  cv::Mat occupied(h, w, CV_8UC1, cv::Scalar(0));
  const auto cell_of = [&](const cv::Point2f& f) {
    return cv::Point(std::min(w - 1, int((f.x - x0) / cell)), std::min(h - 1, int((f.y - y0) / cell)));
  };
  for (const auto& f : feet) occupied.at<std::uint8_t>(cell_of(f)) = 255;
  cv::Mat labels;
  const int n = cv::connectedComponents(occupied, labels, 8, CV_32S);
  std::vector<int> points_in(std::size_t(n), 0);
  for (std::size_t i = 0; i < counted; ++i) ++points_in[std::size_t(labels.at<int>(cell_of(feet[i])))];
  int best = 1;
  for (int c = 2; c < n; ++c)
    if (points_in[std::size_t(c)] > points_in[std::size_t(best)]) best = c;
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < counted; ++i)
    if (labels.at<int>(cell_of(feet[i])) == best) out.push_back(i);
  return out;
}

/// The smaller of the patch's two principal widths (4 standard deviations: a uniform strip's width is
/// 3.5 of them).
double patch_width(const std::vector<cv::Point2f>& pts) {
  if (pts.size() < 3) return 0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : pts) mean += Eigen::Vector2d(p.x, p.y);
  mean /= double(pts.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const auto& p : pts) {
    const Eigen::Vector2d d = Eigen::Vector2d(p.x, p.y) - mean;
    cov += d * d.transpose();
  }
  cov /= double(pts.size());
  return 4 * std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvalues()(0)));
}

}  // namespace

bool TablePlane::under(const Eigen::Vector3d& p, double inset) const {
  if (hull.size() < 3) return false;
  const cv::Point2f foot(float(e1.dot(p)), float(e2.dot(p)));
  return cv::pointPolygonTest(hull, foot, inset > 0) >= inset;
}

double TablePlane::height_of(const Eigen::Vector3d& p) const { return plane.head<3>().dot(p) + plane[3]; }

void TableParams::validate() const {
  if (!(slab_share > 0 && slab_share < 1)) throw Error("", "--slab-share", "must be in (0, 1)");
  if (!(min_width_share >= 0)) throw Error("", "--table-min-width", "must be >= 0");
  if (!(min_standing_share >= 0 && min_standing_share <= 1)) throw Error("", "--table-min-standing", "must be in [0, 1]");
  if (min_points < 3) throw Error("", "--table-min-points", "must be >= 3");
  if (!(max_refit_tilt >= 0 && max_refit_tilt <= 90)) throw Error("", "--table-max-tilt", "must be 0..90 degrees");
  if (!(edge_margin >= 0)) throw Error("", "--edge-margin", "must be >= 0");
  if (!(min_rise >= 0)) throw Error("", "--min-rise", "must be >= 0");
  if (!(mask_depth_share >= 0)) throw Error("", "--mask-depth-share", "must be >= 0 (0: off)");
  if (!(min_image_support >= -1 && min_image_support < 1)) throw Error("", "--min-image-support", "must be in [-1, 1)");
  if (!(chain_rise >= 0)) throw Error("", "--chain-rise", "must be >= 0");
  if (!(min_depression >= 0)) throw Error("", "--table-min-depression", "must be >= 0");
  if (!(min_prominence >= 1)) throw Error("", "--table-prominence", "must be >= 1");
}

namespace {

/// What find_table() examines once per candidate height.
struct TableScan {
  const std::vector<Eigen::Vector3f>& cloud;
  const HeightProfile& hp;
  const Eigen::Vector3d& camera;
  const Eigen::Vector3d& up;
  const TableParams& params;
  double angular_spacing;
  Eigen::Vector3d e1, e2;
};

/// The candidate plane at `height`: its largest patch, plane, hull, width, the points standing on it,
/// and whether it is a table. With `join_through_feet` the feet of the points above the slab join the
/// patch's cells (not its points or hull).
TablePlane table_candidate(const TableScan& s, double height, bool join_through_feet) {
  TablePlane t;
  t.e1 = s.e1;
  t.e2 = s.e2;
  const std::vector<std::size_t> inliers = inliers_of(s.hp, height, s.params.slab_share);
  std::vector<double> inlier_ranges;
  std::vector<cv::Point2f> feet;
  const auto add_foot = [&](std::size_t i) {
    const Eigen::Vector3d p = s.cloud[s.hp.index[i]].cast<double>();
    feet.emplace_back(float(t.e1.dot(p)), float(t.e2.dot(p)));
  };
  for (std::size_t i : inliers) {
    add_foot(i);
    inlier_ranges.push_back(s.hp.range[i]);
  }
  const double range = median_of(inlier_ranges);
  t.thickness = s.params.slab_share * range;
  const std::size_t own_feet = feet.size();
  for (std::size_t i = 0; join_through_feet && i < s.hp.height.size(); ++i)
    if (s.hp.height[i] - height > s.params.slab_share * s.hp.range[i]) add_foot(i);
  // A plane seen at a grazing angle is sampled coarsely along the line of sight: one angular step of
  // the cloud covers range x range / (the camera's height above it) of the plane, more than two slabs
  // when the camera is low; the patch's cells span two such steps, or a table top falls apart in strips.
  const double footprint = s.angular_spacing * range * range / std::max(s.up.dot(s.camera) - height, t.thickness);
  const std::vector<std::size_t> patch = largest_patch(feet, own_feet, 2 * std::max(t.thickness, footprint));
  std::vector<cv::Point2f> patch_feet;
  for (std::size_t j : patch) patch_feet.push_back(feet[j]);
  t.plane = refit_plane(s.cloud, s.hp, inliers, patch, s.up, s.params.max_refit_tilt);
  t.inliers = int(patch.size());
  t.width = patch_width(patch_feet);
  cv::convexHull(patch_feet, t.hull);
  t.camera_height = t.height_of(s.camera);
  for (std::size_t i = 0; i < s.hp.height.size(); ++i) {
    const Eigen::Vector3d p = s.cloud[s.hp.index[i]].cast<double>();
    if (t.height_of(p) > t.thickness && t.under(p)) ++t.standing;
  }
  // The camera looks down at a table: its height above the plane is a share of the patch's distance
  // (a wall's slice just below the camera's height, metres away, is seen nearly level).
  t.found = t.camera_height >= s.params.min_depression * range && t.width >= s.params.min_width_share * t.camera_height &&
            t.standing >= std::max(s.params.min_points, int(s.params.min_standing_share * t.inliers));
  return t;
}

}  // namespace

TablePlane find_table(const std::vector<Eigen::Vector3f>& cloud, const Eigen::Vector3d& camera,
                      const Eigen::Vector3d& up_in, const TableParams& params) {
  params.validate();
  const Eigen::Vector3d up = up_in.normalized();
  const HeightProfile hp = below_camera(cloud, camera, up);
  TableScan scan{cloud, hp, camera, up, params, angular_spacing_of(cloud, hp, camera), {}, {}};
  plane_basis(up, &scan.e1, &scan.e2);
  const int min_count = std::max(params.min_points, int(params.min_share * double(hp.height.size())));
  std::vector<std::pair<double, int>> peaks = height_peaks(hp, params.slab_share, min_count, params.min_prominence);
  // Highest first: a table stands above the floor; an object's top, higher still, has nothing on it.
  std::sort(peaks.begin(), peaks.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  TablePlane fallback;  // the candidate with most points, when none is a table
  fallback.e1 = scan.e1;
  fallback.e2 = scan.e2;
  for (const auto& peak : peaks) {
    TablePlane t = table_candidate(scan, peak.first, false);
    // Objects on a table seen from low hide the table behind them and cut its top into pieces (the
    // near strip, the parts beside and beyond them), none a table alone: the objects join them.
    if (!t.found && params.join_through_feet) {
      TablePlane joined = table_candidate(scan, peak.first, true);
      if (joined.found) t = std::move(joined);
    }
    t.candidates = int(peaks.size());
    if (t.found) return t;
    if (t.inliers > fallback.inliers) fallback = t;
  }
  fallback.candidates = int(peaks.size());
  fallback.found = false;
  return fallback;
}

double cloud_spacing(const std::vector<Eigen::Vector3f>& points, int k) {
  if (points.size() < std::size_t(k) + 1) return 0;
  ColouredCloud c;
  c.points = points;
  const KnnGraph g = knn_graph(c, k);
  std::vector<double> kth(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) kth[i] = g.distances[i * std::size_t(k) + std::size_t(k - 1)];
  return median_of(kth);
}

}  // namespace smseg::cloud
