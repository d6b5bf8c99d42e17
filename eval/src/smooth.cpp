#include "smseg/eval/smooth.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

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
}

nlohmann::json SmoothOptions::to_json() const {
  if (!enabled()) return {{"method", "none"}};
  return {{"method", to_string(method)},
          {"lambda", lambda},
          {"connectivity", connectivity},
          {"cycles", cycles},
          {"p_min", p_min}};
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

/// The contrast-sensitive Potts edges of the image grid, each unordered neighbour pair once.
void add_contrast_edges(const cv::Mat& image, const SmoothOptions& opt, double beta, features::PottsEnergy& e) {
  const int W = image.cols, H = image.rows;
  const auto offs = offsets(opt.connectivity);
  const bool grey = image.type() == CV_8UC1;
  const std::array<double, 256> table = grey_contrast_table(beta);
  e.edges.reserve(std::size_t(W) * std::size_t(H) * offs.size());
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (const Offset& o : offs) {
        const int y1 = y + o.dy, x1 = x + o.dx;
        if (y1 >= H || x1 < 0 || x1 >= W) continue;
        const double contrast =
            grey ? table[std::size_t(std::abs(int(image.at<std::uint8_t>(y, x)) - int(image.at<std::uint8_t>(y1, x1))))]
                 : std::exp(-beta * squared_difference(image, y, x, y1, x1));
        e.edges.push_back({y * W + x, y1 * W + x1, opt.lambda * o.inv_dist * contrast});
      }
}

}  // namespace

cv::Mat smooth_labels(std::span<const float> dists, int classes, const cv::Mat& image, const SmoothOptions& opt,
                      SmoothReport* report) {
  opt.validate();
  check_image(image);
  if (classes < 1 || classes > 255) throw Error("", "classes", "must be 1..255");
  const int W = image.cols, H = image.rows;
  const std::size_t n = std::size_t(W) * std::size_t(H), C = std::size_t(classes);
  if (dists.size() != n * C)
    throw Error("", "distributions", std::to_string(dists.size()) + " values for a " + std::to_string(W) + "x" +
                                         std::to_string(H) + " image of " + std::to_string(classes) + " classes");
  // Working memory kept per thread from frame to frame (the energy's arrays and the max-flow graph):
  // fresh multi-megabyte buffers per frame cost more in page faults than the cuts themselves.
  struct Cache {
    features::PottsEnergy e;
    features::ExpansionSolver solver;
    std::vector<int> labelling;
  };
  thread_local Cache cache;
  features::PottsEnergy& e = cache.e;
  e.nodes = static_cast<int>(n);
  e.labels = classes;
  e.unary.resize(n * C);
  e.edges.clear();
  const double cap = -std::log(opt.p_min);
  for (std::size_t i = 0; i < n; ++i) {
    const float* d = dists.data() + i * C;
    double s = 0;
    for (std::size_t c = 0; c < C; ++c) {
      if (!(d[c] >= 0) || !std::isfinite(d[c]))
        throw Error("", "distributions", "pixel " + std::to_string(i) + " has a negative or non-finite value");
      s += d[c];
    }
    for (std::size_t c = 0; c < C; ++c)
      e.unary[i * C + c] = s > 0 ? capped_cost(double(d[c]) / s, opt.p_min, cap) : -std::log(1.0 / double(C));
  }
  SmoothReport rep;
  rep.beta = contrast_beta(image, opt.connectivity);
  if (opt.lambda > 0) add_contrast_edges(image, opt, rep.beta, e);
  std::vector<int>& labelling = cache.labelling;
  labelling.clear();
  const features::ExpansionReport r = cache.solver.solve(e, labelling, {.max_cycles = opt.cycles});
  rep.energy_before = r.initial_energy;
  rep.energy_after = r.energy;
  rep.cycles = r.cycles;
  rep.moves = r.moves;
  rep.graph_nodes = r.graph_nodes;
  if (report) *report = rep;
  cv::Mat out(H, W, CV_8UC1);
  for (std::size_t i = 0; i < n; ++i) out.data[i] = static_cast<std::uint8_t>(labelling[i]);
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
