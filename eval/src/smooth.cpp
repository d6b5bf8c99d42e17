#include "smseg/eval/smooth.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>

#include <opencv2/core.hpp>

#include "smseg/common/error.hpp"
#include "smseg/graphcut/graphcut.hpp"

namespace smseg::eval {

namespace {

double squared_difference(const cv::Mat& image, int y0, int x0, int y1, int x1) {
  if (image.type() == CV_8UC1) {
    const double d = double(image.at<std::uint8_t>(y0, x0)) - double(image.at<std::uint8_t>(y1, x1));
    return d * d;
  }
  const cv::Vec3b a = image.at<cv::Vec3b>(y0, x0), b = image.at<cv::Vec3b>(y1, x1);
  double s = 0;
  for (int c = 0; c < 3; ++c) s += (double(a[c]) - double(b[c])) * (double(a[c]) - double(b[c]));
  return s;
}

// Forward neighbour offsets (dy, dx): each unordered pair once.
struct Offset {
  int dy, dx;
  double inv_dist;
};
std::vector<Offset> offsets(int connectivity) {
  std::vector<Offset> o = {{0, 1, 1.0}, {1, 0, 1.0}};
  if (connectivity == 8) {
    o.push_back({1, 1, 1.0 / std::sqrt(2.0)});
    o.push_back({1, -1, 1.0 / std::sqrt(2.0)});
  }
  return o;
}

void check_image(const cv::Mat& image) {
  if (image.empty() || (image.type() != CV_8UC1 && image.type() != CV_8UC3))
    throw Error("", "image", "the contrast term needs an 8-bit greyscale or colour image");
}

// -log max(p, p_min), capped at cap = -log p_min: the logarithm only where it is below the cap (most
// classes of a pixel are not), same value as std::min(cap, -std::log(std::max(p_min, p))).
double capped_cost(double p, double p_min, double cap) { return p <= p_min ? cap : std::min(cap, -std::log(p)); }

}  // namespace

std::string to_string(SmoothMethod m) { return m == SmoothMethod::GraphCut ? "graphcut" : "none"; }

SmoothMethod smooth_method_from_string(const std::string& s, const std::string& option) {
  if (s == "none") return SmoothMethod::None;
  if (s == "graphcut") return SmoothMethod::GraphCut;
  throw Error("", option, "\"" + s + "\" is not a smoothing method (none or graphcut)");
}

void SmoothOptions::validate() const {
  if (!(lambda >= 0) || !std::isfinite(lambda)) throw Error("", "--lambda", "must be a finite number >= 0");
  if (connectivity != 4 && connectivity != 8) throw Error("", "--connectivity", "must be 4 or 8");
  if (cycles < 1 || cycles > 100) throw Error("", "--smooth-cycles", "must be 1..100");
  if (!(p_min > 0 && p_min < 1)) throw Error("", "p_min", "must be in (0, 1)");
  if (label_window < 0 || label_window > 1000) throw Error("", "--smooth-window", "must be 0..1000 pixels");
}

nlohmann::json SmoothOptions::to_json() const {
  if (!enabled()) return {{"method", "none"}};
  return {{"method", to_string(method)},
          {"lambda", lambda},
          {"connectivity", connectivity},
          {"cycles", cycles},
          {"p_min", p_min},
          {"label_window", label_window}};
}

double contrast_beta(const cv::Mat& image, int connectivity) {
  check_image(image);
  double sum = 0;
  std::size_t pairs = 0;
  for (const Offset& o : offsets(connectivity))
    for (int y = 0; y + o.dy < image.rows; ++y)
      for (int x = std::max(0, -o.dx); x < image.cols && x + o.dx < image.cols && x + o.dx >= 0; ++x) {
        sum += squared_difference(image, y, x, y + o.dy, x + o.dx);
        ++pairs;
      }
  const double mean = pairs ? sum / double(pairs) : 0.0;
  return mean > 0 ? 1.0 / (2.0 * mean) : 0.0;
}

namespace {

// exp(-beta d^2) for every grey-level difference d: a greyscale frame's edges take their contrast term
// from this table instead of one exp per edge (same values: same argument).
std::array<double, 256> grey_contrast_table(double beta) {
  std::array<double, 256> t{};
  for (int d = 0; d < 256; ++d) t[std::size_t(d)] = std::exp(-beta * (double(d) * double(d)));
  return t;
}

/// Calls f(i, j, weight) for every edge of the image grid (each unordered neighbour pair once, i < j):
/// the contrast-sensitive Potts weight lambda exp(-beta (I_i - I_j)^2) / dist(i, j).
template <class F>
void for_each_contrast_edge(const cv::Mat& image, const SmoothOptions& opt, double beta, F&& f) {
  const int W = image.cols, H = image.rows;
  const auto offs = offsets(opt.connectivity);
  const bool grey = image.type() == CV_8UC1;
  const std::array<double, 256> table = grey_contrast_table(beta);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (const Offset& o : offs) {
        const int y1 = y + o.dy, x1 = x + o.dx;
        if (y1 >= H || x1 < 0 || x1 >= W) continue;
        const double contrast =
            grey ? table[std::size_t(std::abs(int(image.at<std::uint8_t>(y, x)) - int(image.at<std::uint8_t>(y1, x1))))]
                 : std::exp(-beta * squared_difference(image, y, x, y1, x1));
        f(y * W + x, y1 * W + x1, opt.lambda * o.inv_dist * contrast);
      }
}

/// A pixel's distribution values d (C of them), checked: Error naming the pixel (index i) on a negative
/// or non-finite value. Returns their sum.
double checked_sum(const float* d, std::size_t C, std::size_t i) {
  double s = 0;
  for (std::size_t c = 0; c < C; ++c) {
    if (!(d[c] >= 0) || !std::isfinite(d[c]))
      throw Error("", "distributions", "pixel " + std::to_string(i) + " has a negative or non-finite value");
    s += d[c];
  }
  return s;
}

/// The capped unary cost of value v of a pixel whose values sum to s (an all-zero pixel is uniform).
double unary_cost(float v, double s, std::size_t C, double p_min, double cap) {
  return s > 0 ? capped_cost(double(v) / s, p_min, cap) : -std::log(1.0 / double(C));
}

/// The capped unary costs (out[0..C)) of pixel i from its C distribution values d.
void pixel_costs(const float* d, std::size_t C, std::size_t i, double p_min, double cap, double* out) {
  const double s = checked_sum(d, C, i);
  for (std::size_t c = 0; c < C; ++c) out[c] = unary_cost(d[c], s, C, p_min, cap);
}

// Working memory kept per thread from frame to frame (the energy's arrays and the max-flow graph):
// fresh multi-megabyte buffers per frame cost more in page faults than the cuts themselves.
struct SmoothCache {
  features::PottsEnergy e;
  features::ExpansionSolver solver;
  std::vector<int> labelling;
  // Label window only: per pixel, the MAP label, its cost, the sum of the pixel's values, the energy
  // node (-1: held at its MAP label) and the labels it may take (LabelSets); per node, the pixel and the
  // weight of its edges to other nodes.
  std::vector<std::uint8_t> map;
  std::vector<double> map_cost, sum;
  std::vector<int> node_of, pixel_of;
  std::vector<double> incident;
  std::vector<std::uint64_t> near, prefix, suffix;
};

/// The whole frame's energy: a node per pixel, an edge per neighbour pair.
void fill_pixel_energy(std::span<const float> dists, std::size_t C, const cv::Mat& image, const SmoothOptions& opt,
                       double beta, features::PottsEnergy& e) {
  const std::size_t n = image.total();
  const double cap = -std::log(opt.p_min);
  e.nodes = static_cast<int>(n);
  e.labels = static_cast<int>(C);
  e.unary.resize(n * C);
  e.edges.clear();
  for (std::size_t i = 0; i < n; ++i) pixel_costs(dists.data() + i * C, C, i, opt.p_min, cap, e.unary.data() + i * C);
  if (opt.lambda > 0) {
    e.edges.reserve(n * offsets(opt.connectivity).size());
    for_each_contrast_edge(image, opt, beta, [&](int i, int j, double w) { e.edges.push_back({i, j, w}); });
  }
}

/// A set of labels per pixel, as bits: label c is bit c % 64 of word c / 64, and word w of every pixel
/// lies in plane w (`bits[w * n + i]`), so that one plane is a frame of 64-bit words.
struct LabelSets {
  std::uint64_t* bits;
  std::size_t n, planes;
  static std::size_t planes_for(std::size_t labels) { return (labels + 63) / 64; }
  bool has(std::size_t i, std::size_t c) const { return (bits[(c >> 6) * n + i] >> (c & 63)) & 1; }
  int count(std::size_t i) const {
    int labels = 0;
    for (std::size_t p = 0; p < planes; ++p) labels += std::popcount(bits[p * n + i]);
    return labels;
  }
};

/// ORs each element with its neighbours within `radius` along `lines` lines of `length` elements `step`
/// apart (the lines `line_step` apart), clipped to the line. van Herk / Gil-Werman: ORs of prefixes and
/// suffixes within blocks of 2 radius + 1 elements, so the cost does not grow with the radius.
void or_dilate_lines(std::uint64_t* data, int lines, int length, std::ptrdiff_t step, std::ptrdiff_t line_step,
                     int radius, std::vector<std::uint64_t>& prefix, std::vector<std::uint64_t>& suffix) {
  const int k = 2 * radius + 1, last_block = (length - 1) / k * k;
  prefix.resize(std::size_t(length));
  suffix.resize(std::size_t(length));
  for (int l = 0; l < lines; ++l) {
    std::uint64_t* line = data + l * line_step;
    auto at = [&](int x) -> std::uint64_t& { return line[x * step]; };
    for (int start = 0; start < length; start += k) {
      const int end = std::min(start + k, length);
      prefix[std::size_t(start)] = at(start);
      for (int x = start + 1; x < end; ++x) prefix[std::size_t(x)] = prefix[std::size_t(x) - 1] | at(x);
      suffix[std::size_t(end) - 1] = at(end - 1);
      for (int x = end - 2; x >= start; --x) suffix[std::size_t(x)] = suffix[std::size_t(x) + 1] | at(x);
    }
    // The window [a, b] is the ends of two blocks, or one block (a at its start), or, clipped at the
    // line's end, the end of the last block.
    for (int x = 0; x < length; ++x) {
      const int a = x - radius, b = std::min(x + radius, length - 1);
      if (a < 0) at(x) = prefix[std::size_t(b)];
      else if (a >= last_block) at(x) = suffix[std::size_t(a)];
      else at(x) = suffix[std::size_t(a)] | prefix[std::size_t(b)];
    }
  }
}

/// Which labels each pixel may take under the label window, into k.near: label c within `radius` pixels
/// (Chebyshev distance) of a pixel whose MAP label is c. Returns the sets.
LabelSets labels_near(std::size_t C, int W, int H, int radius, SmoothCache& k) {
  const std::size_t n = k.map.size(), planes = LabelSets::planes_for(C);
  k.near.assign(planes * n, 0);
  for (std::size_t i = 0; i < n; ++i) k.near[(k.map[i] >> 6) * n + i] = std::uint64_t(1) << (k.map[i] & 63);
  for (std::size_t p = 0; p < planes; ++p) {
    std::uint64_t* plane = k.near.data() + p * n;
    or_dilate_lines(plane, H, W, 1, W, radius, k.prefix, k.suffix);  // along the rows, then the columns
    or_dilate_lines(plane, W, H, W, 1, radius, k.prefix, k.suffix);
  }
  return {k.near.data(), n, planes};
}

/// Per pixel, the MAP label (the largest value, ties to the lowest label), its cost and the values' sum.
void map_labels(std::span<const float> dists, std::size_t C, std::size_t n, const SmoothOptions& opt,
                SmoothCache& k) {
  const double cap = -std::log(opt.p_min);
  k.map.resize(n);
  k.map_cost.resize(n);
  k.sum.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float* d = dists.data() + i * C;
    const double s = checked_sum(d, C, i);
    const auto m = std::size_t(std::max_element(d, d + C) - d);
    k.map[i] = static_cast<std::uint8_t>(m);
    k.map_cost[i] = unary_cost(d[m], s, C, opt.p_min, cap);
    k.sum[i] = s;
  }
}

/// A node per pixel that may take more than one label (k.node_of, k.pixel_of). Returns the pixel-label
/// pairs allowed, summed over the pixels.
std::int64_t list_nodes(const LabelSets& near, SmoothCache& k) {
  const std::size_t n = near.n;
  k.node_of.assign(n, -1);
  k.pixel_of.clear();
  std::int64_t allowed = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const int count = near.count(i);
    allowed += count;
    if (count > 1) {
      k.node_of[i] = static_cast<int>(k.pixel_of.size());
      k.pixel_of.push_back(static_cast<int>(i));
    }
  }
  return allowed;
}

/// The label window's energy: a node per pixel that may take more than one label (the others are held
/// at their MAP label, so their edges to nodes become unary costs of the nodes, and the rest of their
/// energy a constant), an edge per neighbour pair of nodes. A label outside a node's window costs more
/// than every other label of the node plus all its edges weigh: no expansion move gives it to the node,
/// whatever label the node holds, and the solver does not list the node for it. Fills the cache's
/// per-pixel arrays and the starting labelling (the MAP labels); returns the energy of the held pixels,
/// and the pixel-label pairs allowed in `allowed`.
double fill_window_energy(std::span<const float> dists, std::size_t C, const cv::Mat& image, const SmoothOptions& opt,
                          double beta, SmoothCache& k, std::int64_t& allowed) {
  const std::size_t n = image.total();
  const double cap = -std::log(opt.p_min);
  map_labels(dists, C, n, opt, k);
  const LabelSets near = labels_near(C, image.cols, image.rows, opt.label_window, k);
  allowed = list_nodes(near, k);
  features::PottsEnergy& e = k.e;
  const std::size_t nodes = k.pixel_of.size();
  e.nodes = static_cast<int>(nodes);
  e.labels = static_cast<int>(C);
  e.unary.assign(nodes * C, 0.0);  // the costs of labels outside the window are set below
  e.edges.clear();
  k.incident.assign(nodes, 0.0);
  double held = 0;
  for (std::size_t v = 0; v < nodes; ++v) {
    const auto i = std::size_t(k.pixel_of[v]);
    const float* d = dists.data() + i * C;
    for (std::size_t c = 0; c < C; ++c)
      if (near.has(i, c)) e.unary[v * C + c] = unary_cost(d[c], k.sum[i], C, opt.p_min, cap);
  }
  for (std::size_t i = 0; i < n; ++i)
    if (k.node_of[i] < 0) held += k.map_cost[i];
  auto hold_edge = [&](int node, int held_pixel, double w) {  // the node pays w unless it takes that label
    double* u = e.unary.data() + std::size_t(node) * C;
    for (std::size_t c = 0; c < C; ++c)
      if (c != k.map[std::size_t(held_pixel)]) u[c] += w;
  };
  if (opt.lambda > 0)
    for_each_contrast_edge(image, opt, beta, [&](int i, int j, double w) {
      const int vi = k.node_of[std::size_t(i)], vj = k.node_of[std::size_t(j)];
      if (vi >= 0 && vj >= 0) {
        e.edges.push_back({vi, vj, w});
        k.incident[std::size_t(vi)] += w;
        k.incident[std::size_t(vj)] += w;
      } else if (vi >= 0) {
        hold_edge(vi, j, w);
      } else if (vj >= 0) {
        hold_edge(vj, i, w);
      } else if (k.map[std::size_t(i)] != k.map[std::size_t(j)]) {
        held += w;
      }
    });
  k.labelling.resize(nodes);
  for (std::size_t v = 0; v < nodes; ++v) {
    const auto i = std::size_t(k.pixel_of[v]);
    double* u = e.unary.data() + v * C;
    double highest = u[k.map[i]];
    for (std::size_t c = 0; c < C; ++c)
      if (near.has(i, c)) highest = std::max(highest, u[c]);
    for (std::size_t c = 0; c < C; ++c)
      if (!near.has(i, c)) u[c] = highest + k.incident[v] + 1.0;
    k.labelling[v] = k.map[i];
  }
  return held;
}

void check_sizes(std::span<const float> dists, int classes, const cv::Mat& image) {
  check_image(image);
  if (classes < 1 || classes > 255) throw Error("", "classes", "must be 1..255");
  const std::size_t n = image.total(), C = std::size_t(classes);
  if (dists.size() != n * C)
    throw Error("", "distributions", std::to_string(dists.size()) + " values for a " + std::to_string(image.cols) +
                                         "x" + std::to_string(image.rows) + " image of " + std::to_string(classes) +
                                         " classes");
}

}  // namespace

cv::Mat smooth_labels(std::span<const float> dists, int classes, const cv::Mat& image, const SmoothOptions& opt,
                      SmoothReport* report) {
  opt.validate();
  check_sizes(dists, classes, image);
  const std::size_t n = image.total(), C = std::size_t(classes);
  thread_local SmoothCache cache;
  SmoothReport rep;
  rep.beta = contrast_beta(image, opt.connectivity);
  cv::Mat out(image.rows, image.cols, CV_8UC1);
  features::ExpansionReport r;
  double held = 0;
  if (opt.label_window == 0) {
    fill_pixel_energy(dists, C, image, opt, rep.beta, cache.e);
    rep.allowed_labels = std::int64_t(n * C);
    cache.labelling.clear();  // the solver starts from the MAP labels
    r = cache.solver.solve(cache.e, cache.labelling, {.max_cycles = opt.cycles});
    for (std::size_t i = 0; i < n; ++i) out.data[i] = static_cast<std::uint8_t>(cache.labelling[i]);
  } else {
    held = fill_window_energy(dists, C, image, opt, rep.beta, cache, rep.allowed_labels);
    r = cache.solver.solve(cache.e, cache.labelling, {.max_cycles = opt.cycles});
    std::copy(cache.map.begin(), cache.map.end(), out.data);
    for (std::size_t v = 0; v < cache.pixel_of.size(); ++v)
      out.data[cache.pixel_of[v]] = static_cast<std::uint8_t>(cache.labelling[v]);
  }
  rep.energy_before = held + r.initial_energy;
  rep.energy_after = held + r.energy;
  rep.cycles = r.cycles;
  rep.moves = r.moves;
  rep.graph_nodes = r.graph_nodes;
  if (report) *report = rep;
  return out;
}

cv::Mat smooth_frame(const forest::Classifier& classifier, const forest::FrameData& frame, const SmoothOptions& opt,
                     double* classify_seconds, double* smooth_seconds, SmoothReport* report) {
  if (!frame.gray) throw Error("", "--smooth", "the frame has no greyscale image for the contrast term");
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = std::size_t(frame.width) * std::size_t(frame.height);
  std::vector<std::uint8_t> map(n);
  std::vector<float> dists(n * std::size_t(classifier.num_classes()));
  classifier.classify_frame(frame, map, dists);
  const auto t1 = std::chrono::steady_clock::now();
  const cv::Mat gray(frame.height, frame.width, CV_8UC1, const_cast<std::uint8_t*>(frame.gray));
  cv::Mat labels = smooth_labels(dists, classifier.num_classes(), gray, opt, report);
  const auto t2 = std::chrono::steady_clock::now();
  if (classify_seconds) *classify_seconds = std::chrono::duration<double>(t1 - t0).count();
  if (smooth_seconds) *smooth_seconds = std::chrono::duration<double>(t2 - t1).count();
  return labels;
}

}  // namespace smseg::eval
