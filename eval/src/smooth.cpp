#include "smseg/eval/smooth.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>

#include <opencv2/core.hpp>
#include <tbb/parallel_for.h>

#include "smseg/common/error.hpp"
#include "smseg/common/names.hpp"
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

constexpr std::array<EnumName<SmoothMethod>, 2> kSmoothMethodNames{
    {{SmoothMethod::None, "none"}, {SmoothMethod::GraphCut, "graphcut"}}};

std::string to_string(SmoothMethod m) { return name_of(kSmoothMethodNames, m); }
SmoothMethod smooth_method_from_string(const std::string& s, const std::string& option) {
  return value_named(kSmoothMethodNames, s, option);
}

void SmoothOptions::validate() const {
  if (!(lambda >= 0) || !std::isfinite(lambda)) throw Error("", "--lambda", "must be a finite number >= 0");
  if (connectivity != 4 && connectivity != 8) throw Error("", "--connectivity", "must be 4 or 8");
  if (cycles < 1 || cycles > 100) throw Error("", "--smooth-cycles", "must be 1..100");
  if (!(p_min > 0 && p_min < 1)) throw Error("", "p_min", "must be in (0, 1)");
  if (label_window < 0 || label_window > 1000) throw Error("", "--smooth-window", "must be 0..1000 pixels");
  if (bands < 1 || bands > 64) throw Error("", "--smooth-bands", "must be 1..64");
}

nlohmann::json SmoothOptions::to_json() const {
  if (!enabled()) return {{"method", "none"}};
  return {{"method", to_string(method)},
          {"lambda", lambda},
          {"connectivity", connectivity},
          {"cycles", cycles},
          {"p_min", p_min},
          {"label_window", label_window},
          {"bands", bands},
          {"contrast", contrast}};
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

/// Calls f(i, j, weight) for every edge of the image grid whose first end lies in rows [y_begin, y_end)
/// and for which need(i, j) holds (each unordered neighbour pair once, i < j): the contrast-sensitive
/// Potts weight lambda exp(-beta (I_i - I_j)^2) / dist(i, j), computed only for the edges needed.
template <class Need, class F>
void for_each_contrast_edge(const cv::Mat& image, const SmoothOptions& opt, double beta, int y_begin, int y_end,
                            Need&& need, F&& f) {
  const int W = image.cols, H = image.rows;
  const auto offs = offsets(opt.connectivity);
  const bool grey = image.type() == CV_8UC1;
  const std::array<double, 256> table = grey_contrast_table(beta);
  for (int y = std::max(0, y_begin); y < std::min(H, y_end); ++y)
    for (int x = 0; x < W; ++x)
      for (const Offset& o : offs) {
        const int y1 = y + o.dy, x1 = x + o.dx;
        if (y1 >= H || x1 < 0 || x1 >= W) continue;
        const int i = y * W + x, j = y1 * W + x1;
        if (!need(i, j)) continue;
        const double contrast =
            grey ? table[std::size_t(std::abs(int(image.at<std::uint8_t>(y, x)) - int(image.at<std::uint8_t>(y1, x1))))]
                 : std::exp(-beta * squared_difference(image, y, x, y1, x1));
        f(i, j, opt.lambda * o.inv_dist * contrast);
      }
}

/// Every edge of the image grid (see above).
template <class F>
void for_each_contrast_edge(const cv::Mat& image, const SmoothOptions& opt, double beta, F&& f) {
  for_each_contrast_edge(image, opt, beta, 0, image.rows, [](int, int) { return true; }, f);
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

// Working memory reused from frame to frame (the energy's arrays and the max-flow graph): fresh
// multi-megabyte buffers per frame cost more in page faults than the cuts themselves. Borrowed from a
// pool for one use rather than kept per thread: a thread waiting for its frame's bands may be handed
// another frame's bands meanwhile (TBB work stealing), which must not write into the waiting one's.
template <class T>
class Pool {
 public:
  class Lease {
   public:
    Lease(Pool& pool, std::unique_ptr<T> item) : pool_(pool), item_(std::move(item)) {}
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ~Lease() { pool_.give_back(std::move(item_)); }
    T& operator*() const { return *item_; }
    T* operator->() const { return item_.get(); }

   private:
    Pool& pool_;
    std::unique_ptr<T> item_;
  };
  Lease borrow() {
    std::lock_guard lock(mutex_);
    if (free_.empty()) return Lease(*this, std::make_unique<T>());
    std::unique_ptr<T> item = std::move(free_.back());
    free_.pop_back();
    return Lease(*this, std::move(item));
  }

 private:
  void give_back(std::unique_ptr<T> item) {
    std::lock_guard lock(mutex_);
    free_.push_back(std::move(item));
  }
  std::mutex mutex_;
  std::vector<std::unique_ptr<T>> free_;
};

// One energy and its solver: the whole frame's (no label window) or one band's.
struct SmoothCache {
  graphcut::PottsEnergy e;
  graphcut::ExpansionSolver solver;
  std::vector<int> labelling;
  // Label window only: per pixel of the band, its energy node (-1: held); per node, its pixel and the
  // weight of its edges to other nodes.
  std::vector<int> node_of, pixel_of;
  std::vector<double> incident;
};

// The label window's per-pixel arrays of a frame: the MAP label, its cost, the sum of the pixel's
// values, the labels it may take (LabelSets), and the labels after the bands and after the seams.
struct WindowCache {
  std::vector<std::uint8_t> map;
  std::vector<double> map_cost, sum;
  std::vector<std::uint64_t> near, prefix, suffix;
  std::vector<std::uint8_t> banded, seamed;
};

/// The whole frame's energy: a node per pixel, an edge per neighbour pair.
void fill_pixel_energy(std::span<const float> dists, std::size_t C, const cv::Mat& image, const SmoothOptions& opt,
                       double beta, graphcut::PottsEnergy& e) {
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
LabelSets labels_near(std::size_t C, int W, int H, int radius, WindowCache& k) {
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

/// Calls f(chunk, y0, y1) for the rows [y0, y1) of each of a fixed number of chunks of the frame, at
/// once on the TBB pool. Per-chunk results combined in chunk order do not depend on the thread count.
constexpr std::size_t kRowChunks = 16;
template <class F>
void for_row_chunks(int rows, F&& f) {
  tbb::parallel_for(std::size_t(0), kRowChunks, [&](std::size_t c) {
    f(c, int(std::size_t(rows) * c / kRowChunks), int(std::size_t(rows) * (c + 1) / kRowChunks));
  });
}

/// Per pixel, the MAP label (the largest value, ties to the lowest label), its cost and the values' sum;
/// Error naming the frame's first pixel with a negative or non-finite value.
void map_labels(std::span<const float> dists, std::size_t C, int W, int H, const SmoothOptions& opt,
                WindowCache& k) {
  const double cap = -std::log(opt.p_min);
  const std::size_t n = std::size_t(W) * std::size_t(H);
  k.map.resize(n);
  k.map_cost.resize(n);
  k.sum.resize(n);
  std::array<std::size_t, kRowChunks> bad;  // per chunk, its first pixel with a bad value, or n
  for_row_chunks(H, [&](std::size_t c, int y0, int y1) {
    bad[c] = n;
    for (std::size_t i = std::size_t(y0) * std::size_t(W); i < std::size_t(y1) * std::size_t(W); ++i) {
      const float* d = dists.data() + i * C;
      double s = 0;
      bool valid = true;  // as checked_sum judges
      for (std::size_t l = 0; l < C; ++l) {
        valid = valid && d[l] >= 0 && std::isfinite(d[l]);
        s += d[l];
      }
      if (!valid) {
        bad[c] = i;
        return;
      }
      const auto m = std::size_t(std::max_element(d, d + C) - d);
      k.map[i] = static_cast<std::uint8_t>(m);
      k.map_cost[i] = unary_cost(d[m], s, C, opt.p_min, cap);
      k.sum[i] = s;
    }
  });
  for (const std::size_t i : bad)  // the frame's first bad pixel, whatever the threads
    if (i < n) checked_sum(dists.data() + i * C, C, i);
}

/// A frame under the label window, read-only while its bands are solved.
struct WindowFrame {
  std::span<const float> dists;
  std::size_t C;
  const cv::Mat& image;
  const SmoothOptions& opt;
  double beta;
  const WindowCache& w;
  LabelSets near;
};

/// Rows [y0, y1) of the frame: the pixels one energy may relabel.
struct Band {
  int y0, y1;
};

/// A band's energy under the label window: a node per pixel of the band that may take more than one
/// label; every other pixel of the frame is held at its label in `start`, so its edges to nodes become
/// unary costs of the nodes (the rest of its energy is a constant, left out). A label outside a node's
/// window costs more than every other label of the node plus all its edges weigh: no expansion move
/// gives it to the node, whatever label the node holds, and the solver does not list the node for it.
/// The nodes start at their label in `start`.
void fill_band_energy(const WindowFrame& f, Band band, const std::uint8_t* start, SmoothCache& k) {
  const std::size_t C = f.C, W = std::size_t(f.image.cols);
  const std::size_t first = std::size_t(band.y0) * W, count = std::size_t(band.y1 - band.y0) * W;
  const double cap = -std::log(f.opt.p_min);
  k.node_of.assign(count, -1);
  k.pixel_of.clear();
  for (std::size_t i = first; i < first + count; ++i)
    if (f.near.count(i) > 1) {
      k.node_of[i - first] = static_cast<int>(k.pixel_of.size());
      k.pixel_of.push_back(static_cast<int>(i));
    }
  const auto node = [&](int i) {  // -1 outside the band (unsigned: rows above wrap to large values)
    const std::size_t r = std::size_t(i) - first;
    return r < count ? k.node_of[r] : -1;
  };
  graphcut::PottsEnergy& e = k.e;
  const std::size_t nodes = k.pixel_of.size();
  e.nodes = static_cast<int>(nodes);
  e.labels = static_cast<int>(C);
  e.unary.assign(nodes * C, 0.0);  // the costs of labels outside the window are set below
  e.edges.clear();
  k.incident.assign(nodes, 0.0);
  for (std::size_t v = 0; v < nodes; ++v) {
    const auto i = std::size_t(k.pixel_of[v]);
    const float* d = f.dists.data() + i * C;
    for (std::size_t c = 0; c < C; ++c)
      if (f.near.has(i, c)) e.unary[v * C + c] = unary_cost(d[c], f.w.sum[i], C, f.opt.p_min, cap);
  }
  auto hold_edge = [&](int v, int held_pixel, double w) {  // node v pays w unless it takes that label
    double* u = e.unary.data() + std::size_t(v) * C;
    for (std::size_t c = 0; c < C; ++c)
      if (c != start[std::size_t(held_pixel)]) u[c] += w;
  };
  if (f.opt.lambda > 0)  // the edges with an end in the band: from the row above it to its last row
    for_each_contrast_edge(
        f.image, f.opt, f.beta, band.y0 - 1, band.y1, [&](int i, int j) { return node(i) >= 0 || node(j) >= 0; },
        [&](int i, int j, double w) {
          const int vi = node(i), vj = node(j);
          if (vi >= 0 && vj >= 0) {
            e.edges.push_back({vi, vj, w});
            k.incident[std::size_t(vi)] += w;
            k.incident[std::size_t(vj)] += w;
          } else if (vi >= 0) {
            hold_edge(vi, j, w);
          } else {
            hold_edge(vj, i, w);
          }
        });
  k.labelling.resize(nodes);
  for (std::size_t v = 0; v < nodes; ++v) {
    const auto i = std::size_t(k.pixel_of[v]);
    double* u = e.unary.data() + v * C;
    double highest = u[start[i]];
    for (std::size_t c = 0; c < C; ++c)
      if (f.near.has(i, c)) highest = std::max(highest, u[c]);
    for (std::size_t c = 0; c < C; ++c)
      if (!f.near.has(i, c)) u[c] = highest + k.incident[v] + 1.0;
    k.labelling[v] = start[i];
  }
}

/// Alpha-expansion over one band from `start` (every pixel's label in it is within its window); the
/// band's nodes' labels go to `out`, which holds `start` elsewhere.
graphcut::ExpansionReport solve_band(const WindowFrame& f, Band band, const std::uint8_t* start, std::uint8_t* out,
                                     SmoothCache& k) {
  fill_band_energy(f, band, start, k);
  const graphcut::ExpansionReport r = k.solver.solve(k.e, k.labelling, {.max_cycles = f.opt.cycles});
  for (std::size_t v = 0; v < k.pixel_of.size(); ++v) out[k.pixel_of[v]] = static_cast<std::uint8_t>(k.labelling[v]);
  return r;
}

/// The whole frame's energy E(labels) (see smooth.hpp).
double frame_energy(const WindowFrame& f, const std::uint8_t* labels) {
  const double cap = -std::log(f.opt.p_min);
  const auto W = std::size_t(f.image.cols);
  std::array<double, kRowChunks> part;
  for_row_chunks(f.image.rows, [&](std::size_t c, int y0, int y1) {
    double e = 0;
    for (std::size_t i = std::size_t(y0) * W; i < std::size_t(y1) * W; ++i)
      e += labels[i] == f.w.map[i] ? f.w.map_cost[i]
                                   : unary_cost(f.dists[i * f.C + labels[i]], f.w.sum[i], f.C, f.opt.p_min, cap);
    if (f.opt.lambda > 0)
      for_each_contrast_edge(
          f.image, f.opt, f.beta, y0, y1, [&](int i, int j) { return labels[i] != labels[j]; },
          [&](int, int, double w) { e += w; });
    part[c] = e;
  });
  double e = 0;
  for (const double x : part) e += x;
  return e;
}

/// The frame cut into `count` bands of rows holding about as much of the moves' work each. That work
/// follows the pixel-label pairs a move may flip: a label of the pixel's window other than its MAP label
/// whose unary rise, log(p_map / p_c), is within the most a pixel's edges can weigh (the solver fixes the
/// others before the cut). They crowd where the forest is unsure, not only along the labels' borders.
/// (Weighing each pair by the pixel's own edges, from the image's contrast, cut CamVid frames at the
/// same rows.)
std::vector<Band> bands_of(const WindowFrame& f, int count) {
  const int W = f.image.cols, H = f.image.rows;
  double most_weight = 0;  // lambda times the sum of 1 / dist over a pixel's neighbours
  for (const Offset& o : offsets(f.opt.connectivity)) most_weight += 2 * f.opt.lambda * o.inv_dist;
  const double least_ratio = std::exp(-most_weight);
  std::vector<std::int64_t> before(std::size_t(H) + 1, 0);  // pairs in the rows above each row
  for_row_chunks(H, [&](std::size_t, int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      std::int64_t pairs = 0;
      for (std::size_t i = std::size_t(y) * std::size_t(W), end = i + std::size_t(W); i < end; ++i) {
        if (f.near.count(i) < 2) continue;
        const float* d = f.dists.data() + i * f.C;
        const double floor = double(d[f.w.map[i]]) * least_ratio;
        for (std::size_t c = 0; c < f.C; ++c) pairs += c != f.w.map[i] && f.near.has(i, c) && double(d[c]) >= floor;
      }
      before[std::size_t(y) + 1] = pairs;
    }
  });
  for (int y = 0; y < H; ++y) before[std::size_t(y) + 1] += before[std::size_t(y)];
  std::vector<Band> bands;
  int y0 = 0;
  for (int b = 1; b <= count; ++b) {
    int y1 = H;
    if (b < count) {  // the first row whose nodes above reach b / count of them, leaving a row for each band after
      const std::int64_t goal = before[std::size_t(H)] * b / count;
      y1 = static_cast<int>(std::lower_bound(before.begin(), before.end(), goal) - before.begin());
      y1 = std::clamp(y1, y0 + 1, H - (count - b));
    }
    bands.push_back({y0, y1});
    y0 = y1;
  }
  return bands;
}
/// The seams between the bands: `reach` rows either side of each cut, at most half of either band, so
/// that the seams do not overlap (they are solved at once).
std::vector<Band> seams_of(const std::vector<Band>& bands, int reach) {
  std::vector<Band> seams;
  for (std::size_t b = 1; b < bands.size(); ++b) {
    const int r = std::min({reach, (bands[b - 1].y1 - bands[b - 1].y0) / 2, (bands[b].y1 - bands[b].y0) / 2});
    if (r > 0) seams.push_back({bands[b].y0 - r, bands[b].y0 + r});
  }
  return seams;
}

/// Solves the bands at once (each on the TBB pool with its own energy): their labels go to `out`,
/// the reports are added into `rep`.
void solve_bands(const WindowFrame& f, const std::vector<Band>& bands, const std::uint8_t* start, std::uint8_t* out,
                 SmoothReport& rep) {
  static Pool<SmoothCache> pool;
  std::vector<graphcut::ExpansionReport> reports(bands.size());
  tbb::parallel_for(std::size_t(0), bands.size(), [&](std::size_t b) {
    const auto k = pool.borrow();
    reports[b] = solve_band(f, bands[b], start, out, *k);
  });
  for (const auto& r : reports) {  // in band order: the sum does not depend on the threads
    rep.cycles = std::max(rep.cycles, r.cycles);
    rep.moves += r.moves;
    rep.graph_nodes += r.graph_nodes;
  }
}

/// Smoothing under the label window: the bands (rows cut into opt.bands) are solved apart, at once,
/// each with the rest of the frame held at its MAP labels; then the seams between them, each with the
/// rest held at the bands' result, so that the pixels along a cut see their final neighbours.
cv::Mat smooth_in_window(std::span<const float> dists, std::size_t C, const cv::Mat& image, const SmoothOptions& opt,
                         SmoothReport& rep) {
  static Pool<WindowCache> pool;
  const auto w = pool.borrow();
  const std::size_t n = image.total();
  map_labels(dists, C, image.cols, image.rows, opt, *w);
  const LabelSets near = labels_near(C, image.cols, image.rows, opt.label_window, *w);
  rep.allowed_labels = 0;
  for (std::size_t i = 0; i < n; ++i) rep.allowed_labels += near.count(i);
  const WindowFrame f{dists, C, image, opt, rep.beta, *w, near};
  const std::vector<Band> bands = bands_of(f, std::min(opt.bands, image.rows));
  w->banded = w->map;
  solve_bands(f, bands, w->map.data(), w->banded.data(), rep);
  w->seamed = w->banded;
  solve_bands(f, seams_of(bands, opt.seam_reach()), w->banded.data(), w->seamed.data(), rep);
  rep.energy_before = frame_energy(f, w->map.data());
  rep.energy_after = frame_energy(f, w->seamed.data());
  cv::Mat out(image.rows, image.cols, CV_8UC1);
  std::copy(w->seamed.begin(), w->seamed.end(), out.data);
  return out;
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
  SmoothReport rep;
  rep.beta = opt.contrast ? contrast_beta(image, opt.connectivity) : 0.0;  // beta 0: exp(-beta dI^2) = 1
  cv::Mat out;
  if (opt.label_window > 0) {
    out = smooth_in_window(dists, C, image, opt, rep);
  } else {
    static Pool<SmoothCache> pool;
    const auto k = pool.borrow();
    fill_pixel_energy(dists, C, image, opt, rep.beta, k->e);
    rep.allowed_labels = std::int64_t(n * C);
    k->labelling.clear();  // the solver starts from the MAP labels
    const graphcut::ExpansionReport r = k->solver.solve(k->e, k->labelling, {.max_cycles = opt.cycles});
    out.create(image.rows, image.cols, CV_8UC1);
    for (std::size_t i = 0; i < n; ++i) out.data[i] = static_cast<std::uint8_t>(k->labelling[i]);
    rep.energy_before = r.initial_energy;
    rep.energy_after = r.energy;
    rep.cycles = r.cycles;
    rep.moves = r.moves;
    rep.graph_nodes = r.graph_nodes;
  }
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
