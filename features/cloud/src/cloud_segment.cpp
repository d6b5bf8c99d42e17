// The PCL part of cloud_segment.hpp: cloud files, k-nearest-neighbour graphs, centroid min-cut.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <vector>
#include <sstream>

#include <pcl/common/io.h>
#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
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

namespace smseg::features {

namespace {

bool has_field(const pcl::PCLPointCloud2& c, const std::string& name) {
  return std::any_of(c.fields.begin(), c.fields.end(), [&](const pcl::PCLPointField& f) { return f.name == name; });
}

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

/// PCL 1.13's readers crash on some malformed files: check the header ourselves first. PCD: FIELDS,
/// SIZE, TYPE, WIDTH, HEIGHT, POINTS (> 0) and DATA lines; PLY: the "ply" magic and an end_header.
/// The header must lie in the first 64 KiB (ours are a few hundred bytes), so that a file with no line
/// breaks is not read whole by the check.
/// `text` with every byte that is not printable ASCII shown as '?', for an error line.
std::string printable(std::string text) {
  for (char& c : text)
    if (c < 0x20 || c > 0x7e) c = '?';
  return text;
}

void check_header(const fs::path& path, bool pcd) {
  constexpr std::size_t kMaxHeaderBytes = 64 * 1024;
  std::ifstream file(path, std::ios::binary);
  if (!file) throw Error(path.string(), "", "cannot be opened");
  std::string head(kMaxHeaderBytes, '\0');
  file.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(file.gcount()));
  std::istringstream in(head);
  std::string line;
  // A count the file cannot hold (every element takes at least a byte) is refused before PCL
  // allocates for it: "element vertex 4000000000" in a small file made it ask for 80 GB.
  std::error_code ec;
  const auto file_size = static_cast<long long>(fs::file_size(path, ec));
  const auto check_count = [&](long long count, const std::string& what) {
    if (count > file_size)
      throw Error(path.string(), what, "is " + std::to_string(count) + ", more than the file's " +
                                           std::to_string(file_size) + " bytes can hold");
  };
  if (!pcd) {
    if (!std::getline(in, line) || line.rfind("ply", 0) != 0) throw Error(path.string(), "", "not a PLY file (no \"ply\" line)");
    // PCL 1.13's PLYReader aborts (assertions) or misreads on headers it half-understands: a vertex
    // property it does not know ("uchar rfd"), a damaged property line ("property uchar property uchar
    // red"), colours without red (all found by fuzz_cloud). Only the header grammar PCL reads passes:
    // "format F 1.0", "element NAME COUNT", "property TYPE NAME" with a known vertex property of the
    // type PCL expects for it, comments; the colours come as the three of red, green, blue or not at all.
    static const std::set<std::string> formats = {"ascii", "binary_little_endian", "binary_big_endian"};
    static const std::set<std::string> float_types = {"float", "float32", "double", "float64"};
    static const std::set<std::string> byte_types = {"uchar", "uint8"};
    static const std::set<std::string> label_types = {"uint", "uint32", "int", "int32"};
    static const std::map<std::string, const std::set<std::string>*> vertex_properties = {
        {"x", &float_types},        {"y", &float_types},         {"z", &float_types},
        {"nx", &float_types},       {"ny", &float_types},        {"nz", &float_types},
        {"normal_x", &float_types}, {"normal_y", &float_types},  {"normal_z", &float_types},
        {"curvature", &float_types}, {"intensity", &float_types}, {"red", &byte_types},
        {"green", &byte_types},     {"blue", &byte_types},       {"alpha", &byte_types},
        {"rgb", &label_types},      {"rgba", &label_types},      {"label", &label_types}};
    const auto bad_line = [&](int n, const std::string& why) {
      throw Error(path.string(), "header", "line " + std::to_string(n + 2) + " (\"" + printable(line.substr(0, 40)) +
                                               "\"): " + why);
    };
    std::string element;
    std::set<std::string> properties;
    for (int n = 0; n < 200 && std::getline(in, line); ++n) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      std::istringstream ls(line);
      std::vector<std::string> words;
      for (std::string w; ls >> w;) words.push_back(w);
      if (words.empty()) bad_line(n, "is empty");
      const std::string& word = words[0];
      if (word == "comment" || word == "obj_info") continue;
      if (word == "end_header" && words.size() == 1) {
        const int colours = int(properties.count("red") + properties.count("green") + properties.count("blue"));
        if (colours != 0 && colours != 3)
          throw Error(path.string(), "element vertex", "has some of the colour properties red, green, blue but not all three");
        return;
      }
      if (word == "format") {
        if (words.size() != 3 || !formats.count(words[1]) || words[2] != "1.0") bad_line(n, "expected format ascii|binary_little_endian|binary_big_endian 1.0");
      } else if (word == "element") {
        long long count = -1;
        if (words.size() != 3 || !(std::istringstream(words[2]) >> count) || count < 0) bad_line(n, "expected element NAME COUNT");
        element = words[1];
        check_count(count, "element " + element);
        // An empty vertex list made PCL's conversion index an empty vector (UBSan, found by fuzz_cloud).
        if (element == "vertex" && count <= 0) throw Error(path.string(), "points", "the cloud is empty");
      } else if (word == "property") {
        if (element.empty()) bad_line(n, "a property before any element");
        if (element != "vertex") continue;  // other elements' properties are skipped by PCL
        if (words.size() != 3) bad_line(n, "expected property TYPE NAME (no lists in a vertex)");
        const auto known = vertex_properties.find(words[2]);
        if (known == vertex_properties.end())
          throw Error(path.string(), "element vertex", "property \"" + printable(words[2].substr(0, 40)) + "\" is not one this reader knows");
        if (!known->second->count(words[1])) bad_line(n, "property " + words[2] + " of a type this reader does not read");
        if (!properties.insert(words[2]).second) bad_line(n, "property " + words[2] + " given twice");
      } else {
        bad_line(n, "is not a PLY header line");
      }
    }
    throw Error(path.string(), "", "not a PLY file (no end_header)");
  }
  // PCL 1.13's PCDReader crashes or misreads on headers it half-understands: an unknown keyword (null
  // pointer), an overflowing SIZE (gigabytes allocated), header lines repeated after a damaged DATA
  // line (use after free); all found by fuzz_cloud. Only the header PCL writes passes: each keyword
  // once, in the format's order, FIELDS/SIZE/TYPE/COUNT of the same length with the format's values,
  // WIDTH x HEIGHT = POINTS, and DATA ascii, binary or binary_compressed.
  static const std::vector<std::string> order = {"VERSION", "FIELDS", "SIZE",      "TYPE",   "COUNT",
                                                 "WIDTH",   "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
  static const std::set<std::string> sizes = {"1", "2", "4", "8"}, types = {"I", "U", "F"},
                                     data_kinds = {"ascii", "binary", "binary_compressed"};
  const auto bad = [&](const std::string& key, const std::string& why) {
    throw Error(path.string(), key, why);
  };
  const auto whole_number = [](const std::string& v, std::size_t digits) {
    return !v.empty() && v.size() <= digits && v.find_first_not_of("0123456789") == std::string::npos &&
           !(v.size() > 1 && v.front() == '0');
  };
  std::size_t next = 0, fields = 0;
  long long width = -1, height = -1, points = -1;
  for (int n = 0; n < 100 && next < order.size() && std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    std::vector<std::string> values;
    for (std::string v; ls >> v;) values.push_back(v);
    if (key != order[next]) {
      // VERSION, COUNT and VIEWPOINT may be left out; the others come in the format's order.
      while (next < order.size() && key != order[next] &&
             (order[next] == "VERSION" || order[next] == "COUNT" || order[next] == "VIEWPOINT"))
        ++next;
      if (next == order.size() || key != order[next])
        bad("", "not a PCD file (header line \"" + printable(line.substr(0, 40)) + "\" out of place or unknown)");
    }
    ++next;
    if (key == "FIELDS") fields = values.size();
    if (key == "FIELDS" && (fields == 0 || fields > 64)) bad(key, "expected 1 to 64 fields");
    if (key == "SIZE" || key == "TYPE" || key == "COUNT") {
      if (values.size() != fields) bad(key, "has " + std::to_string(values.size()) + " values for " + std::to_string(fields) + " fields");
      for (const std::string& v : values) {
        const bool ok = key == "SIZE" ? sizes.count(v) > 0 : key == "TYPE" ? types.count(v) > 0 : whole_number(v, 4) && v != "0";
        if (!ok) bad(key, "\"" + printable(v.substr(0, 20)) + "\" is not a value of the PCD format");
      }
    }
    if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS") {
      if (values.size() != 1 || !whole_number(values[0], 12)) bad(key, "expected one whole number");
      const long long v = std::stoll(values[0]);
      check_count(v, key);
      (key == "WIDTH" ? width : key == "HEIGHT" ? height : points) = v;
    }
    if (key == "DATA" && (values.size() != 1 || !data_kinds.count(values[0])))
      bad(key, "expected ascii, binary or binary_compressed");
  }
  if (next < order.size()) bad("", "not a PCD file (its header ends before DATA)");
  if (width < 0 || height < 0 || points < 0) bad("", "not a PCD file (no WIDTH, HEIGHT or POINTS)");
  if (width * height != points) bad("POINTS", "is " + std::to_string(points) + ", not WIDTH x HEIGHT");
  if (points <= 0) throw Error(path.string(), "points", "the cloud is empty");
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

ColouredCloud read_coloured_cloud(const fs::path& path) {
  const std::string ext = path.extension().string();
  if (ext != ".pcd" && ext != ".ply") throw Error(path.string(), "", "a point cloud file must end in .pcd or .ply");
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw Error(path.string(), "", "no such file");
  // PCL reads the whole file into memory: one larger than any cloud we write is refused first.
  if (fs::file_size(path, ec) > kMaxLargeFileBytes)
    throw Error(path.string(), "", "is larger than the " + std::to_string(kMaxLargeFileBytes / kMiB) + " MiB this reader accepts");
  check_header(path, ext == ".pcd");
  pcl::PCLPointCloud2 raw;
  const auto level = pcl::console::getVerbosityLevel();
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  const int rc = ext == ".pcd" ? pcl::io::loadPCDFile(path.string(), raw) : pcl::io::loadPLYFile(path.string(), raw);
  pcl::console::setVerbosityLevel(level);
  if (rc < 0) throw Error(path.string(), "", "PCL cannot read this " + ext.substr(1) + " file");
  if (!has_field(raw, "x") || !has_field(raw, "y") || !has_field(raw, "z"))
    throw Error(path.string(), "fields", "the cloud has no x, y, z fields");
  ColouredCloud c;
  pcl::PointCloud<pcl::PointXYZ> xyz;
  pcl::fromPCLPointCloud2(raw, xyz);
  if (xyz.empty()) throw Error(path.string(), "points", "the cloud is empty");
  c.points.reserve(xyz.size());
  for (const auto& p : xyz) c.points.emplace_back(p.x, p.y, p.z);
  if (has_field(raw, "rgb") || has_field(raw, "rgba")) {
    pcl::PointCloud<pcl::PointXYZRGB> rgb;
    pcl::fromPCLPointCloud2(raw, rgb);
    for (const auto& p : rgb) c.colours.push_back({p.r, p.g, p.b});
  }
  if (has_field(raw, "label")) {
    pcl::PointCloud<pcl::Label> lab;
    pcl::fromPCLPointCloud2(raw, lab);
    for (const auto& p : lab) c.labels.push_back(p.label >= 255u ? -1 : static_cast<int>(p.label));
  }
  c.validate(path.string());
  return c;
}

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
    FlowGraph g;
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
    rep.flow = max_flow(g, &sink_side);
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

}  // namespace smseg::features
