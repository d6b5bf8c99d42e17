// A point cloud seen from one frame (cloud_view.hpp): projection with a z-buffer, saliency regions
// (OpenCV's saliency module), saliency seeds for the MRF of paper 000, pictures and instance scores.
#include "smseg/cloud/cloud_view.hpp"

#include <algorithm>
#include <functional>
#include <cmath>
#include <limits>
#include <numeric>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>
#include <opencv2/saliency.hpp>

namespace smseg::cloud {

void ProjectionParams::validate() const {
  if (!(min_depth > 0) || !std::isfinite(min_depth)) throw Error("", "--min-depth", "must be positive (metres)");
  if (splat_radius < 0 || splat_radius > 20) throw Error("", "--splat-radius", "must be in 0..20 pixels");
  if (!(depth_tolerance >= 0) || !std::isfinite(depth_tolerance))
    throw Error("", "--depth-tolerance", "must be >= 0 (metres)");
}

CloudProjection project_cloud(const ColouredCloud& cloud, const ViewCamera& cam, const ProjectionParams& params) {
  params.validate();
  if (!(cam.fx > 0) || !(cam.fy > 0) || cam.size.width <= 0 || cam.size.height <= 0)
    throw Error("", "camera", "needs a positive focal length and image size");
  Eigen::Matrix3d R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(i, j) = cam.pose.R[3 * i + j];
  const Eigen::Matrix3d Rt = R.transpose();
  const Eigen::Vector3d C(cam.pose.t[0], cam.pose.t[1], cam.pose.t[2]);
  const int W = cam.size.width, H = cam.size.height, r = params.splat_radius;
  CloudProjection out;
  out.pixel.assign(cloud.size(), cv::Point(-1, -1));
  out.depth.assign(cloud.size(), 0.0f);
  cv::Mat zbuf(cam.size, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d X = Rt * (cloud.points[i].cast<double>() - C);
    out.depth[i] = static_cast<float>(X.z());
    if (!(X.z() >= params.min_depth)) continue;
    const double u = cam.fx * X.x() / X.z() + cam.cx, v = cam.fy * X.y() / X.z() + cam.cy;
    if (!(u > -0.5 && u < W - 0.5 && v > -0.5 && v < H - 0.5)) continue;
    const cv::Point p(static_cast<int>(std::lround(u)), static_cast<int>(std::lround(v)));
    out.pixel[i] = p;
    const float z = static_cast<float>(X.z());
    for (int y = std::max(0, p.y - r); y <= std::min(H - 1, p.y + r); ++y)
      for (int x = std::max(0, p.x - r); x <= std::min(W - 1, p.x + r); ++x)
        if ((x - p.x) * (x - p.x) + (y - p.y) * (y - p.y) <= r * r) {
          float& b = zbuf.at<float>(y, x);
          b = std::min(b, z);
        }
  }
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const cv::Point p = out.pixel[i];
    if (p.x < 0) continue;
    const double z = out.depth[i];
    if (z <= zbuf.at<float>(p) + std::max(params.depth_tolerance, 0.02 * z)) out.visible.push_back(static_cast<int>(i));
  }
  return out;
}

void SaliencyParams::validate() const {
  if (method != "colour" && method != "fine-grained" && method != "spectral-residual")
    throw Error("", "--saliency", "is \"" + method + "\", expected colour, fine-grained or spectral-residual");
  if (!(threshold >= 0 && threshold < 1)) throw Error("", "--saliency-threshold", "must be in [0, 1) (0: Otsu)");
  if (!(background > 0 && background <= 1)) throw Error("", "--background", "must be in (0, 1]");
  if (!(min_area > 0 && min_area < 1)) throw Error("", "--min-area", "must be in (0, 1) (share of the image)");
  if (blur < 0 || blur > 50) throw Error("", "--saliency-blur", "must be in 0..50 pixels");
  if (!(scale >= 0.05 && scale <= 1)) throw Error("", "--saliency-scale", "must be in [0.05, 1]");
  if (!(max_area > min_area && max_area <= 1)) throw Error("", "--max-area", "must be in (--min-area, 1]");
  // Each step is one level of split()'s recursion: 1/200 keeps it shallow (and finer than the map's
  // 8-bit precision is never needed); 1e-6 overflowed the stack.
  if (!(step >= 0.005 && step < 1)) throw Error("", "--saliency-step", "must be in [0.005, 1)");
}

namespace {

/// One saliency map of an 8-bit image (the module's algorithms work on its intensity), as float 0..1 at
/// `size`.
cv::Mat saliency_of(const cv::Mat& full, bool fine, cv::Size size, const SaliencyParams& params) {
  cv::Mat image = full, raw;
  if (params.scale < 1.0) cv::resize(full, image, cv::Size(), params.scale, params.scale, cv::INTER_AREA);
  const bool ok = fine ? cv::saliency::StaticSaliencyFineGrained::create()->computeSaliency(image, raw)
                       : cv::saliency::StaticSaliencySpectralResidual::create()->computeSaliency(image, raw);
  if (!ok || raw.empty()) throw Error("", "--saliency", "OpenCV could not compute the " + params.method + " saliency");
  cv::Mat m;
  raw.convertTo(m, CV_32F);
  if (m.channels() != 1) cv::cvtColor(m, m, cv::COLOR_BGR2GRAY);
  if (m.size() != size) cv::resize(m, m, size, 0, 0, cv::INTER_LINEAR);
  cv::normalize(m, m, 0.0, 1.0, cv::NORM_MINMAX);
  return m;
}

/// The image's saliency map (params.method), blurred and normalised to 0..1.
cv::Mat saliency_map(const cv::Mat& bgr, const SaliencyParams& params) {
  cv::Mat sal;
  if (params.method == "colour") {
    // Itti-style conspicuity (as in Rasolzadeh et al., paper 000's saliency): the fine-grained
    // centre-surround saliency of intensity and of the two colour-opponent channels R-G and B-Y, averaged.
    cv::Mat f;
    bgr.convertTo(f, CV_32F, 1.0 / 255.0);
    std::vector<cv::Mat> ch;
    cv::split(f, ch);  // B, G, R
    const cv::Mat I = (ch[0] + ch[1] + ch[2]) / 3.0f;
    const cv::Mat RG = ch[2] - ch[1];
    const cv::Mat BY = ch[0] - (ch[2] + ch[1]) / 2.0f;
    sal = cv::Mat::zeros(bgr.size(), CV_32F);
    for (const cv::Mat& c : {I, RG, BY}) {
      cv::Mat c8, c3;
      cv::normalize(c, c8, 0, 255, cv::NORM_MINMAX, CV_8U);
      cv::cvtColor(c8, c3, cv::COLOR_GRAY2BGR);
      sal += saliency_of(c3, true, bgr.size(), params) / 3.0f;
    }
  } else {
    sal = saliency_of(bgr, params.method == "fine-grained", bgr.size(), params);
  }
  if (params.blur > 0) cv::blur(sal, sal, cv::Size(2 * params.blur + 1, 2 * params.blur + 1), cv::Point(-1, -1),
                                cv::BORDER_REFLECT_101);
  cv::normalize(sal, sal, 0.0, 1.0, cv::NORM_MINMAX);
  return sal;
}

}  // namespace

SalientRegions salient_regions(const cv::Mat& bgr, const SaliencyParams& params) {
  params.validate();
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("", "image", "expected an 8-bit colour image");
  const cv::Mat sal = saliency_map(bgr, params);
  SalientRegions out;
  out.saliency = sal;
  if (params.threshold > 0) {
    out.threshold = params.threshold;
  } else {
    cv::Mat s8, dummy;
    sal.convertTo(s8, CV_8U, 255.0);
    out.threshold = cv::threshold(s8, dummy, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU) / 255.0;
  }
  // Connected salient components. One larger than max_area of the image is a salient structure (a table
  // under the objects, a door) rather than an object: it is re-thresholded inside itself one step higher,
  // until its parts are small enough; what of it is left over counts as background.
  const double min_px = params.min_area * bgr.rows * bgr.cols, max_px = params.max_area * bgr.rows * bgr.cols;
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3));
  std::vector<std::pair<int, cv::Mat>> found;  // area, mask
  cv::Mat structure = cv::Mat::zeros(bgr.size(), CV_8UC1);
  std::function<void(const cv::Mat&, double)> split = [&](const cv::Mat& within, double level) {
    cv::Mat binary = (sal >= level) & within;
    cv::morphologyEx(binary, binary, cv::MORPH_OPEN, kernel);
    cv::Mat cc, stats, centroids;
    const int n = cv::connectedComponentsWithStats(binary, cc, stats, centroids, 8, CV_32S);
    for (int c = 1; c < n; ++c) {
      const int area = stats.at<int>(c, cv::CC_STAT_AREA);
      if (area < min_px) continue;
      const cv::Mat mask = cc == c;
      if (area <= max_px) {
        found.emplace_back(area, mask);
      } else {
        structure.setTo(255, mask);
        if (level + params.step < 1.0) split(mask, level + params.step);
      }
    }
  };
  split(cv::Mat(bgr.size(), CV_8UC1, cv::Scalar(255)), out.threshold);
  std::stable_sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  out.regions = cv::Mat::zeros(bgr.size(), CV_32SC1);
  for (std::size_t k = 0; k < found.size(); ++k) {
    out.regions.setTo(static_cast<int>(k) + 1, found[k].second);
    structure.setTo(0, found[k].second);
  }
  out.structure = structure;
  out.count = static_cast<int>(found.size());
  return out;
}

MrfSeeds saliency_seeds(const std::vector<cv::Point>& pixels, const std::vector<Eigen::Vector3f>& positions,
                        const SalientRegions& sr, double background, int min_points,
                        std::vector<int>* region_of_label) {
  if (pixels.size() != positions.size()) throw Error("", "seeds", "pixels and positions differ in size");
  if (min_points < 1) throw Error("", "--min-seed-points", "must be at least 1");
  std::vector<std::vector<int>> by_region(static_cast<std::size_t>(sr.count) + 1);
  const float below = static_cast<float>(background * sr.threshold);
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const cv::Point p = pixels[i];
    if (p.x < 0 || p.y < 0 || p.x >= sr.regions.cols || p.y >= sr.regions.rows)
      throw Error("", "seeds", "a point's pixel is outside the saliency map");
    const int r = sr.regions.at<int>(p);
    if (r > 0) {
      by_region[static_cast<std::size_t>(r)].push_back(static_cast<int>(i));
    } else if (sr.saliency.at<float>(p) < below || (!sr.structure.empty() && sr.structure.at<std::uint8_t>(p))) {
      by_region[0].push_back(static_cast<int>(i));
    }
  }
  MrfSeeds seeds;
  seeds.method = "saliency";
  std::vector<int> used;
  for (int r = 0; r <= sr.count; ++r) {
    const auto& pts = by_region[static_cast<std::size_t>(r)];
    if (r > 0 && static_cast<int>(pts.size()) < min_points) continue;
    if (r == 0 && pts.empty()) throw Error("", "--seeds saliency", "no point lies in a non-salient area (background)");
    Eigen::Vector3f mean = Eigen::Vector3f::Zero();
    for (int i : pts) mean += positions[static_cast<std::size_t>(i)];
    seeds.regions.push_back(pts);
    seeds.positions.push_back(mean / static_cast<float>(pts.size()));
    used.push_back(r);
  }
  if (used.size() < 2)
    throw Error("", "--seeds saliency",
                sr.count == 0 ? "the image has no salient region"
                              : "no salient region holds " + std::to_string(min_points) + " or more cloud points");
  if (region_of_label) *region_of_label = used;
  return seeds;
}

void split_seed_regions(const ColouredCloud& view, MrfSeeds& seeds, double distance, double colour_tolerance,
                        int min_points, std::vector<int>* region_of_label) {
  if (!(distance > 0) || !(colour_tolerance > 0)) throw Error("", "--seed-split", "needs positive tolerances");
  if (!view.has_colours()) throw Error("", "seeds", "splitting seed regions needs colours");
  if (region_of_label && region_of_label->size() != seeds.regions.size())
    throw Error("", "seeds", "one region per seed label is needed");
  MrfSeeds out;
  out.method = seeds.method;
  std::vector<int> regions_out;
  const float d2 = static_cast<float>(distance * distance), c2 = static_cast<float>(colour_tolerance * colour_tolerance);
  auto colour_d2 = [&](int a, int b) {
    float s = 0;
    for (int k = 0; k < 3; ++k) {
      const float d = float(view.colours[std::size_t(a)][k]) - float(view.colours[std::size_t(b)][k]);
      s += d * d;
    }
    return s;
  };
  for (std::size_t l = 0; l < seeds.regions.size(); ++l) {
    const std::vector<int>& pts = seeds.regions[l];
    std::vector<std::vector<int>> parts;
    if (l == 0) {
      parts.push_back(pts);  // the background stays one label
    } else {
      // Connected components of the points linked by distance < distance and colour distance < tolerance.
      std::vector<int> comp(pts.size(), -1);
      int next = 0;
      for (std::size_t i = 0; i < pts.size(); ++i) {
        if (comp[i] >= 0) continue;
        std::vector<std::size_t> stack{i};
        comp[i] = next;
        while (!stack.empty()) {
          const std::size_t a = stack.back();
          stack.pop_back();
          for (std::size_t b = 0; b < pts.size(); ++b)
            if (comp[b] < 0 && (view.points[std::size_t(pts[a])] - view.points[std::size_t(pts[b])]).squaredNorm() < d2 &&
                colour_d2(pts[a], pts[b]) < c2) {
              comp[b] = next;
              stack.push_back(b);
            }
        }
        ++next;
      }
      parts.assign(std::size_t(next), {});
      for (std::size_t i = 0; i < pts.size(); ++i) parts[std::size_t(comp[i])].push_back(pts[i]);
      std::stable_sort(parts.begin(), parts.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
    }
    for (auto& part : parts) {
      if (l > 0 && static_cast<int>(part.size()) < min_points) continue;
      Eigen::Vector3f mean = Eigen::Vector3f::Zero();
      for (int i : part) mean += view.points[std::size_t(i)];
      out.positions.push_back(mean / static_cast<float>(part.size()));
      out.regions.push_back(std::move(part));
      regions_out.push_back(region_of_label ? (*region_of_label)[l] : static_cast<int>(l));
    }
  }
  if (out.regions.size() < 2)
    throw Error("", "--seeds saliency", "no salient region keeps " + std::to_string(min_points) +
                                            " or more points of one colour and place");
  seeds = std::move(out);
  if (region_of_label) *region_of_label = regions_out;
}

cv::Vec3b label_colour(int label) {
  static const cv::Vec3b kColours[] = {{150, 150, 150}, {40, 40, 230},  {230, 120, 30}, {40, 200, 40},
                                       {20, 210, 240},  {200, 60, 200}, {230, 230, 40}, {60, 120, 250},
                                       {160, 40, 100},  {120, 230, 170}, {30, 90, 140}};
  constexpr int n = sizeof(kColours) / sizeof(kColours[0]);
  if (label < 0) return {0, 0, 0};
  if (label < n) return kColours[label];
  const unsigned h = static_cast<unsigned>(label) * 2654435761u;
  return {static_cast<std::uint8_t>(64 + (h & 127)), static_cast<std::uint8_t>(64 + ((h >> 8) & 127)),
          static_cast<std::uint8_t>(64 + ((h >> 16) & 127))};
}

cv::Mat splat_labels(const CloudProjection& proj, std::span<const int> labels, cv::Size size, int radius) {
  if (labels.size() != proj.pixel.size()) throw Error("", "labels", "one label per point is needed");
  // Far to near, so that the nearest point's disc ends on top (ties: the lower index last).
  std::vector<int> order(proj.visible.begin(), proj.visible.end());
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return proj.depth[a] > proj.depth[b]; });
  cv::Mat out(size, CV_8UC3, cv::Scalar(0, 0, 0));
  for (int i : order) {
    if (labels[static_cast<std::size_t>(i)] < 0) continue;
    const cv::Point p = proj.pixel[static_cast<std::size_t>(i)];
    const cv::Vec3b c = label_colour(labels[static_cast<std::size_t>(i)]);
    for (int y = std::max(0, p.y - radius); y <= std::min(size.height - 1, p.y + radius); ++y)
      for (int x = std::max(0, p.x - radius); x <= std::min(size.width - 1, p.x + radius); ++x)
        if ((x - p.x) * (x - p.x) + (y - p.y) * (y - p.y) <= radius * radius) out.at<cv::Vec3b>(y, x) = c;
  }
  return out;
}

InstanceScore score_instances(std::span<const int> truth, std::span<const int> predicted, int truth_ids, int labels) {
  if (truth.size() != predicted.size()) throw Error("", "score", "truth and prediction differ in size");
  if (truth_ids < 1 || labels < 1) throw Error("", "score", "needs at least one truth id and one label");
  InstanceScore s;
  s.confusion.assign(static_cast<std::size_t>(truth_ids), std::vector<long>(static_cast<std::size_t>(labels), 0));
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (truth[i] < 0) continue;
    if (truth[i] >= truth_ids || predicted[i] < 0 || predicted[i] >= labels)
      throw Error("", "score", "a truth id or label is out of range");
    ++s.confusion[static_cast<std::size_t>(truth[i])][static_cast<std::size_t>(predicted[i])];
  }
  s.label_to_truth.assign(static_cast<std::size_t>(labels), -1);
  for (int l = 0; l < labels; ++l) {
    long best = 0;
    for (int t = 0; t < truth_ids; ++t)
      if (s.confusion[static_cast<std::size_t>(t)][static_cast<std::size_t>(l)] > best) {
        best = s.confusion[static_cast<std::size_t>(t)][static_cast<std::size_t>(l)];
        s.label_to_truth[static_cast<std::size_t>(l)] = t;
      }
  }
  std::vector<int> mapped(predicted.size(), -1);
  for (std::size_t i = 0; i < predicted.size(); ++i)
    if (predicted[i] >= 0 && predicted[i] < labels) mapped[i] = s.label_to_truth[static_cast<std::size_t>(predicted[i])];
  s.truth_points.assign(static_cast<std::size_t>(truth_ids), 0);
  for (int t = 0; t < truth_ids; ++t) {
    for (long c : s.confusion[static_cast<std::size_t>(t)]) s.truth_points[static_cast<std::size_t>(t)] += c;
    s.f1.push_back(f1_score(truth, mapped, t));
  }
  return s;
}

}  // namespace smseg::cloud
