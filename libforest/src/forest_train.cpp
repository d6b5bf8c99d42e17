// Training: extremely randomized trees over sampling windows (see train.hpp).
#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <limits>
#include <cstring>
#include <memory>
#include <numeric>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_pipeline.h>
#include <oneapi/tbb/parallel_reduce.h>

#include "smseg/error.hpp"
#include "smseg/forest/train.hpp"
#include "smseg/io.hpp"
#include "smseg/progress.hpp"

namespace smseg::forest {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// The smallest float >= t: for every float v, v < t (in double) exactly when v < float_ceil(t).
float float_ceil(double t) {
  if (t > static_cast<double>(std::numeric_limits<float>::max())) return std::numeric_limits<float>::infinity();
  float f = static_cast<float>(t);
  if (static_cast<double>(f) < t) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

// ---------------------------------------------------------------------------------------------
// Test sampling: per frame the non-void pixels grouped by class (counting sort), shared by trees.
class TestSampler {
 public:
  TestSampler(const Dataset& data) : width_(data.width), num_classes_(static_cast<int>(data.classes.size())) {
    const std::size_t n = static_cast<std::size_t>(data.width) * data.height;
    const std::size_t C = data.classes.size();
    frames_.resize(data.frames.size());
    class_cum_.assign(C, std::vector<std::uint64_t>(data.frames.size(), 0));
    tbb::parallel_for(std::size_t{0}, data.frames.size(), [&](std::size_t fi) {
      const std::uint8_t* lab = data.frames[fi].labels;
      FramePixels& fp = frames_[fi];
      fp.offsets.assign(C + 1, 0);
      for (std::size_t p = 0; p < n; ++p)
        if (lab[p] != kVoidLabel) ++fp.offsets[lab[p] + 1];
      for (std::size_t c = 0; c < C; ++c) fp.offsets[c + 1] += fp.offsets[c];
      fp.pixels.resize(fp.offsets[C]);
      std::vector<std::uint32_t> pos(fp.offsets.begin(), fp.offsets.end() - 1);
      for (std::size_t p = 0; p < n; ++p)
        if (lab[p] != kVoidLabel) fp.pixels[pos[lab[p]]++] = static_cast<std::uint32_t>(p);
    });
    for (std::size_t fi = 0; fi < frames_.size(); ++fi) {
      if (!frames_[fi].pixels.empty()) nonempty_.push_back(static_cast<int>(fi));
      for (std::size_t c = 0; c < C; ++c)
        class_cum_[c][fi] = (fi ? class_cum_[c][fi - 1] : 0) + (frames_[fi].offsets[c + 1] - frames_[fi].offsets[c]);
    }
    for (std::size_t c = 0; c < C; ++c)
      if (!frames_.empty() && class_cum_[c].back() > 0) present_.push_back(static_cast<int>(c));
    if (nonempty_.empty())
      throw Error("training data", "labels", "no labelled (non-void) pixel in any frame");
  }

  TestPoint draw(Rng& rng, Balance balance) const {
    int fi = 0;
    std::uint32_t p = 0;
    if (balance == Balance::Classes) {
      const int c = present_[rng.below(present_.size())];
      const auto& cum = class_cum_[static_cast<std::size_t>(c)];
      const std::uint64_t r = rng.below(cum.back());
      fi = static_cast<int>(std::upper_bound(cum.begin(), cum.end(), r) - cum.begin());
      const std::uint64_t before = fi ? cum[static_cast<std::size_t>(fi) - 1] : 0;
      const FramePixels& fp = frames_[static_cast<std::size_t>(fi)];
      p = fp.pixels[fp.offsets[static_cast<std::size_t>(c)] + (r - before)];
    } else {
      fi = nonempty_[rng.below(nonempty_.size())];
      const FramePixels& fp = frames_[static_cast<std::size_t>(fi)];
      p = fp.pixels[rng.below(fp.pixels.size())];
    }
    TestPoint t;
    t.frame = fi;
    t.x = static_cast<int>(p % static_cast<std::uint32_t>(width_));
    t.y = static_cast<int>(p / static_cast<std::uint32_t>(width_));
    return t;
  }

 private:
  struct FramePixels {
    std::vector<std::uint32_t> offsets;  // class c: pixels[offsets[c] .. offsets[c+1])
    std::vector<std::uint32_t> pixels;   // pixel indices y * width + x
  };
  int width_;
  int num_classes_;
  std::vector<FramePixels> frames_;
  std::vector<std::vector<std::uint64_t>> class_cum_;  // [class][frame] cumulative pixel counts
  std::vector<int> nonempty_, present_;
};

/// The frames' summed-area tables interleaved per pixel (stack[(y*(W+1)+x)*F + f]): the F reads of
/// one window corner then share a cache line, which matters because tests are scattered at random
/// over the frames. Made once per training and shared by the trees.
struct Stacks {
  std::vector<std::vector<double>> frames;
};

Stacks make_stacks(const Dataset& data) {
  Stacks s;
  const std::size_t F = data.features.size();
  const std::size_t cells = static_cast<std::size_t>(data.width + 1) * (data.height + 1);
  s.frames.resize(data.frames.size());
  tbb::parallel_for(std::size_t{0}, data.frames.size(), [&](std::size_t fi) {
    auto& out = s.frames[fi];
    out.resize(cells * F);
    for (std::size_t f = 0; f < F; ++f) {
      const double* sat = data.frames[fi].sats[f];
      for (std::size_t i = 0; i < cells; ++i) out[i * F + f] = sat[i];
    }
  });
  return s;
}

void validate_for_training(const Dataset& data, const TrainParams& params) {
  params.validate();
  data.validate(true, params.textons);
}

Corpus make_corpus(const Dataset& data, const TrainParams& params, const TestSampler& sampler,
                   const Stacks& stacks, int tree) {
  Rng rng(tree_seed(params.seed, tree));
  const WindowBounds bounds = WindowBounds::for_image(data.width, data.height);
  const WindowSampler windows(params.windows, bounds);
  const int Ks = params.ks(), Kt = params.kt();
  const int F = static_cast<int>(data.features.size());
  Corpus corpus;
  corpus.num_classes = static_cast<int>(data.classes.size());
  std::vector<Window> wins(static_cast<std::size_t>(Ks));
  for (auto& w : wins) w = windows.draw(rng);
  std::vector<Window> offsets;
  if (params.textons) {
    offsets.resize(static_cast<std::size_t>(Ks));
    for (auto& o : offsets) windows.draw_offset(rng, o.dx, o.dy);
  }
  corpus.tests.resize(static_cast<std::size_t>(Kt));
  for (auto& t : corpus.tests) {
    t = sampler.draw(rng, params.balance);
    t.label = data.frames[static_cast<std::size_t>(t.frame)].labels[static_cast<std::size_t>(t.y) * data.width + t.x];
  }
  corpus.candidates.reserve(static_cast<std::size_t>(Ks) * (F + (params.textons ? kNumTextonTests : 0)));
  for (const Window& w : wins)
    for (int f = 0; f < F; ++f) corpus.candidates.push_back({w, f});
  for (const Window& o : offsets)
    for (int k = 0; k < kNumTextonTests; ++k) corpus.candidates.push_back({o, F + k});

  // Sorted by class, then frame and position: the grower keeps each node's tests grouped by class
  // (stable partitions), and tests that follow each other read nearby table rows.
  std::sort(corpus.tests.begin(), corpus.tests.end(), [](const TestPoint& a, const TestPoint& b) {
    if (a.label != b.label) return a.label < b.label;
    return a.frame != b.frame ? a.frame < b.frame : a.y != b.y ? a.y < b.y : a.x < b.x;
  });
  const std::size_t n = corpus.tests.size();
  corpus.values.resize(corpus.candidates.size() * n);
  float* values = corpus.values.data();
  const auto& tests = corpus.tests;
  const std::size_t num_windows = wins.size(), num_offsets = offsets.size();
  const std::size_t window_cands = num_windows * static_cast<std::size_t>(F);
  const int W = data.width, H = data.height;
  const std::size_t stride = static_cast<std::size_t>(W) + 1;
  constexpr std::size_t kBlock = 16;  // tests per block: each block writes whole cache lines per column
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (n + kBlock - 1) / kBlock, 2),
                    [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t b = r.begin(); b != r.end(); ++b) {
      const std::size_t t0 = b * kBlock, t1 = std::min(n, t0 + kBlock);
      for (std::size_t wi = 0; wi < num_windows; ++wi) {
        const RelRect rect = rel_rect(wins[wi]);
        float* out = values + wi * F * n;
        for (std::size_t t = t0; t < t1; ++t) {
          const TestPoint& tp = tests[t];
          // The same corners as window_sum(), on the interleaved stack (bit-identical sums).
          const int xa = std::clamp(tp.x + rect.x0, 0, W), xb = std::clamp(tp.x + rect.x1, 0, W);
          const int ya = std::clamp(tp.y + rect.y0, 0, H), yb = std::clamp(tp.y + rect.y1, 0, H);
          const double* s = stacks.frames[static_cast<std::size_t>(tp.frame)].data();
          const double* tl = s + (static_cast<std::size_t>(ya) * stride + static_cast<std::size_t>(xa)) * F;
          const double* tr = s + (static_cast<std::size_t>(ya) * stride + static_cast<std::size_t>(xb)) * F;
          const double* bl = s + (static_cast<std::size_t>(yb) * stride + static_cast<std::size_t>(xa)) * F;
          const double* br = s + (static_cast<std::size_t>(yb) * stride + static_cast<std::size_t>(xb)) * F;
          for (int f = 0; f < F; ++f)
            out[static_cast<std::size_t>(f) * n + t] = static_cast<float>((br[f] - tr[f]) - (bl[f] - tl[f]));
        }
      }
      for (std::size_t oi = 0; oi < num_offsets; ++oi) {
        const Window& o = offsets[oi];
        for (int k = 0; k < kNumTextonTests; ++k) {
          float* out = values + (window_cands + oi * kNumTextonTests + static_cast<std::size_t>(k)) * n;
          for (std::size_t t = t0; t < t1; ++t)
            out[t] = texton_value(data.frames[static_cast<std::size_t>(tests[t].frame)].gray, W, H,
                                  tests[t].x, tests[t].y, o.dx, o.dy, k);
        }
      }
    }
  });
  return corpus;
}

// ---------------------------------------------------------------------------------------------
// Growing a tree.

struct Split {
  double score = -1.0;
  std::size_t candidate = std::numeric_limits<std::size_t>::max();
  double threshold = 0.0;
  bool better_than(const Split& o) const {
    return score > o.score || (score == o.score && candidate < o.candidate);
  }
};

class Grower {
 public:
  /// Takes the corpus apart: its value matrix is reordered in place as the tree grows, so that the
  /// tests of every node are contiguous in every column (sequential, vectorisable scans).
  Grower(Corpus&& corpus, int n_min, std::uint64_t seed)
      : n_(corpus.tests.size()),
        nc_(corpus.candidates.size()),
        n_min_(n_min),
        seed_(seed),
        C_(static_cast<std::size_t>(corpus.num_classes)),
        candidates_(std::move(corpus.candidates)),
        values_(std::move(corpus.values)) {
    xlogx_.resize(n_ + 1);
    xlogx_[0] = 0.0;
    for (std::size_t i = 1; i <= n_; ++i) xlogx_[i] = static_cast<double>(i) * std::log(static_cast<double>(i));
    labels_.resize(n_);
    for (std::size_t t = 0; t < n_; ++t) labels_[t] = corpus.tests[t].label;
    // Tests grouped by class (build_corpus already sorts them so; others are permuted once). Stable
    // partitions keep every node's tests grouped by class, so a class's left count is a plain sum.
    std::vector<std::uint32_t> perm(n_);
    std::iota(perm.begin(), perm.end(), 0u);
    std::stable_sort(perm.begin(), perm.end(), [&](std::uint32_t a, std::uint32_t b) { return labels_[a] < labels_[b]; });
    bool identity = true;
    for (std::size_t i = 0; i < n_; ++i) identity = identity && perm[i] == i;
    if (!identity) {
      std::vector<float> tmp(n_);
      for (std::size_t c = 0; c < nc_; ++c) {
        float* col = column(c);
        for (std::size_t i = 0; i < n_; ++i) tmp[i] = col[perm[i]];
        std::copy(tmp.begin(), tmp.end(), col);
      }
      std::vector<std::uint8_t> l(n_);
      for (std::size_t i = 0; i < n_; ++i) l[i] = labels_[perm[i]];
      labels_ = std::move(l);
    }
  }

  Tree grow() {
    Tree tree;
    tree.nodes.emplace_back();
    struct Item {
      int node;
      std::size_t begin, end;
      std::shared_ptr<const LiveSet> live;  // candidates that vary over the node's tests, with range
    };
    auto root = std::make_shared<LiveSet>();
    {
      std::vector<float> lo(nc_), hi(nc_);
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nc_, 64), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t c = r.begin(); c != r.end(); ++c) minmax(column(c), n_, lo[c], hi[c]);
      });
      for (std::size_t c = 0; c < nc_; ++c) root->add(static_cast<std::uint32_t>(c), lo[c], hi[c]);
    }
    std::vector<Item> stack{{0, 0, n_, root}};
    std::vector<std::uint32_t> counts(C_), lcounts(C_);
    std::vector<std::uint8_t> mask, tmp8;
    while (!stack.empty()) {
      Item it = std::move(stack.back());
      stack.pop_back();
      const std::size_t b = it.begin, m = it.end - it.begin;
      count_classes(b, it.end, counts);
      Split best;
      if (!is_leaf(counts, m)) best = best_split(it.node, b, m, counts, *it.live);
      Node& node = tree.nodes[static_cast<std::size_t>(it.node)];
      if (best.score < 0.0) {  // pure, too few tests, or every candidate constant
        node.counts = counts;
        continue;
      }
      const Candidate& cand = candidates_[best.candidate];
      node.feature = cand.feature;
      node.win = cand.win;
      node.threshold = best.threshold;
      // Stable partition (value < threshold first) of the labels and of every live column; the
      // children's value ranges come out of the same pass (the segments are then in L1/L2).
      const float tf = float_ceil(best.threshold);
      const float* bc = column(best.candidate) + b;
      mask.resize(m);
      std::size_t nl = 0;
      for (std::size_t i = 0; i < m; ++i) nl += mask[i] = bc[i] < tf ? 1 : 0;
      tmp8.resize(m);
      partition(labels_.data() + b, mask.data(), m, nl, tmp8.data());
      count_classes(b, b + nl, lcounts);
      const bool grow_left = !is_leaf(lcounts, nl);
      for (std::size_t k = 0; k < C_; ++k) lcounts[k] = counts[k] - lcounts[k];
      const bool grow_right = !is_leaf(lcounts, m - nl);
      auto left_set = std::make_shared<LiveSet>(), right_set = std::make_shared<LiveSet>();
      if (grow_left || grow_right) {
        const LiveSet& live = *it.live;
        const std::size_t L = live.cand.size();
        std::vector<float> llo(L), lhi(L), rlo(L), rhi(L);
        auto part = [&](std::size_t j0, std::size_t j1) {
          std::vector<float> tmp(m);
          for (std::size_t j = j0; j < j1; ++j) {
            float* seg = column(live.cand[j]) + b;
            partition(seg, mask.data(), m, nl, tmp.data());
            if (grow_left) minmax(seg, nl, llo[j], lhi[j]);
            if (grow_right) minmax(seg + nl, m - nl, rlo[j], rhi[j]);
          }
        };
        if (m * L < (std::size_t{1} << 20)) {
          part(0, L);
        } else {
          tbb::parallel_for(tbb::blocked_range<std::size_t>(0, L, 32),
                            [&](const tbb::blocked_range<std::size_t>& r) { part(r.begin(), r.end()); });
        }
        for (std::size_t j = 0; j < L; ++j) {
          if (grow_left) left_set->add(live.cand[j], llo[j], lhi[j]);
          if (grow_right) right_set->add(live.cand[j], rlo[j], rhi[j]);
        }
      }
      const int left = static_cast<int>(tree.nodes.size());
      node.left = left;
      node.right = left + 1;
      tree.nodes.emplace_back();  // invalidates `node`
      tree.nodes.emplace_back();
      it.live.reset();
      // Depth first, left subtree first.
      stack.push_back({left + 1, b + nl, it.end, std::move(right_set)});
      stack.push_back({left, b, b + nl, std::move(left_set)});
    }
    return tree;
  }

 private:
  struct LiveSet {
    std::vector<std::uint32_t> cand;
    std::vector<float> lo, hi;
    void add(std::uint32_t c, float l, float h) {
      if (!(l < h)) return;  // constant here, hence in every descendant
      cand.push_back(c);
      lo.push_back(l);
      hi.push_back(h);
    }
  };

  float* column(std::size_t c) { return values_.data() + c * n_; }
  const float* column(std::size_t c) const { return values_.data() + c * n_; }

  void count_classes(std::size_t b, std::size_t e, std::vector<std::uint32_t>& counts) const {
    std::fill(counts.begin(), counts.end(), 0u);
    for (std::size_t i = b; i < e; ++i) ++counts[labels_[i]];
  }
  bool is_leaf(const std::vector<std::uint32_t>& counts, std::size_t m) const {
    const bool pure = std::count_if(counts.begin(), counts.end(), [](std::uint32_t v) { return v > 0; }) <= 1;
    return pure || m < static_cast<std::size_t>(n_min_) || m < 2;
  }

  typedef float v4f __attribute__((vector_size(16)));
  typedef std::int32_t v4i __attribute__((vector_size(16)));

  static v4f load4(const float* p) {
    v4f v;
    std::memcpy(&v, p, sizeof v);
    return v;
  }

  static void minmax(const float* v, std::size_t m, float& lo_out, float& hi_out) {
    if (m == 0) {
      lo_out = hi_out = 0.0f;
      return;
    }
    float lo = v[0], hi = v[0];
    std::size_t i = 0;
    if (m >= 8) {
      v4f lo0 = load4(v), hi0 = lo0, lo1 = load4(v + 4), hi1 = lo1;
      for (i = 8; i + 8 <= m; i += 8) {
        const v4f a = load4(v + i), c = load4(v + i + 4);
        lo0 = a < lo0 ? a : lo0;
        hi0 = a > hi0 ? a : hi0;
        lo1 = c < lo1 ? c : lo1;
        hi1 = c > hi1 ? c : hi1;
      }
      lo0 = lo1 < lo0 ? lo1 : lo0;
      hi0 = hi1 > hi0 ? hi1 : hi0;
      for (int k = 0; k < 4; ++k) {
        lo = std::min(lo, lo0[k]);
        hi = std::max(hi, hi0[k]);
      }
    }
    for (; i < m; ++i) {
      lo = std::min(lo, v[i]);
      hi = std::max(hi, v[i]);
    }
    lo_out = lo;
    hi_out = hi;
  }

  static std::uint32_t count_less(const float* v, std::size_t m, float t) {
    std::size_t i = 0;
    std::uint32_t cnt = 0;
    if (m >= 8) {
      v4i c0 = {0, 0, 0, 0}, c1 = c0;
      const v4f tv = {t, t, t, t};
      for (; i + 8 <= m; i += 8) {
        c0 -= load4(v + i) < tv;  // true is -1
        c1 -= load4(v + i + 4) < tv;
      }
      c0 += c1;
      cnt = static_cast<std::uint32_t>(c0[0] + c0[1] + c0[2] + c0[3]);
    }
    for (; i < m; ++i) cnt += v[i] < t ? 1u : 0u;
    return cnt;
  }

  // Stable, branch-free partition of seg[0..m) by mask (1 = left, nl of them).
  template <class T>
  static void partition(T* seg, const std::uint8_t* mask, std::size_t m, std::size_t nl, T* tmp) {
    std::size_t l = 0, r = 0;
    for (std::size_t i = 0; i < m; ++i) {
      const T v = seg[i];
      seg[l] = v;  // l <= i: never overwrites an unread value
      tmp[r] = v;
      l += mask[i];
      r += 1u - mask[i];
    }
    std::copy(tmp, tmp + r, seg + nl);
  }

  Split best_split(int node, std::size_t b, std::size_t m, const std::vector<std::uint32_t>& counts,
                   const LiveSet& live) const {
    double sum_nc = 0.0;
    for (auto v : counts) sum_nc += xlogx_[v];
    auto scan = [&](std::size_t j0, std::size_t j1) {
      Split best;
      std::vector<std::uint32_t> left(C_);
      for (std::size_t j = j0; j < j1; ++j) {
        const std::size_t c = live.cand[j];
        const float* vals = column(c) + b;
        const double dlo = live.lo[j], dhi = live.hi[j];
        double t = dhi - hash_uniform(seed_, static_cast<std::uint64_t>(node), c) * (dhi - dlo);
        if (!(t > dlo)) t = dhi;  // threshold in (lo, hi]: both sides non-empty
        const float tf = float_ceil(t);
        std::size_t s = 0;
        for (std::size_t k = 0; k < C_; ++k) {
          left[k] = counts[k] ? count_less(vals + s, counts[k], tf) : 0u;
          s += counts[k];
        }
        const double sc = score(left, counts, m, sum_nc);
        const Split cand{sc, c, t};
        if (cand.better_than(best)) best = cand;
      }
      return best;
    };
    const std::size_t L = live.cand.size();
    if (m * L < (std::size_t{1} << 20)) return scan(0, L);
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, L, 16), Split{},
        [&](const tbb::blocked_range<std::size_t>& r, Split acc) {
          const Split s = scan(r.begin(), r.end());
          return s.better_than(acc) ? s : acc;
        },
        [](const Split& a, const Split& c) { return a.better_than(c) ? a : c; });
  }

  double score(const std::vector<std::uint32_t>& left, const std::vector<std::uint32_t>& counts,
               std::size_t n, double sum_nc) const {
    std::size_t nl = 0;
    double sum_l = 0.0, sum_r = 0.0;
    for (std::size_t k = 0; k < C_; ++k) {
      nl += left[k];
      sum_l += xlogx_[left[k]];
      sum_r += xlogx_[counts[k] - left[k]];
    }
    const std::size_t nr = n - nl;
    if (nl == 0 || nr == 0) return 0.0;
    const double nlogn = xlogx_[n];
    const double hc = nlogn - sum_nc;                                // n H(C)
    const double hs = nlogn - xlogx_[nl] - xlogx_[nr];               // n H(S)
    const double hcs = (xlogx_[nl] - sum_l) + (xlogx_[nr] - sum_r);  // n H(C|S)
    const double denom = hc + hs;
    return denom > 0.0 ? 2.0 * (hc - hcs) / denom : 0.0;
  }

  std::size_t n_, nc_;
  int n_min_;
  std::uint64_t seed_;
  std::size_t C_;
  std::vector<Candidate> candidates_;
  std::vector<float> values_;
  std::vector<double> xlogx_;
  std::vector<std::uint8_t> labels_;
};

}  // namespace

double wehenkel_pavella(std::span<const std::uint32_t> left, std::span<const std::uint32_t> right) {
  if (left.size() != right.size()) throw Error("", "wehenkel_pavella", "left and right class counts differ in size");
  auto xlx = [](double x) { return x > 0.0 ? x * std::log(x) : 0.0; };
  double nl = 0, nr = 0, sl = 0, sr = 0, sc = 0;
  for (std::size_t k = 0; k < left.size(); ++k) {
    nl += left[k];
    nr += right[k];
    sl += xlx(left[k]);
    sr += xlx(right[k]);
    sc += xlx(static_cast<double>(left[k]) + right[k]);
  }
  const double n = nl + nr;
  if (nl == 0 || nr == 0) return 0.0;
  const double hc = (xlx(n) - sc) / n;
  const double hs = (xlx(n) - xlx(nl) - xlx(nr)) / n;
  const double hcs = ((xlx(nl) - sl) + (xlx(nr) - sr)) / n;
  if (hc <= 0.0) return 0.0;
  return 2.0 * (hc - hcs) / (hc + hs);
}

Corpus build_corpus(const Dataset& data, const TrainParams& params, int tree) {
  validate_for_training(data, params);
  if (tree < 0 || tree >= params.M)
    throw Error("", "tree", "is " + std::to_string(tree) + ", expected 0.." + std::to_string(params.M - 1));
  const TestSampler sampler(data);
  const Stacks stacks = make_stacks(data);
  return make_corpus(data, params, sampler, stacks, tree);
}

Tree grow_tree(const Corpus& corpus, int n_min, std::uint64_t seed) {
  if (corpus.tests.empty()) throw Error("", "corpus", "no tests");
  if (corpus.values.size() != corpus.tests.size() * corpus.candidates.size())
    throw Error("", "corpus.values", "size is not tests x candidates");
  for (const auto& t : corpus.tests)
    if (t.label >= corpus.num_classes) throw Error("", "corpus.tests", "label outside the class list");
  Corpus copy = corpus;
  return Grower(std::move(copy), n_min, seed).grow();
}

Forest train_forest(const Dataset& data, const TrainParams& params) {
  const auto t0 = Clock::now();
  validate_for_training(data, params);
  const TestSampler sampler(data);
  const Stacks stacks = make_stacks(data);
  Forest forest;
  forest.width = data.width;
  forest.height = data.height;
  forest.classes = data.classes;
  forest.features = data.features;
  forest.textons = params.textons;
  forest.params = params;
  forest.trees.resize(static_cast<std::size_t>(params.M));
  std::vector<double> tree_seconds(static_cast<std::size_t>(params.M), 0.0);

  const std::size_t candidates = static_cast<std::size_t>(params.ks()) *
                                 (data.features.size() + (params.textons ? kNumTextonTests : 0));
  const std::size_t per_tree = candidates * static_cast<std::size_t>(params.kt()) * sizeof(float) +
                               static_cast<std::size_t>(params.kt()) * 32;
  const std::size_t budget = params.memory_mb << 20;
  const std::size_t in_flight = std::clamp<std::size_t>(budget / std::max<std::size_t>(per_tree, 1), 1,
                                                        static_cast<std::size_t>(params.M));
  Progress progress("train trees", params.M, params.progress);
  int next = 0;
  tbb::parallel_pipeline(
      in_flight,
      tbb::make_filter<void, int>(tbb::filter_mode::serial_in_order,
                                  [&](tbb::flow_control& fc) -> int {
                                    if (next >= params.M) {
                                      fc.stop();
                                      return 0;
                                    }
                                    return next++;
                                  }) &
          tbb::make_filter<int, void>(tbb::filter_mode::parallel, [&](int t) {
            const auto tt = Clock::now();
            Corpus corpus = make_corpus(data, params, sampler, stacks, t);
            forest.trees[static_cast<std::size_t>(t)] =
                Grower(std::move(corpus), params.n_min, tree_seed(params.seed, t)).grow();
            tree_seconds[static_cast<std::size_t>(t)] = seconds_since(tt);
            progress.tick();
          }));
  progress.finish();
  forest.compute_stats();
  for (std::size_t t = 0; t < tree_seconds.size(); ++t) forest.stats.trees[t].seconds = tree_seconds[t];
  forest.stats.seconds = seconds_since(t0);
  return forest;
}

std::string candidate_name(const Candidate& c, const std::vector<std::string>& features) {
  const int F = static_cast<int>(features.size());
  std::string name = c.feature < F ? features[static_cast<std::size_t>(c.feature)]
                     : c.feature < F + kNumTextonTests ? texton_names()[static_cast<std::size_t>(c.feature - F)]
                                                       : "?";
  name += "[dx=" + std::to_string(c.win.dx) + ";dy=" + std::to_string(c.win.dy);
  if (c.feature < F) name += ";w=" + std::to_string(c.win.w) + ";h=" + std::to_string(c.win.h);
  return name + "]";
}

void export_corpus_csv(const Dataset& data, const TrainParams& params, int tree, const std::filesystem::path& path) {
  const Corpus corpus = build_corpus(data, params, tree);
  std::string out = "label";
  for (const Candidate& c : corpus.candidates) {
    out += ',';
    out += candidate_name(c, data.features);
  }
  out += "\n";
  const std::size_t n = corpus.tests.size();
  out.reserve(out.size() + n * (corpus.candidates.size() * 8 + 4));
  char buf[64];
  for (std::size_t t = 0; t < n; ++t) {
    out += std::to_string(corpus.tests[t].label);
    for (std::size_t c = 0; c < corpus.candidates.size(); ++c) {
      const auto res = std::to_chars(buf, buf + sizeof buf, corpus.values[c * n + t]);
      out += ',';
      out.append(buf, res.ptr);
    }
    out += '\n';
  }
  write_file_atomic(path, out);
}

}  // namespace smseg::forest
