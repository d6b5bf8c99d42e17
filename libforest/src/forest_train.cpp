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

#include "forest_corpus.hpp"
#include "forest_simd.hpp"
#include "smseg/common/error.hpp"
#include "smseg/forest/train.hpp"
#include "smseg/common/io.hpp"
#include "smseg/common/progress.hpp"

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

void validate_for_training(const Dataset& data, const TrainParams& params) {
  params.validate();
  data.validate(true, params.textons);
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

/// The corpus's candidate-major values test-major: out[t * nc + c] = values[c * n + t] (tiled).
std::unique_ptr<float[]> transpose_values(const float* values, std::size_t n, std::size_t nc) {
  auto out = std::make_unique_for_overwrite<float[]>(std::max<std::size_t>(n * nc, 1));
  constexpr std::size_t kTile = 16;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (n + kTile - 1) / kTile, 4),
                    [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t tb = r.begin(); tb != r.end(); ++tb) {
      const std::size_t t0 = tb * kTile, t1 = std::min(n, t0 + kTile);
      for (std::size_t c0 = 0; c0 < nc; c0 += kTile) {
        const std::size_t c1 = std::min(nc, c0 + kTile);
        for (std::size_t t = t0; t < t1; ++t)
          for (std::size_t c = c0; c < c1; ++c) out[t * nc + c] = values[c * n + t];
      }
    }
  });
  return out;
}

class Grower {
 public:
  /// Grows a tree from `corpus` (its tests and candidates; it must outlive the grower).
  ///
  /// Layout: the values come test-major (rows_[t * nc + c], transpose_values), and a node is a
  /// range of order_ (test indices, grouped by class). A split partitions only that index range;
  /// the columns never move. Per node, every candidate's range over the node's tests and its
  /// class-wise counts below its threshold come from two passes over the node's rows, each a
  /// contiguous, vectorisable loop over a block of candidates.
  /// `rows`: the corpus's values test-major (transpose_values), kept by the caller.
  Grower(const Corpus& corpus, const float* rows, int n_min, std::uint64_t seed, Score score)
      : n_(corpus.tests.size()),
        nc_(corpus.candidates.size()),
        n_min_(n_min),
        seed_(seed),
        score_(score),
        C_(static_cast<std::size_t>(corpus.num_classes)),
        candidates_(corpus.candidates),
        rows_(rows),
        simd_(detail::default_simd_kernels()) {
    xlogx_.resize(n_ + 1);
    xlogx_[0] = 0.0;
    for (std::size_t i = 1; i <= n_; ++i) xlogx_[i] = static_cast<double>(i) * std::log(static_cast<double>(i));
    labels_.resize(n_);
    for (std::size_t t = 0; t < n_; ++t) labels_[t] = corpus.tests[t].label;
    // Tests grouped by class (stably): partitions keep every node's tests grouped by class, so a
    // class's tests are one run of the node's range.
    order_.resize(n_);
    std::iota(order_.begin(), order_.end(), 0u);
    std::stable_sort(order_.begin(), order_.end(), [&](std::uint32_t a, std::uint32_t b) { return labels_[a] < labels_[b]; });
  }

  Tree grow() {
    Tree tree;
    tree.nodes.emplace_back();
    struct Item {
      int node;
      std::size_t begin, end;  // the node's range of order_
    };
    std::vector<Item> stack{{0, 0, n_}};
    std::vector<std::uint32_t> counts(C_), tmp;
    while (!stack.empty()) {
      const Item it = stack.back();
      stack.pop_back();
      const std::size_t b = it.begin, m = it.end - it.begin;
      std::fill(counts.begin(), counts.end(), 0u);
      for (std::size_t i = b; i < it.end; ++i) ++counts[labels_[order_[i]]];
      Split best;
      if (!is_leaf(counts, m)) best = best_split(it.node, order_.data() + b, m, counts);
      Node& node = tree.nodes[static_cast<std::size_t>(it.node)];
      if (best.score < 0.0) {  // pure, too few tests, or every candidate constant
        node.counts = counts;
        continue;
      }
      const Candidate& cand = candidates_[best.candidate];
      node.feature = cand.feature;
      node.win = cand.win;
      node.threshold = best.threshold;
      // Stable partition of the node's tests (value < threshold first).
      const float tf = float_ceil(best.threshold);
      std::uint32_t* ord = order_.data() + b;
      tmp.resize(m);
      std::size_t nl = 0, nr = 0;
      for (std::size_t i = 0; i < m; ++i) {
        const std::uint32_t t = ord[i];
        const bool left = rows_[t * nc_ + best.candidate] < tf;
        ord[nl] = t;  // nl <= i: never overwrites an unread entry
        tmp[nr] = t;
        nl += left;
        nr += !left;
      }
      std::copy(tmp.begin(), tmp.begin() + static_cast<std::ptrdiff_t>(nr), ord + nl);
      const int left = static_cast<int>(tree.nodes.size());
      node.left = left;
      node.right = left + 1;
      tree.nodes.emplace_back();  // invalidates `node`
      tree.nodes.emplace_back();
      // Depth first, left subtree first.
      stack.push_back({left + 1, b + nl, it.end});
      stack.push_back({left, b, b + nl});
    }
    return tree;
  }

 private:
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
  static void store4(float* p, v4f v) { std::memcpy(p, &v, sizeof v); }
  // A node's tests are rows scattered over the value matrix (ord), which the processor cannot
  // foresee: the block's part of the row kAhead tests on is asked for while this one is scanned.
  static constexpr std::size_t kAhead = 4;
  static void prefetch_row(const float* r, std::size_t n) {
    for (std::size_t j = 0; j < n; j += 64 / sizeof(float)) __builtin_prefetch(r + j);
  }

  static constexpr std::size_t kBlock = 256;  // candidates per block (scratch stays in L1)

  // The node scan's two loops in 4-float vectors, the reference the SIMD targets' kernels match
  // (SimdKernels::row_range and count_below say what each computes).
  void row_range(const std::uint32_t* ord, std::size_t m, std::size_t j0, std::size_t B, float* lo, float* hi) const {
    {
      const float* r = rows_ + ord[0] * nc_ + j0;
      std::copy(r, r + B, lo);
      std::copy(r, r + B, hi);
    }
    const std::size_t B4 = B & ~std::size_t{3};  // whole 4-float vectors; the rest one by one
    for (std::size_t i = 1; i < m; ++i) {
      const float* r = rows_ + ord[i] * nc_ + j0;
      if (i + kAhead < m) prefetch_row(rows_ + ord[i + kAhead] * nc_ + j0, B);
      for (std::size_t j = 0; j < B4; j += 4) {
        const v4f v = load4(r + j), l = load4(lo + j), h = load4(hi + j);
        store4(lo + j, v < l ? v : l);
        store4(hi + j, v > h ? v : h);
      }
      for (std::size_t j = B4; j < B; ++j) {
        const float v = r[j];
        lo[j] = v < lo[j] ? v : lo[j];
        hi[j] = v > hi[j] ? v : hi[j];
      }
    }
  }

  void count_below(const std::uint32_t* ord, std::size_t i0, std::size_t i1, std::size_t m, std::size_t j0,
                   std::size_t B, const float* tf, std::int32_t* cnt) const {
    const std::size_t B4 = B & ~std::size_t{3};
    for (std::size_t i = i0; i < i1; ++i) {
      const float* r = rows_ + ord[i] * nc_ + j0;
      if (i + kAhead < m) prefetch_row(rows_ + ord[i + kAhead] * nc_ + j0, B);
      for (std::size_t j = 0; j < B4; j += 4) {
        v4i c;
        std::memcpy(&c, cnt + j, sizeof c);
        c -= load4(r + j) < load4(tf + j);  // true is -1
        std::memcpy(cnt + j, &c, sizeof c);
      }
      for (std::size_t j = B4; j < B; ++j) cnt[j] += r[j] < tf[j] ? 1 : 0;
    }
  }

  /// The best split of a node over candidates [j0, j1): every candidate that is not constant over
  /// the node's tests gets one threshold uniform in (min, max] and is scored.
  Split scan_block(int node, const std::uint32_t* ord, std::size_t m, const std::vector<std::uint32_t>& counts,
                   double sum_nc, std::size_t j0, std::size_t j1) const {
    const std::size_t B = j1 - j0;
    alignas(64) float lo[kBlock], hi[kBlock], tf[kBlock];
    alignas(64) std::int32_t cnt[kBlock];
    if (simd_) simd_->row_range(rows_, nc_, ord, m, j0, B, lo, hi);
    else row_range(ord, m, j0, B, lo, hi);
    double thr[kBlock];
    for (std::size_t j = 0; j < B; ++j) {
      const double dlo = lo[j], dhi = hi[j];
      if (!(lo[j] < hi[j])) {  // constant over the node: not a candidate here
        tf[j] = -std::numeric_limits<float>::infinity();
        continue;
      }
      double t = dhi - hash_uniform(seed_, static_cast<std::uint64_t>(node), j0 + j) * (dhi - dlo);
      if (!(t > dlo)) t = dhi;  // threshold in (lo, hi]: both sides non-empty
      thr[j] = t;
      tf[j] = float_ceil(t);
    }
    // Per candidate, what the score needs of the class-wise counts below its threshold, class by
    // class in order: how many go left, and the sums of x log x of the left and right counts. Classes
    // the node lacks are skipped: their terms are 0 (x log x of 0), which leaves a sum as it is.
    alignas(64) std::uint32_t nl[kBlock];
    alignas(64) double sum_l[kBlock], sum_r[kBlock];
    std::fill(nl, nl + B, 0u);
    std::fill(sum_l, sum_l + B, 0.0);
    std::fill(sum_r, sum_r + B, 0.0);
    std::size_t s = 0;
    for (std::size_t k = 0; k < C_; ++k) {
      if (counts[k] == 0) continue;
      std::fill(cnt, cnt + B, 0);
      if (simd_) simd_->count_below(rows_, nc_, ord, s, s + counts[k], m, j0, B, tf, cnt);
      else count_below(ord, s, s + counts[k], m, j0, B, tf, cnt);
      for (std::size_t j = 0; j < B; ++j) {
        const auto left = static_cast<std::uint32_t>(cnt[j]);
        nl[j] += left;
        sum_l[j] += xlogx_[left];
        sum_r[j] += xlogx_[counts[k] - left];
      }
      s += counts[k];
    }
    Split best;
    for (std::size_t j = 0; j < B; ++j) {
      if (!(lo[j] < hi[j])) continue;
      const Split cand{score(nl[j], sum_l[j], sum_r[j], m, sum_nc), j0 + j, thr[j]};
      if (cand.better_than(best)) best = cand;
    }
    return best;
  }

  Split best_split(int node, const std::uint32_t* ord, std::size_t m, const std::vector<std::uint32_t>& counts) const {
    double sum_nc = 0.0;
    for (auto v : counts) sum_nc += xlogx_[v];
    const std::size_t blocks = (nc_ + kBlock - 1) / kBlock;
    auto scan = [&](std::size_t b0, std::size_t b1) {
      Split best;
      for (std::size_t bi = b0; bi < b1; ++bi) {
        const Split s = scan_block(node, ord, m, counts, sum_nc, bi * kBlock, std::min(nc_, (bi + 1) * kBlock));
        if (s.better_than(best)) best = s;
      }
      return best;
    };
    if (m * nc_ < (std::size_t{1} << 19)) return scan(0, blocks);
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, blocks, 1), Split{},
        [&](const tbb::blocked_range<std::size_t>& r, Split acc) {
          const Split s = scan(r.begin(), r.end());
          return s.better_than(acc) ? s : acc;
        },
        [](const Split& a, const Split& c) { return a.better_than(c) ? a : c; });
  }

  /// The split score in n log n form (natural logs): Wehenkel-Pavella 2 n I / (n H(C) + n H(S)), or
  /// the information gain n I / n = I(C;S) in nats.
  /// `nl` of the n tests go left; sum_l and sum_r: the sums over classes of x log x of the left and
  /// right class counts; sum_nc: of the node's class counts.
  double score(std::size_t nl, double sum_l, double sum_r, std::size_t n, double sum_nc) const {
    const std::size_t nr = n - nl;
    if (nl == 0 || nr == 0) return 0.0;
    const double nlogn = xlogx_[n];
    const double hc = nlogn - sum_nc;                                // n H(C)
    const double hcs = (xlogx_[nl] - sum_l) + (xlogx_[nr] - sum_r);  // n H(C|S)
    if (score_ == Score::InformationGain) return (hc - hcs) / static_cast<double>(n);
    const double hs = nlogn - xlogx_[nl] - xlogx_[nr];               // n H(S)
    const double denom = hc + hs;
    return denom > 0.0 ? 2.0 * (hc - hcs) / denom : 0.0;
  }

  std::size_t n_, nc_;
  int n_min_;
  std::uint64_t seed_;
  Score score_;
  std::size_t C_;
  const std::vector<Candidate>& candidates_;
  std::vector<double> xlogx_;
  std::vector<std::uint8_t> labels_;   // by test index
  std::vector<std::uint32_t> order_;   // test indices; every node is a range, grouped by class
  const float* rows_;                  // test-major values: rows_[t * nc_ + c]
  const detail::SimdKernels* simd_;    // the node scan's vector kernels; null: the loops above
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

double information_gain(std::span<const std::uint32_t> left, std::span<const std::uint32_t> right) {
  if (left.size() != right.size()) throw Error("", "information_gain", "left and right class counts differ in size");
  auto xlx = [](double x) { return x > 0.0 ? x * std::log2(x) : 0.0; };
  double nl = 0, nr = 0, sl = 0, sr = 0, sc = 0;
  for (std::size_t k = 0; k < left.size(); ++k) {
    nl += left[k];
    nr += right[k];
    sl += xlx(left[k]);
    sr += xlx(right[k]);
    sc += xlx(static_cast<double>(left[k]) + right[k]);
  }
  if (nl == 0 || nr == 0) return 0.0;
  const double n = nl + nr;
  const double hc = (xlx(n) - sc) / n;
  const double hcs = ((xlx(nl) - sl) + (xlx(nr) - sr)) / n;
  return std::max(0.0, hc - hcs);
}

Corpus build_corpus(const Dataset& data, const TrainParams& params, int tree) {
  validate_for_training(data, params);
  if (tree < 0 || tree >= params.M)
    throw Error("", "tree", "is " + std::to_string(tree) + ", expected 0.." + std::to_string(params.M - 1));
  const detail::TestSampler sampler(data);
  Corpus corpus = detail::draw_corpus(data, params, sampler, tree);
  const std::size_t n = corpus.tests.size(), nc = corpus.candidates.size();
  std::vector<float> rows(n * nc);
  const Corpus* corpora[] = {&corpus};
  float* const outs[] = {rows.data()};
  detail::fill_rows(data, corpora, outs);
  corpus.values.resize(n * nc);  // candidate-major, as Corpus says
  for (std::size_t t = 0; t < n; ++t)
    for (std::size_t c = 0; c < nc; ++c) corpus.values[c * n + t] = rows[t * nc + c];
  return corpus;
}

namespace {
// `with_values`: the corpus must carry its values (else they come test-major from the caller).
void check_corpus(const Corpus& corpus, Score score, bool with_values = true) {
  if (corpus.tests.empty()) throw Error("", "corpus", "no tests");
  if (with_values && corpus.values.size() != corpus.tests.size() * corpus.candidates.size())
    throw Error("", "corpus.values", "size is not tests x candidates");
  for (const auto& t : corpus.tests)
    if (t.label >= corpus.num_classes) throw Error("", "corpus.tests", "label outside the class list");
  if (score != Score::WehenkelPavella && score != Score::InformationGain) throw Error("", "score", "unknown split score");
}
}  // namespace

Tree grow_tree(const Corpus& corpus, int n_min, std::uint64_t seed, Score score) {
  check_corpus(corpus, score);
  const auto rows = transpose_values(corpus.values.data(), corpus.tests.size(), corpus.candidates.size());
  return Grower(corpus, rows.get(), n_min, seed, score).grow();
}

std::vector<Tree> grow_trees(const Corpus& corpus, int n_min, std::span<const std::uint64_t> seeds, Score score) {
  check_corpus(corpus, score);
  const auto rows = transpose_values(corpus.values.data(), corpus.tests.size(), corpus.candidates.size());
  return grow_trees_from_rows(corpus, rows.get(), n_min, seeds, score);
}

std::vector<Tree> grow_trees_from_rows(const Corpus& corpus, const float* rows, int n_min,
                                       std::span<const std::uint64_t> seeds, Score score) {
  check_corpus(corpus, score, false);
  std::vector<Tree> trees(seeds.size());
  tbb::parallel_for(std::size_t{0}, seeds.size(), [&](std::size_t t) {
    trees[t] = Grower(corpus, rows, n_min, seeds[t], score).grow();
  });
  return trees;
}

namespace {
/// Refuses, in one line, a memory budget that cannot hold even one tree.
detail::MemoryPlan checked_memory_plan(const Dataset& data, const TrainParams& params) {
  const detail::MemoryPlan plan = detail::plan_memory(data, params);
  if (plan.trees_at_once == 0) {
    const auto mb = [](std::size_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20); };
    throw Error("", "memory_mb",
                "is " + std::to_string(params.memory_mb) + " MB; this training needs at least " +
                    mb(plan.fixed_bytes + plan.per_tree_bytes) + " MB (one tree at a time: " +
                    mb(plan.per_tree_bytes) + " MB for its Kt x candidates values and grower, " +
                    mb(plan.fixed_bytes) + " MB for the process, test sampler and frames being read)");
  }
  return plan;
}
}  // namespace

Forest train_forest(const Dataset& data, const TrainParams& params) {
  return train_forest_trees(data, params, TreeRange{0, params.M});
}

Forest train_forest_trees(const Dataset& data, const TrainParams& params, TreeRange range) {
  const auto t0 = Clock::now();
  validate_for_training(data, params);
  range.validate(params.M, "tree range");
  const int count = range.size();
  const detail::MemoryPlan plan = checked_memory_plan(data, params);
  const detail::TestSampler sampler(data);
  Forest forest;
  forest.width = data.width;
  forest.height = data.height;
  forest.classes = data.classes;
  forest.features = data.features;
  forest.textons = params.textons;
  forest.params = params;
  forest.trees.resize(static_cast<std::size_t>(count));
  std::vector<double> tree_seconds(static_cast<std::size_t>(count), 0.0);

  // Trees in batches of as many as the budget holds: a batch's corpora are filled in one pass over
  // the frames, then its trees grow in parallel; the next batch fills the same matrices. Tree t is the same
  // whichever range or batch it is trained in: its draws depend on (seed, t) only.
  Progress progress("train trees", count, params.progress);
  const int batch = static_cast<int>(plan.trees_at_once);
  // The value matrices, kept from batch to batch: a fresh one costs the faults and zeroing of its
  // pages again (1.8 GB a tree for the CamVid headline forest, whose batches hold one tree each).
  struct Matrix {
    std::unique_ptr<float[]> rows;
    std::size_t values = 0;
  };
  std::vector<Matrix> matrices;
  for (int first = range.begin; first < range.end; first += batch) {
    const int in_batch = std::min(batch, range.end - first);
    const auto tb = Clock::now();
    std::vector<Corpus> corpora(static_cast<std::size_t>(in_batch));
    tbb::parallel_for(0, in_batch, [&](int i) {
      corpora[static_cast<std::size_t>(i)] = detail::draw_corpus(data, params, sampler, first + i);
    });
    matrices.resize(corpora.size());  // a smaller last batch frees the matrices it does not need
    std::vector<const Corpus*> corpus_ptrs;
    std::vector<float*> row_ptrs;
    for (std::size_t i = 0; i < corpora.size(); ++i) {
      const std::size_t values = std::max<std::size_t>(1, corpora[i].tests.size() * corpora[i].candidates.size());
      if (matrices[i].values != values) matrices[i] = {std::make_unique_for_overwrite<float[]>(values), values};
      corpus_ptrs.push_back(&corpora[i]);
      row_ptrs.push_back(matrices[i].rows.get());
    }
    detail::fill_rows(data, corpus_ptrs, row_ptrs);
    const double fill_seconds = seconds_since(tb) / in_batch;
    tbb::parallel_for(0, in_batch, [&](int i) {
      const auto tt = Clock::now();
      const auto slot = static_cast<std::size_t>(first + i - range.begin);
      forest.trees[slot] = Grower(corpora[static_cast<std::size_t>(i)], row_ptrs[static_cast<std::size_t>(i)],
                                  params.n_min, tree_seed(params.seed, first + i), params.score).grow();
      tree_seconds[slot] = fill_seconds + seconds_since(tt);
      progress.tick();
    });
    const auto tl = Clock::now();
    detail::count_leaf_tests(data, params, sampler,
                             std::span(forest.trees).subspan(static_cast<std::size_t>(first - range.begin),
                                                             static_cast<std::size_t>(in_batch)),
                             first);
    for (int i = 0; i < in_batch; ++i) tree_seconds[static_cast<std::size_t>(first + i - range.begin)] += seconds_since(tl) / in_batch;
  }
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

