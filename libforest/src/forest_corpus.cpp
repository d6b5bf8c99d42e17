// Training corpora in bounded memory (see forest_corpus.hpp).
#include "forest_corpus.hpp"

#include <algorithm>
#include <cmath>

#include <oneapi/tbb/enumerable_thread_specific.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include "smseg/common/error.hpp"
#include "smseg/forest/rng.hpp"

namespace smseg::forest::detail {

namespace {
void release(const FrameData& frame) {
  if (frame.release) frame.release();
}
}  // namespace

TestSampler::TestSampler(const Dataset& data)
    : data_(data), C_(data.classes.size()), H_(static_cast<std::size_t>(data.height)) {
  const std::size_t W = static_cast<std::size_t>(data.width);
  rows_.resize(data.frames.size());
  class_cum_.assign(C_, std::vector<std::uint64_t>(data.frames.size(), 0));
  tbb::parallel_for(std::size_t{0}, data.frames.size(), [&](std::size_t fi) {
    std::vector<std::uint32_t>& r = rows_[fi];
    r.assign((C_ + 1) * (H_ + 1), 0);
    const std::uint8_t* lab = data.frames[fi].labels;
    std::vector<std::uint32_t> row(C_ + 1);
    for (std::size_t y = 0; y < H_; ++y) {
      std::fill(row.begin(), row.end(), 0u);
      for (std::size_t x = 0; x < W; ++x) {
        const std::uint8_t l = lab[y * W + x];
        if (l != kVoidLabel) ++row[l];
      }
      for (std::size_t k = 0; k < C_; ++k) row[C_] += row[k];
      for (std::size_t k = 0; k <= C_; ++k) r[k * (H_ + 1) + y + 1] = r[k * (H_ + 1) + y] + row[k];
    }
    release(data.frames[fi]);
  });
  for (std::size_t fi = 0; fi < rows_.size(); ++fi) {
    if (cum(fi, C_)[H_] > 0) nonempty_.push_back(static_cast<int>(fi));
    for (std::size_t c = 0; c < C_; ++c) class_cum_[c][fi] = (fi ? class_cum_[c][fi - 1] : 0) + cum(fi, c)[H_];
  }
  for (std::size_t c = 0; c < C_; ++c)
    if (!rows_.empty() && class_cum_[c].back() > 0) present_.push_back(static_cast<int>(c));
  if (nonempty_.empty()) throw Error("training data", "labels", "no labelled (non-void) pixel in any frame");
  // Integer weights (1/1024 steps of sqrt(pixels)), so the draw is exact and the same everywhere.
  for (const int c : present_) {
    const auto w = static_cast<std::uint64_t>(std::llround(1024.0 * std::sqrt(double(class_cum_[std::size_t(c)].back()))));
    sqrt_cum_.push_back((sqrt_cum_.empty() ? 0 : sqrt_cum_.back()) + std::max<std::uint64_t>(w, 1));
  }
}

std::size_t TestSampler::bytes(const Dataset& data) {
  const std::size_t C = data.classes.size();
  return data.frames.size() * ((C + 1) * (static_cast<std::size_t>(data.height) + 1) * 4 + C * 8 + 64);
}

const std::uint32_t* TestSampler::cum(std::size_t fi, std::size_t k) const {
  return rows_[fi].data() + k * (H_ + 1);
}

std::uint32_t TestSampler::select(std::size_t fi, std::size_t k, std::uint64_t rank) const {
  const std::uint32_t* c = cum(fi, k);
  // The row: the last y with c[y] <= rank (c[0] = 0 <= rank < c[H]).
  const std::size_t y = static_cast<std::size_t>(std::upper_bound(c, c + H_ + 1, rank) - c) - 1;
  std::uint64_t left = rank - c[y];
  const std::size_t W = static_cast<std::size_t>(data_.width);
  const std::uint8_t* lab = data_.frames[fi].labels + y * W;
  for (std::size_t x = 0; x < W; ++x) {
    if (lab[x] == k && left-- == 0) return static_cast<std::uint32_t>(y * W + x);
  }
  throw Error("training data", "labels", "changed while training");  // the counts came from these labels
}

TestPoint TestSampler::draw(Rng& rng, Balance balance) const {
  std::size_t fi = 0;
  std::uint32_t p = 0;
  if (balance == Balance::Classes || balance == Balance::Sqrt) {
    std::size_t which = 0;
    if (balance == Balance::Classes) {
      which = rng.below(present_.size());
    } else {
      const std::uint64_t w = rng.below(sqrt_cum_.back());
      which = static_cast<std::size_t>(std::upper_bound(sqrt_cum_.begin(), sqrt_cum_.end(), w) - sqrt_cum_.begin());
    }
    const auto c = static_cast<std::size_t>(present_[which]);
    const auto& cc = class_cum_[c];
    const std::uint64_t r = rng.below(cc.back());
    fi = static_cast<std::size_t>(std::upper_bound(cc.begin(), cc.end(), r) - cc.begin());
    const std::uint64_t before = fi ? cc[fi - 1] : 0;
    p = select(fi, c, r - before);
  } else {
    fi = static_cast<std::size_t>(nonempty_[rng.below(nonempty_.size())]);
    // The rank counts the frame's non-void pixels grouped by class (class 0's in raster order, then
    // class 1's, ...): the order the thesis-style draw has always used.
    std::uint64_t rank = rng.below(cum(fi, C_)[H_]);
    std::size_t c = 0;
    while (rank >= cum(fi, c)[H_]) rank -= cum(fi, c++)[H_];
    p = select(fi, c, rank);
  }
  TestPoint t;
  t.frame = static_cast<int>(fi);
  t.x = static_cast<int>(p % static_cast<std::uint32_t>(data_.width));
  t.y = static_cast<int>(p / static_cast<std::uint32_t>(data_.width));
  t.label = data_.frames[fi].labels[p];
  return t;
}

Corpus draw_corpus(const Dataset& data, const TrainParams& params, const TestSampler& sampler, int tree) {
  Rng rng(tree_seed(params.seed, tree));
  const WindowSampler windows(params.windows, WindowBounds::for_image(data.width, data.height));
  const int Ks = params.ks(), Kt = params.kt();
  const int F = static_cast<int>(data.features.size());
  std::vector<Window> wins(static_cast<std::size_t>(Ks));
  for (auto& w : wins) w = windows.draw(rng);
  std::vector<Window> offsets;
  if (params.textons) {
    offsets.resize(static_cast<std::size_t>(Ks));
    for (auto& o : offsets) windows.draw_offset(rng, o.dx, o.dy);
  }
  Corpus corpus;
  corpus.num_classes = static_cast<int>(data.classes.size());
  corpus.tests.resize(static_cast<std::size_t>(Kt));
  for (auto& t : corpus.tests) t = sampler.draw(rng, params.balance);
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
  return corpus;
}

namespace {
// A frame's summed-area tables as fill_row reads them: feature f's value at cell i is
// at[f][i * stride]. Either the tables as they are (stride 1), or a copy with the features of a cell
// side by side (stride F, interleave_tables).
struct TableView {
  std::vector<const double*> at;
  std::size_t stride = 1;
};

std::size_t table_cells(const FrameData& frame) {
  return (static_cast<std::size_t>(frame.width) + 1) * (static_cast<std::size_t>(frame.height) + 1);
}

// The frame's tables cell by cell, features side by side: out[cell * F + f] = sats[f][cell]. A test
// reads every feature at the same four corners; one table per feature puts those reads in 4 F cache
// lines, this copy in 4 to 8.
TableView interleave_tables(const FrameData& frame, std::vector<double>& out) {
  const std::size_t cells = table_cells(frame), F = frame.sats.size();
  out.resize(cells * F);
  TableView view{std::vector<const double*>(F), F};
  for (std::size_t f = 0; f < F; ++f) view.at[f] = out.data() + f;
  // In blocks of cells whose copy stays in L1 (256 cells of 15 features: 30 KB): each table is read in
  // order and each block written while cached. Feature by feature over the whole frame, every write
  // went to a line long evicted (a fifth of the headline forest's training time, 2026-12-07).
  constexpr std::size_t kCells = 256;
  for (std::size_t b = 0; b < cells; b += kCells) {
    const std::size_t e = std::min(cells, b + kCells);
    for (std::size_t f = 0; f < F; ++f) {
      const double* sat = frame.sats[f];
      double* to = out.data() + f;
      for (std::size_t i = b; i < e; ++i) to[i * F] = sat[i];
    }
  }
  return view;
}

// Every candidate's value at one test, into its row: window candidates from the tables (the corners
// window_sum() reads, in its order: the classifier's sums, bit for bit), texton candidates from the
// greyscale image. Candidates come window by window, so the clipped corners are found once per window
// and serve its run of features.
void fill_row(const FrameData& frame, const TableView& tables, const Corpus& corpus, const TestPoint& t, float* row) {
  const int W = frame.width, H = frame.height;
  const std::size_t S = static_cast<std::size_t>(W) + 1, F = frame.sats.size(), step = tables.stride;
  const Candidate* cands = corpus.candidates.data();
  const std::size_t n = corpus.candidates.size();
  std::size_t c = 0;
  while (c < n && static_cast<std::size_t>(cands[c].feature) < F) {
    const Window& win = cands[c].win;
    const RelRect r = rel_rect(win);
    const std::size_t xa = static_cast<std::size_t>(std::clamp(t.x + r.x0, 0, W));
    const std::size_t xb = static_cast<std::size_t>(std::clamp(t.x + r.x1, 0, W));
    const std::size_t ta = static_cast<std::size_t>(std::clamp(t.y + r.y0, 0, H)) * S;
    const std::size_t tb = static_cast<std::size_t>(std::clamp(t.y + r.y1, 0, H)) * S;
    const std::size_t bb = (tb + xb) * step, ab = (ta + xb) * step, ba = (tb + xa) * step, aa = (ta + xa) * step;
    for (; c < n && cands[c].win == win && static_cast<std::size_t>(cands[c].feature) < F; ++c) {
      const double* sat = tables.at[static_cast<std::size_t>(cands[c].feature)];
      row[c] = static_cast<float>((sat[bb] - sat[ab]) - (sat[ba] - sat[aa]));
    }
  }
  for (; c < n; ++c) row[c] = attribute_value(frame, cands[c].feature, cands[c].win, t.x, t.y);
}
}  // namespace

void fill_rows(const Dataset& data, std::span<const Corpus* const> corpora, std::span<float* const> rows) {
  // Per frame, the (corpus, test) pairs that lie in it.
  struct Ref {
    std::uint32_t corpus, test;
  };
  std::vector<std::vector<Ref>> by_frame(data.frames.size());
  for (std::size_t i = 0; i < corpora.size(); ++i)
    for (std::size_t t = 0; t < corpora[i]->tests.size(); ++t)
      by_frame[static_cast<std::size_t>(corpora[i]->tests[t].frame)].push_back(
          {static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(t)});
  tbb::enumerable_thread_specific<std::vector<double>> interleaved;  // one copy per thread, reused
  tbb::parallel_for(std::size_t{0}, data.frames.size(), [&](std::size_t fi) {
    std::vector<Ref>& refs = by_frame[fi];
    if (refs.empty()) return;
    const FrameData& frame = data.frames[fi];
    // Tests in raster order, whichever tree they belong to: the next test's windows lie near the
    // last one's. (Each writes its own row: the order changes no value.)
    const auto at = [&](const Ref& r) { const TestPoint& t = corpora[r.corpus]->tests[r.test]; return std::pair(t.y, t.x); };
    std::sort(refs.begin(), refs.end(), [&](const Ref& a, const Ref& b) { return at(a) < at(b); });
    // The interleaved copy pays when the tests read at least as many values as it copies.
    std::size_t reads = 0;
    for (const Ref& r : refs) reads += corpora[r.corpus]->candidates.size() * 4;
    const TableView tables = reads >= table_cells(frame) * frame.sats.size()
                                 ? interleave_tables(frame, interleaved.local())
                                 : TableView{frame.sats, 1};
    for (const Ref& r : refs) {
      const Corpus& c = *corpora[r.corpus];
      fill_row(frame, tables, c, c.tests[r.test], rows[r.corpus] + std::size_t{r.test} * c.candidates.size());
    }
    release(frame);
  });
}

MemoryPlan plan_memory(const Dataset& data, const TrainParams& params) {
  const std::size_t candidates =
      static_cast<std::size_t>(params.ks()) * (data.features.size() + (params.textons ? kNumTextonTests : 0));
  const std::size_t kt = static_cast<std::size_t>(params.kt());
  const std::size_t cells = static_cast<std::size_t>(data.width + 1) * static_cast<std::size_t>(data.height + 1);
  const std::size_t pixels = static_cast<std::size_t>(data.width) * static_cast<std::size_t>(data.height);
  // A frame being read: its mapped tables and images, and the interleaved copy of its tables.
  const std::size_t frame_bytes = 2 * cells * 8 * data.features.size() + 2 * pixels;
  const auto threads = static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  // The process itself (code, libraries, thread stacks, allocator slack), measured at ~40 MB.
  constexpr std::size_t kProcess = std::size_t{64} << 20;
  MemoryPlan plan;
  plan.fixed_bytes = kProcess + TestSampler::bytes(data) + threads * frame_bytes + data.frames.size() * 256;
  // The value matrix; tests (corpus and per-frame index); the grower's order, labels and x log x
  // table; the tree (at most 2 Kt / n_min nodes of ~100 bytes with their leaf counts).
  // The leaf tests: each with its frame reference and the leaf it reaches.
  plan.per_tree_bytes = kt * candidates * sizeof(float) + kt * (sizeof(TestPoint) + 8) + kt * (4 + 1 + 8) +
                        2 * kt / static_cast<std::size_t>(std::max(1, params.n_min)) * 100 +
                        static_cast<std::size_t>(params.leaf_tests) * (sizeof(TestPoint) + 8 + 4);
  const std::size_t budget = params.memory_mb << 20;
  plan.trees_at_once = budget > plan.fixed_bytes
                           ? std::min<std::size_t>((budget - plan.fixed_bytes) / plan.per_tree_bytes,
                                                   static_cast<std::size_t>(params.M))
                           : 0;
  return plan;
}

}  // namespace smseg::forest::detail
