// GrabCutSFM (paper 001) and its baselines: plane RANSAC, k-means, 2D RANSAC, OpenCV GrabCut.
// Plain Eigen / OpenCV (our own seeded RANSAC and k-means so that a seed fixes every draw); it lives
// with the other cloud segmenters in smseg_cloud.
#include "smseg/cloud/grabcut_sfm.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "grabcut_sfm_detail.hpp"
#include "smseg/common/error.hpp"
#include "smseg/frontend/trajectory.hpp"

namespace smseg::cloud {

namespace {

using detail::median;
using detail::stage_seed;

/// Uniform integer in [0, n) from the generator (its own arithmetic: std::uniform_int_distribution's
/// draws differ between standard libraries).
std::size_t draw(std::mt19937_64& rng, std::size_t n) { return static_cast<std::size_t>(rng() % n); }

double draw_unit(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1.0p-53; }

const cv::Scalar kPalette[] = {{40, 40, 230},  {60, 180, 60},  {230, 120, 30}, {30, 200, 230},
                               {200, 60, 200}, {230, 220, 40}, {120, 120, 255}, {20, 120, 160}};

}  // namespace

void PinholeIntrinsics::validate() const {
  if (!(std::isfinite(fx) && fx > 0 && std::isfinite(fy) && fy > 0))
    throw Error("", "intrinsics", "the focal length must be positive (fx " + std::to_string(fx) + ", fy " +
                                      std::to_string(fy) + ")");
  if (!std::isfinite(cx) || !std::isfinite(cy)) throw Error("", "intrinsics", "the principal point must be finite");
}

bool project_point(const Eigen::Vector3f& world, const sequence::Pose& pose, const PinholeIntrinsics& k, cv::Point2f* pixel,
                   double* depth) {
  const Eigen::Matrix3d R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(pose.R.data());
  const Eigen::Vector3d c(pose.t[0], pose.t[1], pose.t[2]);
  const Eigen::Vector3d x = R.transpose() * (world.cast<double>() - c);
  if (depth) *depth = x.z();
  if (!(x.z() > 1e-6)) return false;
  if (pixel) *pixel = cv::Point2f(float(k.fx * x.x() / x.z() + k.cx), float(k.fy * x.y() / x.z() + k.cy));
  return true;
}

namespace {

/// Of hypotheses scored in two clouds (plane, inliers in the first, inliers in the second), the plane
/// both hold: the highest lesser share of either cloud's best count (a plane that is the best of one
/// cloud and nearly empty in the other loses to one that is good in both).
Eigen::Vector4d plane_both_hold(const std::vector<std::array<double, 6>>& scored, int* count) {
  double max_own = 0, max_agree = 0;
  for (const auto& h : scored) {
    max_own = std::max(max_own, h[4]);
    max_agree = std::max(max_agree, h[5]);
  }
  double best_score = -1;
  Eigen::Vector4d best(0, 0, 0, 0);
  for (const auto& h : scored) {
    const double score = std::min(h[4] / std::max(max_own, 1.0), h[5] / std::max(max_agree, 1.0));
    if (score > best_score) {
      best_score = score;
      best = Eigen::Vector4d(h[0], h[1], h[2], h[3]);
      *count = int(h[4]);
    }
  }
  return best;
}

/// Least-squares refit to the plane's inliers: the normal is the covariance's smallest eigenvector;
/// `mean` the inliers' mean.
Eigen::Vector3d least_squares_normal(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector4d& plane,
                                     double distance, Eigen::Vector3d* mean) {
  *mean = Eigen::Vector3d::Zero();
  int m = 0;
  for (const auto& p : points)
    if (std::abs(plane.head<3>().dot(p.cast<double>()) + plane[3]) <= distance) {
      *mean += p.cast<double>();
      ++m;
    }
  *mean /= m;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points)
    if (std::abs(plane.head<3>().dot(p.cast<double>()) + plane[3]) <= distance) {
      const Eigen::Vector3d d = p.cast<double>() - *mean;
      cov += d * d.transpose();
    }
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(0).normalized();
}

}  // namespace

std::vector<char> ransac_plane(const std::vector<Eigen::Vector3f>& points, double distance, int iterations,
                               std::uint64_t seed, Eigen::Vector4d* plane_out, const Eigen::Vector3d& up,
                               double min_cos, bool up_is_known, const std::vector<Eigen::Vector3f>* agree) {
  const std::size_t n = points.size();
  std::vector<char> inlier(n, 0);
  if (plane_out) plane_out->setZero();
  if (n < 3) return inlier;
  std::mt19937_64 rng(seed);
  const auto count_in = [&](const std::vector<Eigen::Vector3f>& cloud, const Eigen::Vector4d& pl) {
    int c = 0;
    for (const auto& p : cloud)
      if (std::abs(pl.head<3>().dot(p.cast<double>()) + pl[3]) <= distance) ++c;
    return c;
  };
  const auto count = [&](const Eigen::Vector4d& pl) { return count_in(points, pl); };
  Eigen::Vector4d best(0, 0, 0, 0);
  int best_count = -1;
  // With `agree`: every hypothesis is kept and the one both clouds support best wins (below).
  std::vector<std::array<double, 6>> scored;  // plane, inliers in points, inliers in agree
  for (int it = 0; it < iterations; ++it) {
    if (up_is_known) {
      const Eigen::Vector3d pa = points[draw(rng, n)].cast<double>();
      const Eigen::Vector4d pl(up.x(), up.y(), up.z(), -up.dot(pa));
      const int cnt = count(pl);
      if (agree) scored.push_back({pl[0], pl[1], pl[2], pl[3], double(cnt), double(count_in(*agree, pl))});
      if (cnt > best_count) {
        best_count = cnt;
        best = pl;
      }
      continue;
    }
    const std::size_t a = draw(rng, n), b = draw(rng, n), c = draw(rng, n);
    if (a == b || b == c || a == c) continue;
    const Eigen::Vector3d pa = points[a].cast<double>(), pb = points[b].cast<double>(), pc = points[c].cast<double>();
    Eigen::Vector3d nrm = (pb - pa).cross(pc - pa);
    const double len = nrm.norm();
    if (!(len > 1e-12)) continue;
    nrm /= len;
    if (std::abs(nrm.dot(up)) < min_cos) continue;  // not facing `up` closely enough
    const Eigen::Vector4d pl(nrm.x(), nrm.y(), nrm.z(), -nrm.dot(pa));
    const int cnt = count(pl);
    if (agree) scored.push_back({pl[0], pl[1], pl[2], pl[3], double(cnt), double(count_in(*agree, pl))});
    if (cnt > best_count) {
      best_count = cnt;
      best = pl;
    }
  }
  if (agree && !scored.empty()) best = plane_both_hold(scored, &best_count);
  if (best_count < 3) return inlier;
  Eigen::Vector3d mean;
  Eigen::Vector3d nrm = least_squares_normal(points, best, distance, &mean);
  if (up_is_known && nrm.dot(up) < 0) nrm = -nrm;
  const Eigen::Vector4d refit(nrm.x(), nrm.y(), nrm.z(), -nrm.dot(mean));
  const bool refit_faces_up = !up_is_known || nrm.dot(up) >= min_cos;
  const Eigen::Vector4d& pl = refit_faces_up && count(refit) >= best_count ? refit : best;
  for (std::size_t i = 0; i < n; ++i)
    inlier[i] = std::abs(pl.head<3>().dot(points[i].cast<double>()) + pl[3]) <= distance ? 1 : 0;
  if (plane_out) *plane_out = pl;
  return inlier;
}

namespace {

/// Rows of `dim` floats and what k-means does with them.
struct KmeansData {
  const std::vector<float>& data;
  std::size_t n, d, k;
  double dist2(std::size_t i, const float* c) const {
    double s = 0;
    for (std::size_t j = 0; j < d; ++j) {
      const double v = double(data[i * d + j]) - double(c[j]);
      s += v * v;
    }
    return s;
  }
};

/// k-means++ seeding: the first centre a random row, each next one a row drawn with probability
/// proportional to its squared distance from the nearest centre so far.
void kmeanspp_seeds(const KmeansData& x, std::mt19937_64& rng, std::vector<float>& centres, std::vector<double>& nearest) {
  const std::size_t first = draw(rng, x.n), d = x.d;
  std::copy_n(&x.data[first * d], d, &centres[0]);
  for (std::size_t i = 0; i < x.n; ++i) nearest[i] = x.dist2(i, &centres[0]);
  for (std::size_t c = 1; c < x.k; ++c) {
    double total = 0;
    for (double v : nearest) total += v;
    std::size_t pick = 0;
    if (total > 0) {
      double r = draw_unit(rng) * total;
      pick = x.n - 1;
      for (std::size_t i = 0; i < x.n; ++i) {
        r -= nearest[i];
        if (r < 0) {
          pick = i;
          break;
        }
      }
    } else {
      pick = draw(rng, x.n);
    }
    std::copy_n(&x.data[pick * d], d, &centres[c * d]);
    for (std::size_t i = 0; i < x.n; ++i) nearest[i] = std::min(nearest[i], x.dist2(i, &centres[c * d]));
  }
}

/// Each row to its nearest centre; `nearest` its squared distance. Returns whether a label changed and
/// adds the squared distances to `cost`.
bool assign_rows(const KmeansData& x, const std::vector<float>& centres, std::vector<int>& labels,
                 std::vector<double>& nearest, double& cost) {
  bool changed = false;
  for (std::size_t i = 0; i < x.n; ++i) {
    int bl = 0;
    double bd = std::numeric_limits<double>::infinity();
    for (std::size_t c = 0; c < x.k; ++c) {
      const double v = x.dist2(i, &centres[c * x.d]);
      if (v < bd) {
        bd = v;
        bl = int(c);
      }
    }
    nearest[i] = bd;
    cost += bd;
    if (labels[i] != bl) {
      labels[i] = bl;
      changed = true;
    }
  }
  return changed;
}

/// Each centre to the mean of its rows; an empty cluster takes the row farthest from its centre.
void update_centres(const KmeansData& x, const std::vector<int>& labels, std::vector<float>& centres,
                    std::vector<double>& nearest) {
  const std::size_t d = x.d;
  std::vector<double> sum(x.k * d, 0.0);
  std::vector<std::size_t> cnt(x.k, 0);
  for (std::size_t i = 0; i < x.n; ++i) {
    const std::size_t c = std::size_t(labels[i]);
    ++cnt[c];
    for (std::size_t j = 0; j < d; ++j) sum[c * d + j] += x.data[i * d + j];
  }
  for (std::size_t c = 0; c < x.k; ++c) {
    if (cnt[c] == 0) {
      const std::size_t far = std::size_t(std::max_element(nearest.begin(), nearest.end()) - nearest.begin());
      std::copy_n(&x.data[far * d], d, &centres[c * d]);
      nearest[far] = 0;
      continue;
    }
    for (std::size_t j = 0; j < d; ++j) centres[c * d + j] = float(sum[c * d + j] / double(cnt[c]));
  }
}

/// Clusters numbered by their first row (so the labelling does not depend on the seeding order).
std::vector<int> canonical_labels(const KmeansData& x, const std::vector<int>& labels, const std::vector<float>& centres,
                                  std::vector<float>* centres_out) {
  std::vector<int> order(x.k, -1);
  int next = 0;
  for (std::size_t i = 0; i < x.n; ++i)
    if (order[std::size_t(labels[i])] < 0) order[std::size_t(labels[i])] = next++;
  for (auto& o : order)
    if (o < 0) o = next++;
  std::vector<int> out(x.n);
  for (std::size_t i = 0; i < x.n; ++i) out[i] = order[std::size_t(labels[i])];
  if (centres_out) {
    centres_out->assign(x.k * x.d, 0.f);
    for (std::size_t c = 0; c < x.k; ++c)
      std::copy_n(&centres[c * x.d], x.d, &(*centres_out)[std::size_t(order[c]) * x.d]);
  }
  return out;
}

}  // namespace

std::vector<int> kmeans(const std::vector<float>& data, int dim, int k, int attempts, int max_iterations,
                        std::uint64_t seed, std::vector<float>* centres_out) {
  if (dim < 1 || data.size() % std::size_t(dim) != 0) throw Error("", "kmeans", "data size is not a multiple of dim");
  const std::size_t n = data.size() / std::size_t(dim);
  if (k < 1) throw Error("", "k", "must be >= 1");
  if (n < std::size_t(k))
    throw Error("", "k", std::to_string(n) + " points cannot make " + std::to_string(k) + " clusters");
  const KmeansData x{data, n, std::size_t(dim), std::size_t(k)};
  std::mt19937_64 rng(seed);
  std::vector<int> best_labels, labels(n);
  std::vector<float> best_centres, centres(x.k * x.d);
  std::vector<double> nearest(n);
  double best_cost = std::numeric_limits<double>::infinity();
  for (int attempt = 0; attempt < attempts; ++attempt) {
    kmeanspp_seeds(x, rng, centres, nearest);
    std::fill(labels.begin(), labels.end(), -1);
    double cost = 0;
    for (int it = 0; it < max_iterations; ++it) {  // Lloyd iterations
      cost = 0;
      if (!assign_rows(x, centres, labels, nearest, cost)) break;
      update_centres(x, labels, centres, nearest);
    }
    if (cost < best_cost) {
      best_cost = cost;
      best_labels = labels;
      best_centres = centres;
    }
  }
  return canonical_labels(x, best_labels, best_centres, centres_out);
}

std::vector<int> euclidean_clusters(const std::vector<Eigen::Vector3f>& points, double tolerance, int min_size) {
  const std::size_t n = points.size();
  std::vector<int> parent(n);
  for (std::size_t i = 0; i < n; ++i) parent[i] = int(i);
  const auto find = [&](int a) {
    while (parent[std::size_t(a)] != a) {
      parent[std::size_t(a)] = parent[std::size_t(parent[std::size_t(a)])];
      a = parent[std::size_t(a)];
    }
    return a;
  };
  const detail::VoxelGrid grid(points, tolerance);
  for (std::size_t i = 0; i < n; ++i)
    grid.for_each_near(points[i], [&](std::size_t j) {
      if (j <= i) return;
      const int a = find(int(i)), b = find(int(j));
      if (a != b) parent[std::size_t(std::max(a, b))] = std::min(a, b);
    });
  std::vector<int> size(n, 0);
  for (std::size_t i = 0; i < n; ++i) ++size[std::size_t(find(int(i)))];
  std::vector<int> label(n, -1), id(n, -1);
  int next = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const int r = find(int(i));
    if (size[std::size_t(r)] < min_size) continue;
    if (id[std::size_t(r)] < 0) id[std::size_t(r)] = next++;
    label[i] = id[std::size_t(r)];
  }
  return label;
}

std::vector<char> compact_inliers_2d(const std::vector<cv::Point2f>& points, double threshold, int iterations,
                                     std::uint64_t seed) {
  const std::size_t n = points.size();
  std::vector<char> inlier(n, 1);
  if (n < 3) return inlier;
  std::vector<double> xs(n), ys(n);
  for (std::size_t i = 0; i < n; ++i) {
    xs[i] = points[i].x;
    ys[i] = points[i].y;
  }
  const double mx = median(xs), my = median(ys);
  std::vector<double> ax(n), ay(n);
  for (std::size_t i = 0; i < n; ++i) {
    ax[i] = std::abs(xs[i] - mx);
    ay[i] = std::abs(ys[i] - my);
  }
  // Robust standard deviations, at least half a pixel (a cluster on one image row or column).
  const double sx = std::max(0.5, 1.4826 * median(ax)), sy = std::max(0.5, 1.4826 * median(ay));
  const double t2 = threshold * threshold;
  const auto inside = [&](std::size_t i, double cx, double cy) {
    const double u = (xs[i] - cx) / sx, v = (ys[i] - cy) / sy;
    return u * u + v * v <= t2;
  };
  std::mt19937_64 rng(seed);
  double bx = mx, by = my;
  int best = -1;
  for (int it = 0; it < iterations; ++it) {
    const std::size_t a = draw(rng, n), b = draw(rng, n);
    const double cx = 0.5 * (xs[a] + xs[b]), cy = 0.5 * (ys[a] + ys[b]);
    int cnt = 0;
    for (std::size_t i = 0; i < n; ++i) cnt += inside(i, cx, cy) ? 1 : 0;
    if (cnt > best) {
      best = cnt;
      bx = cx;
      by = cy;
    }
  }
  // Refit the centre to the inliers, recount.
  double sxs = 0, sys = 0;
  int m = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (inside(i, bx, by)) {
      sxs += xs[i];
      sys += ys[i];
      ++m;
    }
  if (m > 0) {
    const double cx = sxs / m, cy = sys / m;
    int cnt = 0;
    for (std::size_t i = 0; i < n; ++i) cnt += inside(i, cx, cy) ? 1 : 0;
    if (cnt >= best) {
      bx = cx;
      by = cy;
    }
  }
  for (std::size_t i = 0; i < n; ++i) inlier[i] = inside(i, bx, by) ? 1 : 0;
  return inlier;
}

cv::Mat grabcut_box(const cv::Mat& image, cv::Rect box, int iterations, std::uint64_t seed) {
  if (image.empty() || image.type() != CV_8UC3) throw Error("", "image", "GrabCut needs an 8-bit colour image");
  if (image.cols < 3 || image.rows < 3) throw Error("", "image", "too small for GrabCut (under 3 x 3 pixels)");
  const int x0 = std::max(box.x, 1), y0 = std::max(box.y, 1);
  const int x1 = std::min(box.x + box.width, image.cols - 1), y1 = std::min(box.y + box.height, image.rows - 1);
  if (x1 - x0 < 2 || y1 - y0 < 2)
    throw Error("", "box", "the box [" + std::to_string(box.x) + ", " + std::to_string(box.y) + ", " +
                               std::to_string(box.width) + " x " + std::to_string(box.height) +
                               "] leaves under 2 x 2 pixels inside the image");
  const cv::Rect rect(x0, y0, x1 - x0, y1 - y0);
  cv::Mat mask(image.size(), CV_8UC1, cv::Scalar(cv::GC_BGD));
  cv::Mat bgd, fgd;
  cv::RNG& rng = cv::theRNG();
  const cv::RNG saved = rng;
  rng = cv::RNG(stage_seed(seed, 7) | 1u);
  try {
    cv::grabCut(image, mask, rect, bgd, fgd, iterations, cv::GC_INIT_WITH_RECT);
  } catch (const cv::Exception& e) {
    rng = saved;
    throw Error("", "grabcut", std::string("OpenCV grabCut failed: ") + e.what());
  }
  rng = saved;
  cv::Mat out = (mask == cv::GC_FGD) | (mask == cv::GC_PR_FGD);
  return out;
}

cv::Mat kmeans2_colour(const cv::Mat& image, std::uint64_t seed, cv::Mat* clusters) {
  if (image.empty() || image.type() != CV_8UC3) throw Error("", "image", "k-means on colour needs an 8-bit colour image");
  const std::size_t n = std::size_t(image.total());
  if (n < 2) throw Error("", "image", "k-means (k = 2) needs at least 2 pixels");
  std::vector<float> data(n * 3);
  std::size_t i = 0;
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x, ++i) {
      const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
      data[i * 3] = p[0];
      data[i * 3 + 1] = p[1];
      data[i * 3 + 2] = p[2];
    }
  const std::vector<int> labels = kmeans(data, 3, 2, 3, 100, stage_seed(seed, 11));
  cv::Mat lab(image.size(), CV_8UC1);
  std::size_t size[2] = {0, 0}, border[2] = {0, 0};
  i = 0;
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x, ++i) {
      const int l = labels[i];
      lab.at<std::uint8_t>(y, x) = std::uint8_t(l);
      ++size[l];
      if (x == 0 || y == 0 || x == image.cols - 1 || y == image.rows - 1) ++border[l];
    }
  int fg = border[0] < border[1] ? 0 : border[1] < border[0] ? 1 : (size[0] <= size[1] ? 0 : 1);
  if (clusters) *clusters = lab.clone();
  return lab == fg;
}

double mask_f1(const cv::Mat& predicted, const cv::Mat& truth, const cv::Mat& ignore) {
  if (predicted.size() != truth.size() || (!ignore.empty() && ignore.size() != truth.size()))
    throw Error("", "mask", "the masks differ in size (" + std::to_string(predicted.cols) + " x " +
                                std::to_string(predicted.rows) + " against " + std::to_string(truth.cols) + " x " +
                                std::to_string(truth.rows) + ")");
  if (predicted.type() != CV_8UC1 || truth.type() != CV_8UC1 || (!ignore.empty() && ignore.type() != CV_8UC1))
    throw Error("", "mask", "masks must be 8-bit single-channel");
  long tp = 0, fp = 0, fn = 0;
  for (int y = 0; y < truth.rows; ++y) {
    const std::uint8_t* p = predicted.ptr<std::uint8_t>(y);
    const std::uint8_t* t = truth.ptr<std::uint8_t>(y);
    const std::uint8_t* g = ignore.empty() ? nullptr : ignore.ptr<std::uint8_t>(y);
    for (int x = 0; x < truth.cols; ++x) {
      if (g && g[x]) continue;
      const bool pp = p[x] != 0, tt = t[x] != 0;
      tp += pp && tt;
      fp += pp && !tt;
      fn += !pp && tt;
    }
  }
  if (tp + fp + fn == 0) return std::numeric_limits<double>::quiet_NaN();
  return 2.0 * double(tp) / double(2 * tp + fp + fn);
}

std::vector<Eigen::Vector3f> dense_frame_cloud(const cv::Mat& depth, const sequence::Calibration& c, const sequence::Pose& pose, int step) {
  if (step < 1) throw Error("", "--dense-cloud", "the pixel step must be >= 1");
  if (depth.type() != CV_32FC1 || !c.fx) throw Error("", "depth", "expected a CV_32FC1 depth map and a focal length");
  const Eigen::Matrix3d R = frontend::pose_rotation(pose);
  const Eigen::Vector3d centre = frontend::pose_centre(pose);
  const double fx = *c.fx, fy = c.fy.value_or(fx);
  std::vector<Eigen::Vector3f> out;
  for (int y = 0; y < depth.rows; y += step)
    for (int x = 0; x < depth.cols; x += step) {
      const double z = depth.at<float>(y, x);
      if (!(z > 0)) continue;
      out.push_back((R * Eigen::Vector3d((x - c.cx) * z / fx, (y - c.cy) * z / fy, z) + centre).cast<float>());
    }
  return out;
}

std::vector<Eigen::Vector3f> window_cloud(const frontend::FrontEndResult& fe, int frame, int window) {
  std::vector<Eigen::Vector3f> out;
  const int first = fe.first_frame, n = static_cast<int>(fe.poses.size());
  for (const frontend::Track& t : fe.tracks) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int count = 0;
    for (std::size_t i = 0; i < t.frames.size(); ++i) {
      const int f = t.frames[i];
      if (f < frame - window || f > frame + window || f < first || f >= first + n) continue;
      if (i >= t.disparities.size() || !(t.disparities[i] > 0) || i >= t.points.size()) continue;
      const sequence::Pose& p = fe.poses[std::size_t(f - first)];
      const Eigen::Matrix3d R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(p.R.data());
      sum += R * t.points[i] + Eigen::Vector3d(p.t[0], p.t[1], p.t[2]);
      ++count;
    }
    if (count > 0) out.push_back((sum / count).cast<float>());
  }
  return out;
}

cv::Mat grabcut_sfm_overlay(const cv::Mat& image, const cv::Mat& mask, const GrabCutSfmReport& rep) {
  cv::Mat out = image.clone();
  if (!mask.empty() && mask.size() == image.size()) {
    cv::Mat tint(image.size(), CV_8UC3, cv::Scalar(60, 220, 60));
    cv::Mat mixed;
    cv::addWeighted(image, 0.55, tint, 0.45, 0, mixed);
    mixed.copyTo(out, mask);
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
    cv::drawContours(out, contours, -1, cv::Scalar(40, 255, 40), 1, cv::LINE_AA);
  }
  const std::size_t palette = sizeof kPalette / sizeof kPalette[0];
  for (std::size_t i = 0; i < rep.projected.size(); ++i) {
    if (rep.projected_cluster[i] == rep.chosen) continue;
    cv::circle(out, rep.projected[i], 1, kPalette[std::size_t(rep.projected_cluster[i]) % palette], cv::FILLED);
  }
  const cv::Scalar chosen_colour(0, 255, 255);
  for (std::size_t i = 0; i < rep.chosen_points.size(); ++i) {
    const cv::Point2f p = rep.chosen_points[i];
    if (i < rep.chosen_inlier.size() && !rep.chosen_inlier[i])
      cv::drawMarker(out, p, cv::Scalar(255, 0, 255), cv::MARKER_CROSS, 7, 1);
    else
      cv::circle(out, p, 2, chosen_colour, cv::FILLED);
  }
  if (rep.inlier_box.area() > 0) cv::rectangle(out, rep.inlier_box, cv::Scalar(0, 0, 200), 1);
  if (rep.box.area() > 0) cv::rectangle(out, rep.box, cv::Scalar(0, 0, 255), 2);
  return out;
}

}  // namespace smseg::cloud
