// The PCL part of cloud_segment.hpp: writing cloud files, k-nearest-neighbour graphs, centroid min-cut
// (read_coloured_cloud, our own reader, is in cloud_read.cpp).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <vector>

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/min_cut_segmentation.h>
#include <tbb/parallel_for.h>

#include "smseg/common/error.hpp"
#include "smseg/common/io.hpp"
#include "smseg/cloud/cloud_segment.hpp"
#include "smseg/graphcut/graphcut.hpp"
#include "knn_graph.hpp"
#include "pcl_write.hpp"

namespace smseg::cloud {

namespace {

std::array<std::uint8_t, 3> label_colour(int label) {
  if (label < 0) return {170, 170, 170};
  static const std::array<std::array<std::uint8_t, 3>, 10> palette = {{{128, 128, 128},
                                                                       {220, 40, 40},
                                                                       {40, 170, 60},
                                                                       {40, 80, 220},
                                                                       {230, 200, 40},
                                                                       {170, 60, 190},
                                                                       {40, 190, 200},
                                                                       {240, 130, 30},
                                                                       {250, 250, 250},
                                                                       {90, 50, 20}}};
  return palette[std::size_t(label) % palette.size()];
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

void write_labelled_cloud(const fs::path& path, const ColouredCloud& cloud, std::span<const int> labels) {
  pcl_write::check_extension(path);
  if (labels.size() != cloud.size()) throw Error(path.string(), "labels", "one label per point expected");
  pcl::PointCloud<pcl::PointXYZRGBL> pc;
  pc.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    pcl::PointXYZRGBL p;
    p.x = cloud.points[i].x();
    p.y = cloud.points[i].y();
    p.z = cloud.points[i].z();
    const auto rgb = cloud.has_colours() ? cloud.colours[i] : label_colour(labels[i]);
    p.r = rgb[0];
    p.g = rgb[1];
    p.b = rgb[2];
    p.label = labels[i] >= 0 ? static_cast<std::uint32_t>(labels[i]) : 255u;
    pc.push_back(p);
  }
  pc.width = static_cast<std::uint32_t>(pc.size());
  pc.height = 1;
  pcl_write::save_atomic(path, pc);
}

KnnGraph knn_graph(const ColouredCloud& cloud, int k) {
  if (k < 1) throw Error("", "--neighbours", "must be at least 1");
  if (cloud.size() < std::size_t(k) + 1)
    throw Error("", "points", "the cloud has " + std::to_string(cloud.size()) + " points, fewer than k + 1 = " +
                                  std::to_string(k + 1));
  pcl::PointCloud<pcl::PointXYZ>::Ptr pc(new pcl::PointCloud<pcl::PointXYZ>);
  pc->reserve(cloud.size());
  for (const auto& p : cloud.points) pc->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(pc);
  const std::size_t n = cloud.size(), K = std::size_t(k);
  KnnGraph g;
  g.k = k;
  g.neighbours.assign(n * K, -1);
  g.distances.assign(n * K, 0.0f);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
    pcl::Indices idx;
    std::vector<float> sq;
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      tree.nearestKSearch(static_cast<int>(i), k + 1, idx, sq);
      // The query point itself comes first (or among exact duplicates): drop it by index.
      std::size_t m = 0;
      for (std::size_t j = 0; j < idx.size() && m < K; ++j) {
        if (std::size_t(idx[j]) == i) continue;
        g.neighbours[i * K + m] = idx[j];
        g.distances[i * K + m] = std::sqrt(sq[j]);
        ++m;
      }
    }
  });
  double sum = 0;
  std::size_t cnt = 0;
  for (std::size_t i = 0; i < n * K; ++i)
    if (g.neighbours[i] >= 0) sum += g.distances[i], ++cnt;
  g.mean_distance = cnt ? sum / double(cnt) : 0.0;
  // Each unordered pair once, in a fixed order.
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t m = 0; m < K; ++m) {
      const int j = g.neighbours[i * K + m];
      if (j < 0) continue;
      const int a = std::min<int>(static_cast<int>(i), j), b = std::max<int>(static_cast<int>(i), j);
      g.pairs.push_back({a, b, g.distances[i * K + m]});
    }
  std::sort(g.pairs.begin(), g.pairs.end(),
            [](const KnnGraph::Pair& x, const KnnGraph::Pair& y) { return x.i != y.i ? x.i < y.i : x.j < y.j; });
  g.pairs.erase(std::unique(g.pairs.begin(), g.pairs.end(),
                            [](const KnnGraph::Pair& x, const KnnGraph::Pair& y) { return x.i == y.i && x.j == y.j; }),
                g.pairs.end());
  return g;
}

void CentroidMinCutParams::validate() const {
  if (!(radius > 0) || !std::isfinite(radius)) throw Error("", "--radius", "must be a distance > 0");
  if (neighbours < 1 || neighbours > 100) throw Error("", "--neighbours", "must be 1..100");
  if (!(sigma >= 0) || !std::isfinite(sigma)) throw Error("", "--sigma", "must be 0 (mean neighbour distance) or > 0");
  if (!(lambda >= 0) || !std::isfinite(lambda)) throw Error("", "--lambda", "must be >= 0");
  if (!(source_weight > 0) || !std::isfinite(source_weight)) throw Error("", "--source-weight", "must be > 0");
  if (up < 0 || up > 2) throw Error("", "--up", "must be x, y or z");
}

std::vector<int> centroid_mincut(const ColouredCloud& cloud, const CentroidMinCutParams& params,
                                 CentroidMinCutReport* report) {
  params.validate();
  if (cloud.size() == 0) throw Error("", "points", "the cloud is empty");
  cloud.validate("cloud");
  const auto t0 = std::chrono::steady_clock::now();
  CentroidMinCutReport rep;
  Eigen::Vector3d sum(0, 0, 0);
  for (const auto& p : cloud.points) sum += p.cast<double>();
  rep.centroid = (sum / double(cloud.size())).cast<float>();
  const double R2 = params.radius * params.radius;
  std::vector<std::uint8_t> inside(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    inside[i] = (cloud.points[i] - rep.centroid).squaredNorm() <= R2;
    rep.seeds += inside[i];
  }
  if (rep.seeds == 0)
    throw Error("", "--radius", "no point lies within " + std::to_string(params.radius) +
                                    " of the cloud's centroid: no object seed (a larger radius?)");
  std::vector<int> labels(cloud.size(), 0);
  if (params.solver == MinCutSolver::MaxFlow) {
    const KnnGraph knn = knn_graph(cloud, params.neighbours);
    rep.sigma = params.sigma > 0 ? params.sigma : knn.mean_distance;
    if (!(rep.sigma > 0)) throw Error("", "--sigma", "the points coincide: the mean neighbour distance is 0");
    graphcut::FlowGraph g;
    g.source.resize(cloud.size());
    g.sink.resize(cloud.size());
    // Source side = object. Cost of object 1 - P_obj (the sink link, cut when the point stays with the
    // source), cost of background P_obj (the source link).
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      g.source[i] = inside[i] ? 1.0 : 0.0;
      g.sink[i] = inside[i] ? 0.0 : 1.0;
    }
    g.edges.reserve(knn.pairs.size());
    for (const auto& p : knn.pairs) {
      const double w = params.lambda * std::exp(-double(p.distance) / rep.sigma);
      g.edges.push_back({p.i, p.j, w, w});
    }
    std::vector<std::uint8_t> sink_side;
    rep.flow = graphcut::max_flow(g, &sink_side);
    for (std::size_t i = 0; i < cloud.size(); ++i) labels[i] = sink_side[i] ? 0 : 1;
  } else {
    if (cloud.size() < std::size_t(params.neighbours) + 1)
      throw Error("", "points", "the cloud has fewer points than k + 1");
    // PCL measures the unary across its z axis: put the cloud's up axis there.
    const int a = (params.up + 1) % 3, b = (params.up + 2) % 3, c = params.up;
    pcl::PointCloud<pcl::PointXYZ>::Ptr pc(new pcl::PointCloud<pcl::PointXYZ>);
    pc->reserve(cloud.size());
    for (const auto& p : cloud.points) pc->push_back(pcl::PointXYZ(p[a], p[b], p[c]));
    if (params.sigma > 0) {
      rep.sigma = params.sigma;
    } else {
      rep.sigma = knn_graph(cloud, params.neighbours).mean_distance;
      if (!(rep.sigma > 0)) throw Error("", "--sigma", "the points coincide: the mean neighbour distance is 0");
    }
    pcl::PointCloud<pcl::PointXYZ>::Ptr fg(new pcl::PointCloud<pcl::PointXYZ>);
    fg->push_back(pcl::PointXYZ(rep.centroid[a], rep.centroid[b], rep.centroid[c]));
    pcl::MinCutSegmentation<pcl::PointXYZ> seg;
    seg.setInputCloud(pc);
    seg.setForegroundPoints(fg);
    seg.setSigma(rep.sigma);
    seg.setRadius(params.radius);
    seg.setNumberOfNeighbours(static_cast<unsigned>(params.neighbours));
    seg.setSourceWeight(params.source_weight);
    std::vector<pcl::PointIndices> clusters;
    seg.extract(clusters);
    if (clusters.size() != 2) throw Error("", "min-cut", "pcl::MinCutSegmentation returned no segmentation");
    for (const auto i : clusters[1].indices) labels[std::size_t(i)] = 1;
    rep.flow = seg.getMaxFlow();
  }
  rep.seconds = seconds_since(t0);
  if (report) *report = rep;
  return labels;
}

}  // namespace smseg::cloud
