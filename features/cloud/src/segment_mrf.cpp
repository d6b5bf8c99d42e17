// Multi-class MRF segmentation of a coloured point cloud (paper 000): seeds, colour GMMs, alpha-expansion.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include <Eigen/Dense>
#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/console/print.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/conditional_euclidean_clustering.h>
#include <pcl/segmentation/sac_segmentation.h>
#include <tbb/parallel_for.h>

#include "smseg/common/error.hpp"
#include "smseg/cloud/cloud_segment.hpp"
#include "smseg/graphcut/graphcut.hpp"
#include "knn_graph.hpp"

namespace smseg::cloud {

namespace {

/// An RGB Gaussian mixture (GrabCut's colour model): weights, means, inverse covariances and
/// 1 / sqrt(det Sigma) per component.
struct Gmm {
  std::vector<double> weight, norm;
  std::vector<Eigen::Vector3d> mean;
  std::vector<Eigen::Matrix3d> inv;

  int components() const { return static_cast<int>(weight.size()); }

  double likelihood(const Eigen::Vector3d& c) const {
    double l = 0;
    for (std::size_t k = 0; k < weight.size(); ++k) {
      if (weight[k] <= 0) continue;
      const Eigen::Vector3d d = c - mean[k];
      l += weight[k] * norm[k] * std::exp(-0.5 * d.dot(inv[k] * d));
    }
    return l;
  }
  int best(const Eigen::Vector3d& c) const {
    int arg = 0;
    double top = -1;
    for (std::size_t k = 0; k < weight.size(); ++k) {
      if (weight[k] <= 0) continue;
      const Eigen::Vector3d d = c - mean[k];
      const double v = weight[k] * norm[k] * std::exp(-0.5 * d.dot(inv[k] * d));
      if (v > top) top = v, arg = static_cast<int>(k);
    }
    return arg;
  }

  /// Fits component k to the colours assigned to it (assign[i] = component of colours[i]).
  void fit(const std::vector<Eigen::Vector3d>& colours, const std::vector<int>& assign, int K) {
    weight.assign(std::size_t(K), 0.0);
    norm.assign(std::size_t(K), 0.0);
    mean.assign(std::size_t(K), Eigen::Vector3d::Zero());
    inv.assign(std::size_t(K), Eigen::Matrix3d::Identity());
    std::vector<Eigen::Matrix3d> sq(std::size_t(K), Eigen::Matrix3d::Zero());
    std::vector<double> n(std::size_t(K), 0.0);
    for (std::size_t i = 0; i < colours.size(); ++i) {
      const std::size_t k = std::size_t(assign[i]);
      n[k] += 1;
      mean[k] += colours[i];
      sq[k] += colours[i] * colours[i].transpose();
    }
    for (std::size_t k = 0; k < std::size_t(K); ++k) {
      if (n[k] == 0) continue;
      weight[k] = n[k] / double(colours.size());
      mean[k] /= n[k];
      // Covariance plus a floor of 4 (2 grey levels) on the diagonal: a flat colour stays invertible.
      Eigen::Matrix3d cov = sq[k] / n[k] - mean[k] * mean[k].transpose();
      cov.diagonal().array() += 4.0;
      inv[k] = cov.inverse();
      norm[k] = 1.0 / std::sqrt(cov.determinant());
    }
  }

  /// Initial fit: k-means (10 rounds) from centres at luminance quantiles, then fit.
  void init(const std::vector<Eigen::Vector3d>& colours, int K) {
    K = std::max(1, std::min<int>(K, static_cast<int>(colours.size())));
    std::vector<std::size_t> order(colours.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return colours[a].sum() < colours[b].sum(); });
    std::vector<Eigen::Vector3d> centre(static_cast<std::size_t>(K));
    for (int k = 0; k < K; ++k) centre[std::size_t(k)] = colours[order[(2 * std::size_t(k) + 1) * order.size() / (2 * std::size_t(K))]];
    std::vector<int> assign(colours.size(), 0);
    for (int round = 0; round < 10; ++round) {
      for (std::size_t i = 0; i < colours.size(); ++i) {
        double best = INFINITY;
        for (int k = 0; k < K; ++k) {
          const double d = (colours[i] - centre[std::size_t(k)]).squaredNorm();
          if (d < best) best = d, assign[i] = k;
        }
      }
      std::vector<Eigen::Vector3d> sum(std::size_t(K), Eigen::Vector3d::Zero());
      std::vector<int> cnt(std::size_t(K), 0);
      for (std::size_t i = 0; i < colours.size(); ++i) sum[std::size_t(assign[i])] += colours[i], ++cnt[std::size_t(assign[i])];
      for (int k = 0; k < K; ++k)
        if (cnt[std::size_t(k)] > 0) centre[std::size_t(k)] = sum[std::size_t(k)] / cnt[std::size_t(k)];
    }
    fit(colours, assign, K);
  }

  /// GrabCut's re-estimation: each colour to its most likely component, then fit.
  void refit(const std::vector<Eigen::Vector3d>& colours) {
    const int K = components();
    std::vector<int> assign(colours.size());
    for (std::size_t i = 0; i < colours.size(); ++i) assign[i] = best(colours[i]);
    fit(colours, assign, K);
  }
};

Eigen::Vector3d rgb(const ColouredCloud& c, std::size_t i) {
  return {double(c.colours[i][0]), double(c.colours[i][1]), double(c.colours[i][2])};
}

MrfSeeds finish_seeds(const ColouredCloud& cloud, std::vector<std::vector<int>> regions, std::string method) {
  MrfSeeds s;
  s.method = std::move(method);
  for (auto& r : regions) {
    Eigen::Vector3d m(0, 0, 0);
    for (int i : r) m += cloud.points[std::size_t(i)].cast<double>();
    s.positions.push_back((m / double(r.size())).cast<float>());
    s.regions.push_back(std::move(r));
  }
  return s;
}

}  // namespace

void PlaneSeedParams::validate() const {
  if (!(plane_distance > 0)) throw Error("", "--plane-distance", "must be > 0");
  if (!(cluster_tolerance >= 0)) throw Error("", "--cluster-tolerance", "must be >= 0 (0: 3 x mean neighbour distance)");
  if (!(colour_tolerance > 0)) throw Error("", "--colour-tolerance", "must be > 0");
  if (min_cluster < 1) throw Error("", "--min-cluster", "must be >= 1");
}

void MrfParams::validate() const {
  if (neighbours < 1 || neighbours > 100) throw Error("", "--neighbours", "must be 1..100");
  if (components < 1 || components > 20) throw Error("", "--components", "must be 1..20");
  if (!(lambda >= 0) || !std::isfinite(lambda)) throw Error("", "--lambda", "must be >= 0");
  if (max_iterations < 1) throw Error("", "--iterations", "must be >= 1");
  if (!(tolerance >= 0)) throw Error("", "--tolerance", "must be >= 0");
}

MrfSeeds plane_seeds(const ColouredCloud& cloud, const PlaneSeedParams& params) {
  params.validate();
  if (cloud.size() < 10) throw Error("", "points", "the cloud has too few points for plane seeding");
  if (!cloud.has_colours()) throw Error("", "rgb", "plane seeding clusters by colour: the cloud has no colours");
  pcl::PointCloud<pcl::PointXYZ>::Ptr xyz(new pcl::PointCloud<pcl::PointXYZ>);
  for (const auto& p : cloud.points) xyz->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  pcl::SACSegmentation<pcl::PointXYZ> sac;  // fixed RNG seed (random = false): same cloud, same plane
  sac.setOptimizeCoefficients(true);
  sac.setModelType(pcl::SACMODEL_PLANE);
  sac.setMethodType(pcl::SAC_RANSAC);
  sac.setDistanceThreshold(params.plane_distance);
  sac.setMaxIterations(500);
  sac.setInputCloud(xyz);
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coeffs;
  // PCL prints a line per rejected sample (a thousand for a cloud along a line); what matters, no plane,
  // is said below in one line.
  const auto pcl_level = pcl::console::getVerbosityLevel();
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // its "sample not good" lines are errors too
  sac.segment(inliers, coeffs);
  pcl::console::setVerbosityLevel(pcl_level);
  if (inliers.indices.size() < 3 || coeffs.values.size() != 4)
    throw Error("", "seeds", "RANSAC found no supporting plane");
  const Eigen::Vector4d plane(coeffs.values[0], coeffs.values[1], coeffs.values[2], coeffs.values[3]);
  std::vector<double> side(cloud.size());
  int above = 0, below = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    side[i] = plane.head<3>().dot(cloud.points[i].cast<double>()) + plane[3];
    above += side[i] > params.plane_distance;
    below += side[i] < -params.plane_distance;
  }
  const double sign = above >= below ? 1.0 : -1.0;
  std::vector<std::vector<int>> regions;
  regions.emplace_back(inliers.indices.begin(), inliers.indices.end());
  std::sort(regions[0].begin(), regions[0].end());
  pcl::PointCloud<pcl::PointXYZRGB>::Ptr up(new pcl::PointCloud<pcl::PointXYZRGB>);
  std::vector<int> back;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (sign * side[i] > params.plane_distance) {
      pcl::PointXYZRGB p;
      p.x = cloud.points[i].x();
      p.y = cloud.points[i].y();
      p.z = cloud.points[i].z();
      p.r = cloud.colours[i][0];
      p.g = cloud.colours[i][1];
      p.b = cloud.colours[i][2];
      up->push_back(p);
      back.push_back(static_cast<int>(i));
    }
  if (up->size() < std::size_t(params.min_cluster)) throw Error("", "seeds", "no points above the supporting plane: nothing to seed");
  double tol = params.cluster_tolerance;
  if (tol <= 0) tol = 3.0 * knn_graph(cloud, 4).mean_distance;
  const float ct2 = float(params.colour_tolerance * params.colour_tolerance);
  pcl::ConditionalEuclideanClustering<pcl::PointXYZRGB> cec;
  cec.setInputCloud(up);
  cec.setConditionFunction([ct2](const pcl::PointXYZRGB& a, const pcl::PointXYZRGB& b, float) {
    const float dr = float(a.r) - float(b.r), dg = float(a.g) - float(b.g), db = float(a.b) - float(b.b);
    return dr * dr + dg * dg + db * db < ct2;
  });
  cec.setClusterTolerance(float(tol));
  cec.setMinClusterSize(params.min_cluster);
  cec.setMaxClusterSize(static_cast<int>(up->size()));
  pcl::IndicesClusters clusters;
  cec.segment(clusters);
  if (clusters.empty()) throw Error("", "seeds", "no cluster of at least " + std::to_string(params.min_cluster) + " points above the plane");
  std::vector<std::vector<int>> objects;
  for (const auto& c : clusters) {
    std::vector<int> r;
    for (const auto i : c.indices) r.push_back(back[std::size_t(i)]);
    std::sort(r.begin(), r.end());
    objects.push_back(std::move(r));
  }
  std::stable_sort(objects.begin(), objects.end(), [](const auto& a, const auto& b) {
    return a.size() != b.size() ? a.size() > b.size() : a.front() < b.front();
  });
  for (auto& o : objects) regions.push_back(std::move(o));
  return finish_seeds(cloud, std::move(regions), "plane");
}

MrfSeeds file_seeds(const ColouredCloud& cloud, const fs::path& path) {
  const Json j = read_json(path);
  const std::string where = path.string();
  if (!j.is_object() || j.value("format", "") != "smseg-seeds" || j.value("version", 0) != 1)
    throw Error(where, "format", "expected {\"format\": \"smseg-seeds\", \"version\": 1, ...}");
  if (!j.contains("radius") || !j["radius"].is_number() || !(j["radius"].get<double>() > 0))
    throw Error(where, "radius", "a positive number is expected");
  const double r2 = std::pow(j["radius"].get<double>(), 2);
  if (!j.contains("seeds") || !j["seeds"].is_array() || j["seeds"].empty())
    throw Error(where, "seeds", "a non-empty array of {\"label\": L, \"position\": [x, y, z]} is expected");
  std::map<int, std::vector<int>> by_label;
  for (std::size_t s = 0; s < j["seeds"].size(); ++s) {
    const Json& e = j["seeds"][s];
    const std::string field = "seeds[" + std::to_string(s) + "]";
    if (!e.is_object() || !e.contains("label") || !e["label"].is_number_integer() || e["label"].get<int>() < 0 ||
        e["label"].get<int>() > 254 || !e.contains("position") || !e["position"].is_array() || e["position"].size() != 3 ||
        !std::all_of(e["position"].begin(), e["position"].end(), [](const Json& v) { return v.is_number(); }))
      throw Error(where, field, "expected {\"label\": 0..254, \"position\": [x, y, z]}");
    const Eigen::Vector3f pos(e["position"][0].get<float>(), e["position"][1].get<float>(), e["position"][2].get<float>());
    std::vector<int>& region = by_label[e["label"].get<int>()];
    const std::size_t before = region.size();
    for (std::size_t i = 0; i < cloud.size(); ++i)
      if ((cloud.points[i] - pos).squaredNorm() <= r2) region.push_back(static_cast<int>(i));
    if (region.size() == before)
      throw Error(where, field, "bad seed: no point of the cloud within the radius of its position");
  }
  std::vector<std::vector<int>> regions;
  int expect = 0;
  for (auto& [label, region] : by_label) {
    if (label != expect) throw Error(where, "seeds", "labels must be 0..L-1, each used (label " + std::to_string(expect) + " is missing)");
    ++expect;
    std::sort(region.begin(), region.end());
    region.erase(std::unique(region.begin(), region.end()), region.end());
    regions.push_back(std::move(region));
  }
  if (regions.size() < 2) throw Error(where, "seeds", "at least two labels are needed");
  return finish_seeds(cloud, std::move(regions), "file");
}

std::vector<int> mrf_segment(const ColouredCloud& cloud, const MrfSeeds& seeds, const MrfParams& params,
                             MrfReport* report) {
  params.validate();
  if (cloud.size() == 0) throw Error("", "points", "the cloud is empty");
  cloud.validate("cloud");
  if (!cloud.has_colours()) throw Error("", "rgb", "the MRF's colour models need a cloud with colours");
  const int L = static_cast<int>(seeds.regions.size());
  if (L < 2) throw Error("", "seeds", "at least two seeded labels are needed");
  for (int l = 0; l < L; ++l) {
    if (seeds.regions[std::size_t(l)].empty()) throw Error("", "seeds", "label " + std::to_string(l) + " has no seed point");
    for (int i : seeds.regions[std::size_t(l)])
      if (i < 0 || std::size_t(i) >= cloud.size()) throw Error("", "seeds", "seed point index outside the cloud");
  }
  const auto t0 = std::chrono::steady_clock::now();
  MrfReport rep;
  rep.labels = L;
  const std::size_t n = cloud.size();
  std::vector<Eigen::Vector3d> colour(n);
  for (std::size_t i = 0; i < n; ++i) colour[i] = rgb(cloud, i);

  const KnnGraph knn = knn_graph(cloud, params.neighbours);
  rep.mean_distance = knn.mean_distance;
  double sq = 0;
  for (const auto& p : knn.pairs) sq += (colour[std::size_t(p.i)] - colour[std::size_t(p.j)]).squaredNorm();
  const double mean_sq = knn.pairs.empty() ? 0.0 : sq / double(knn.pairs.size());
  rep.beta = mean_sq > 0 ? 1.0 / (2.0 * mean_sq) : 0.0;
  graphcut::PottsEnergy e;
  e.nodes = static_cast<int>(n);
  e.labels = L;
  e.unary.assign(n * std::size_t(L), 0.0);
  const double dbar = knn.mean_distance > 0 ? knn.mean_distance : 1.0;
  for (const auto& p : knn.pairs) {
    const double d = std::max(double(p.distance), 1e-3 * dbar);
    const double w = params.lambda * (dbar / d) *
                     std::exp(-rep.beta * (colour[std::size_t(p.i)] - colour[std::size_t(p.j)]).squaredNorm());
    e.edges.push_back({p.i, p.j, w});
  }

  std::vector<Gmm> gmm(static_cast<std::size_t>(L));
  for (int l = 0; l < L; ++l) {
    std::vector<Eigen::Vector3d> c;
    for (int i : seeds.regions[std::size_t(l)]) c.push_back(colour[std::size_t(i)]);
    gmm[std::size_t(l)].init(c, params.components);
  }
  graphcut::ExpansionSolver solver;
  std::vector<int> labels;
  for (int it = 0; it < params.max_iterations; ++it) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 2048), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t i = r.begin(); i < r.end(); ++i)
        for (int l = 0; l < L; ++l)
          e.unary[i * std::size_t(L) + std::size_t(l)] = -std::log(gmm[std::size_t(l)].likelihood(colour[i]) + 1e-300);
    });
    const graphcut::ExpansionReport r = solver.solve(e, labels);
    rep.energies.push_back(r.energy);
    ++rep.iterations;
    if (it > 0) {
      const double prev = rep.energies[rep.energies.size() - 2];
      if (std::abs(prev - r.energy) <= params.tolerance * std::abs(prev)) break;
    }
    if (it + 1 == params.max_iterations) break;
    for (int l = 0; l < L; ++l) {
      std::vector<Eigen::Vector3d> c;
      for (std::size_t i = 0; i < n; ++i)
        if (labels[i] == l) c.push_back(colour[i]);
      if (c.size() >= 2) gmm[std::size_t(l)].refit(c);
    }
  }
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (report) *report = rep;
  return labels;
}

std::vector<int> seed_truth(const ColouredCloud& cloud, const MrfSeeds& seeds) {
  std::vector<int> out;
  for (const auto& r : seeds.regions) {
    std::map<int, int> count;
    for (int i : r)
      if (cloud.has_labels() && cloud.labels[std::size_t(i)] >= 0) ++count[cloud.labels[std::size_t(i)]];
    int best = -1, n = 0;
    for (const auto& [label, c] : count)
      if (c > n) best = label, n = c;
    out.push_back(best);
  }
  return out;
}

}  // namespace smseg::cloud
