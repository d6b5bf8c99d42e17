// The classifier's fast path (see classify.hpp): compact breadth-first trees, pixel sets routed tree
// by tree and node by node. The arithmetic is posterior()'s: the same double window
// sums in the same order (window_sum), the same float thresholds, the same float sums of the leaf
// distributions, so the labels and distributions are bit for bit the reference path's.
#include <algorithm>
#include <cstddef>
#include <deque>
#include <new>

#include <sys/mman.h>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include "smseg/common/error.hpp"
#include "smseg/forest/classify.hpp"
#include "forest_simd.hpp"

namespace smseg::forest {

namespace {
constexpr int kMaxClasses = 256;
constexpr std::uint32_t kMaxCompactIndex = (1u << 23) - 1;  // 23 bits of CompactNode::next
// Pixels in flight per tree walk (route_tree): enough independent table reads to hide the cache
// latency, few enough that the lanes stay in registers and L1.
constexpr std::size_t kLanes = 16;
// route_tree asks for the next step's table cells ahead of time when the frame's tables are larger
// than this (bench_eval: CamVid's 8.3 MB gain, the synthetic 320x240 frame's 3.7 MB lose).
constexpr std::size_t kPrefetchTableBytes = std::size_t(6) << 20;

// The children's runs of a split: left [left_b, left_e), right [right_b, right_e).
struct SplitRuns {
  std::uint32_t left_b, left_e, right_b, right_e;
};

// partition_tree's and partition_chunks' walk: depth first from `root`, whose run is [0, count) of
// the caller's entries; at a leaf node at_leaf(node, run), at a split at_split(node, run) gives the
// children's runs (a split's children are adjacent: left, then right). `runs` is the stack.
template <class Nodes, class Runs, class AtLeaf, class AtSplit>
void visit_depth_first(const Nodes* nodes, Runs& runs, std::uint32_t root, std::uint32_t count, std::uint32_t leaf_bit,
                       AtLeaf at_leaf, AtSplit at_split) {
  runs.clear();
  runs.push_back({root, 0, count});
  while (!runs.empty()) {
    const auto r = runs.back();
    runs.pop_back();
    const auto c = nodes[r.node];
    if (c.next & leaf_bit) {
      at_leaf(c, r);
      continue;
    }
    const SplitRuns children = at_split(c, r);
    const std::uint32_t left_child = c.next >> 9;
    runs.push_back({left_child + 1, children.right_b, children.right_e});
    runs.push_back({left_child, children.left_b, children.left_e});
  }
}
}  // namespace

namespace {
std::string target_name(const detail::SimdKernels* kernels) { return kernels ? kernels->name : "scalar"; }
}  // namespace

std::string Classifier::simd_target() const { return target_name(simd_); }

void Classifier::set_simd_target(std::string_view name) { simd_ = detail::simd_kernels(name, "SIMD target"); }

std::vector<std::string> Classifier::simd_targets() { return detail::simd_target_names(); }

std::string Classifier::default_simd_target() { return target_name(detail::default_simd_kernels()); }

void Classifier::build_compact(const Forest& forest) {
  // The vector walk (SimdKernels::walk) reads the nodes as two 64-bit words: the rectangle, then
  // threshold and link.
  static_assert(sizeof(CompactNode) == 16 && offsetof(CompactNode, x0) == 0 && offsetof(CompactNode, y1) == 6 &&
                    offsetof(CompactNode, threshold) == 8 && offsetof(CompactNode, next) == 12,
                "SimdKernels::walk's view of a compact node");
  compact_.reserve(nodes_.size());
  std::size_t base = 0;  // the tree's first index in nodes_
  for (const Tree& tree : forest.trees) {
    // Breadth first: a split's children are taken from the queue one after the other, so they get
    // adjacent places.
    const auto root = static_cast<std::uint32_t>(compact_.size());
    compact_roots_.push_back(root);
    std::deque<std::int32_t> queue{0};
    compact_.emplace_back();
    std::uint32_t at = root;
    while (!queue.empty()) {
      const std::int32_t i = queue.front();
      queue.pop_front();
      const PackedNode& p = nodes_[base + static_cast<std::size_t>(i)];
      CompactNode c{p.x0, p.x1, p.y0, p.y1, p.threshold, 0};
      if (p.feature < 0) {
        c = CompactNode{0, 0, 0, 0, 0.0f, static_cast<std::uint32_t>(p.left) << 9 | kLeafBit};
      } else {
        const auto left = static_cast<std::uint32_t>(compact_.size());
        if (left + 1 > kMaxCompactIndex || p.feature > 255)
          throw Error("", "trees", "the forest is too large for the classifier (2^23 nodes, 256 attributes)");
        c.next = left << 9 | static_cast<std::uint32_t>(p.feature);
        compact_.emplace_back();
        compact_.emplace_back();
        queue.push_back(p.left - static_cast<std::int32_t>(base));
        queue.push_back(p.right - static_cast<std::int32_t>(base));
      }
      if (p.feature < 0 && static_cast<std::uint32_t>(p.left) > kMaxCompactIndex)
        throw Error("", "trees", "the forest has too many leaves for the classifier (2^23)");
      compact_[at++] = c;
    }
    base += tree.nodes.size();
  }
}

// Walks pixels [b, e) of the set through one tree, kLanes at a time (classify_pixels' sets: a few
// pixels scattered over the frame, where partition_tree's runs soon hold one pixel each and each
// split waits for the last one's table read), each lane taking the next pixel as soon as its own
// reaches a leaf, so the lanes' table reads are independent and overlap. A lane keeps its pixel's
// coordinates; a step is the node's test and the move to its child, and only a lane at a leaf (one
// step in ~20 on a CamVid-size forest, so the branch is mostly foreseen) writes and takes a pixel.
// kClamp: corners clipped to the image (window_sum); otherwise every window is inside for every pixel
// and the four reads are at fixed offsets from the pixel's own cell (the same cells, so the same sums).
template <bool kClamp, bool kTextons>
void Classifier::route_tree(const FrameData& frame, const Tables& tables, const Scratch& s, std::size_t b,
                            std::size_t e, std::uint32_t root, std::int32_t* leaf) const {
  if (b >= e) return;
  const CompactNode* nodes = compact_.data();
  const double* const* sats = frame.sats.data();
  const std::int32_t W = width_, H = height_;
  const std::ptrdiff_t S = tables.stride;
  const std::uint32_t F = static_cast<std::uint32_t>(num_features_);
  const std::int32_t* xs = s.xs.data();
  const std::int32_t* ys = s.ys.data();
  const bool prefetch = frame.sats.size() * std::size_t(W + 1) * std::size_t(H + 1) * sizeof(double) > kPrefetchTableBytes;
  std::uint32_t node[kLanes];
  std::int32_t px[kLanes], py[kLanes];
  std::size_t pixel[kLanes];
  std::size_t next = b, live = 0;
  auto start = [&](std::size_t g) {  // lane g takes the set's next pixel from the root, or stops (e)
    node[g] = root;
    pixel[g] = next < e ? next++ : e;
    if (pixel[g] == e) return;
    px[g] = xs[pixel[g]];
    py[g] = ys[pixel[g]];
    ++live;
  };
  for (std::size_t g = 0; g < kLanes; ++g) start(g);
  while (live > 0) {
    for (std::size_t g = 0; g < kLanes; ++g) {
      if (pixel[g] == e) continue;
      const CompactNode c = nodes[node[g]];
      if (c.next & kLeafBit) {
        leaf[pixel[g]] = static_cast<std::int32_t>(c.next >> 9);
        --live;
        start(g);
        continue;
      }
      const std::uint32_t attr = c.next & 0xffu;
      const std::int32_t x = px[g], y = py[g];
      float v;
      if (kTextons && attr >= F) {
        v = texton_value(frame.gray, W, H, x, y, c.x0, c.y0, static_cast<int>(attr - F));
      } else if (kClamp) {
        v = static_cast<float>(window_sum(sats[attr], W, H, x, y, RelRect{c.x0, c.x1, c.y0, c.y1}));
      } else {
        const double* cell = tables.at[attr] + (y * S + x);
        const double* top = cell + c.y0 * S;
        const double* bot = cell + c.y1 * S;
        v = static_cast<float>((bot[c.x1] - top[c.x1]) - (bot[c.x0] - top[c.x0]));
      }
      node[g] = (c.next >> 9) + (v < c.threshold ? 0u : 1u);
      // Asks now for the next step's four corners, read when this lane comes round again (kLanes
      // steps later): the voters are scattered over the frame, so nearly every read misses the
      // caches, and the processor's window alone holds only a few lanes' misses at a time. Tables
      // that mostly stay in the caches (kPrefetchTableBytes) gain nothing from the requests and pay
      // for them, so they are not asked for.
      if (!prefetch) continue;
      const CompactNode d = nodes[node[g]];
      if ((d.next & kLeafBit) || (d.next & 0xffu) >= F) continue;  // a leaf reads no table, a texton test the image
      if constexpr (kClamp) {
        const double* sat = sats[d.next & 0xffu];
        const std::ptrdiff_t xa = std::clamp(x + d.x0, 0, W), xb = std::clamp(x + d.x1, 0, W);
        const std::ptrdiff_t ya = std::clamp(y + d.y0, 0, H) * (W + 1), yb = std::clamp(y + d.y1, 0, H) * (W + 1);
        __builtin_prefetch(sat + ya + xa);
        __builtin_prefetch(sat + ya + xb);
        __builtin_prefetch(sat + yb + xa);
        __builtin_prefetch(sat + yb + xb);
      } else {
        const double* cell = tables.at[d.next & 0xffu] + (y * S + x);
        __builtin_prefetch(cell + d.y0 * S + d.x0);
        __builtin_prefetch(cell + d.y0 * S + d.x1);
        __builtin_prefetch(cell + d.y1 * S + d.x0);
        __builtin_prefetch(cell + d.y1 * S + d.x1);
      }
    }
  }
}

// The scalar split of partition_tree (see there): the tests of run [b, e) first, outcomes to
// s.goes_right, then the stable partition, with no branch on the outcome (each pixel is written to
// both sides, counted on one). Returns the first pixel of the right-hand side.
std::uint32_t Classifier::split_scalar(const FrameData& frame, const double* table, const detail::WindowCorners& w,
                                       const CompactNode& c, bool texton, Scratch& s, std::uint32_t b,
                                       std::uint32_t e) const {
  Scratch::Routed* a = s.routed.data();
  Scratch::Routed* right = s.right.data();
  std::uint8_t* goes_right = s.goes_right.data();
  if (texton) {
    const int texton_index = static_cast<int>((c.next & 0xffu) - static_cast<std::uint32_t>(num_features_));
    for (std::uint32_t i = b; i < e; ++i)
      goes_right[i] = !(texton_value(frame.gray, width_, height_, s.xs[a[i].at], s.ys[a[i].at], c.x0, c.y0,
                                     texton_index) < c.threshold);
  } else {
    for (std::uint32_t i = b; i < e; ++i) {
      const double* cell = table + a[i].cell;
      goes_right[i] =
          !(static_cast<float>((cell[w.bot_b] - cell[w.top_b]) - (cell[w.bot_a] - cell[w.top_a])) < c.threshold);
    }
  }
  std::uint32_t l = b, k = 0;
  for (std::uint32_t i = b; i < e; ++i) {
    const Scratch::Routed p = a[i];
    const std::uint32_t to_right = goes_right[i];
    a[l] = p;
    right[k] = p;
    l += 1u - to_right;
    k += to_right;
  }
  std::copy(right, right + k, a + l);
  return l;
}

// Routes pixels [0, n) of the set through one tree, node by node: at a split, the node's pixels are
// partitioned (stably) into its children's runs, which are split in turn, depth first. A node's
// constants are read once for all its pixels, and the pixels' table reads go through the tables in
// increasing order. A split is two passes: the tests first, outcomes to `goes_right`, then the
// partition. In one pass the store to a[l] (l waits for the last test, which waits for its table
// reads) comes before the next pixel's read of a[i]; the processor holds that read until the store's
// address is known, so every table read waited for the one before (profiled: half of the time).
// Apart, the tests' reads are independent of each other and overlap. Every window of every pixel
// lies inside `tables` (whole frames read the padded copy): the reads are at fixed offsets from the
// pixel's cell.
void Classifier::partition_tree(const FrameData& frame, const Tables& tables, Scratch& s, std::size_t n,
                                std::uint32_t root, std::int32_t* leaf) const {
  if (n == 0) return;
  const std::ptrdiff_t S = tables.stride;
  const std::uint32_t F = static_cast<std::uint32_t>(num_features_);
  s.routed.resize(n);
  s.right.resize(n);
  s.goes_right.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    s.routed[i] = {static_cast<std::int32_t>(s.ys[i] * S + s.xs[i]), static_cast<std::int32_t>(i)};
  const Scratch::Routed* a = s.routed.data();
  auto at_leaf = [&](const CompactNode& c, const Scratch::Run& r) {
    const auto row = static_cast<std::int32_t>(c.next >> 9);
    for (std::uint32_t i = r.b; i < r.e; ++i) leaf[a[i].at] = row;
  };
  auto at_split = [&](const CompactNode& c, const Scratch::Run& r) {
    const std::uint32_t attr = c.next & 0xffu;
    const bool texton = textons_ && attr >= F;
    const detail::WindowCorners corners{c.y0 * S + c.x0, c.y0 * S + c.x1, c.y1 * S + c.x0, c.y1 * S + c.x1};
    const double* table = texton ? nullptr : tables.at[attr];  // a texton test reads the grey image
    const std::uint32_t l = split_scalar(frame, table, corners, c, texton, s, r.b, r.e);
    return SplitRuns{r.b, l, l, r.e};
  };
  visit_depth_first(compact_.data(), s.runs, root, static_cast<std::uint32_t>(n), kLeafBit, at_leaf, at_split);
}

// partition_tree's work in chunk entries, for the SIMD targets: a run holds up to kChunkPixels row
// neighbours per entry (a bit each), so that a split reads each corner of an entry's pixels with one
// or two vector loads, whatever pixels of the chunk still reach the node, and partitions entries
// rather than pixels. A node's pixels are regions of the image: on the CamVid-size forest an entry
// holds 11 of its 16 pixels on average (2.5 million entries a frame against 3.6 million 8-pixel
// blocks of single pixels, a fifth of which were not row neighbours and needed gathers).
void Classifier::partition_chunks(const FrameData& frame, const Tables& tables, const Tile& tile, Scratch& s,
                                  std::uint32_t root, std::int32_t* leaf) const {
  constexpr int P = detail::kChunkPixels;
  const std::ptrdiff_t S = tables.stride;
  const std::uint32_t F = static_cast<std::uint32_t>(num_features_);
  const int per_row = (tile.width + P - 1) / P;
  const std::size_t count = static_cast<std::size_t>(per_row) * static_cast<std::size_t>(tile.height);
  s.chunks.resize(std::max(s.chunks.size(), 2 * count));
  s.chunks_spare.resize(count);
  s.chunk_cell.resize(count);
  for (int ty = 0, i = 0; ty < tile.height; ++ty)
    for (int c = 0; c < per_row; ++c, ++i) {
      const int in_row = std::min(P, tile.width - c * P);  // the row's last chunk may be short
      s.chunks[i] = {static_cast<std::uint16_t>(i), static_cast<std::uint16_t>((1u << in_row) - 1u)};
      s.chunk_cell[i] = static_cast<std::int32_t>((tile.y0 + ty) * S + tile.x0 + c * P);
    }
  auto at_leaf = [&](const CompactNode& c, const Scratch::Run& r) {
    simd_->leaf_rows(s.chunks.data(), r.b, r.e, static_cast<std::int32_t>(c.next >> 9), per_row, tile.width, leaf);
  };
  auto at_split = [&](const CompactNode& c, const Scratch::Run& r) {
    // The children's runs take the parent's place and may need up to twice its room (a chunk whose
    // pixels go both ways is in both). The run split is always the last one in s.chunks: the pending
    // runs lie below it, the left child goes on top of the right.
    if (s.chunks.size() < r.b + 2 * (r.e - r.b)) s.chunks.resize(std::max<std::size_t>(r.b + 2 * (r.e - r.b), 2 * s.chunks.size()));
    const std::uint32_t attr = c.next & 0xffu;
    std::uint32_t m, end;
    if (textons_ && attr >= F) {
      m = split_chunks_texton(frame, tile, c, s, r.b, r.e, &end);
    } else {
      const detail::WindowCorners corners{c.y0 * S + c.x0, c.y0 * S + c.x1, c.y1 * S + c.x0, c.y1 * S + c.x1};
      m = simd_->split_chunks(s.chunks.data(), s.chunks_spare.data(), r.b, r.e, s.chunk_cell.data(), tables.at[attr],
                              corners, detail::float_bound(c.threshold), &end);
    }
    return SplitRuns{m, end, r.b, m};
  };
  visit_depth_first(compact_.data(), s.runs, root, static_cast<std::uint32_t>(count), kLeafBit, at_leaf, at_split);
}

std::uint32_t Classifier::split_chunks_texton(const FrameData& frame, const Tile& tile, const CompactNode& c,
                                              Scratch& s, std::uint32_t b, std::uint32_t e, std::uint32_t* end) const {
  constexpr int P = detail::kChunkPixels;
  const int per_row = (tile.width + P - 1) / P;
  const int test = static_cast<int>((c.next & 0xffu) - static_cast<std::uint32_t>(num_features_));
  for (std::uint32_t i = b; i < e; ++i) {
    const detail::ChunkEntry entry = s.chunks[i];
    const int y = tile.y0 + entry.chunk / per_row, x0 = tile.x0 + entry.chunk % per_row * P;
    std::uint32_t to_right = 0;
    for (std::uint32_t bits = entry.bits; bits; bits &= bits - 1) {
      const int lane = std::countr_zero(bits);
      if (!(texton_value(frame.gray, width_, height_, x0 + lane, y, c.x0, c.y0, test) < c.threshold)) to_right |= 1u << lane;
    }
    s.chunks_spare[i - b].bits = static_cast<std::uint16_t>(to_right);
  }
  return detail::split_entries(s.chunks.data(), s.chunks_spare.data(), b, e, end);
}

std::size_t Classifier::order_inside_first(Scratch& s, std::size_t n) const {
  s.index.resize(n);
  std::vector<std::int32_t> xs(n), ys(n);
  std::size_t in = 0;
  for (std::size_t i = 0; i < n; ++i) in += inside(s.xs[i], s.ys[i]);
  for (std::size_t i = 0, a = 0, b = in; i < n; ++i) {
    const std::size_t to = inside(s.xs[i], s.ys[i]) ? a++ : b++;
    xs[to] = s.xs[i];
    ys[to] = s.ys[i];
    s.index[to] = static_cast<std::uint32_t>(i);
  }
  s.xs.swap(xs);
  s.ys.swap(ys);
  return in;
}

void Classifier::classify_set(const FrameData& frame, const Tables& tables, Scratch& s, std::size_t n,
                              std::size_t inside, bool with_dists, const Tile* tile) const {
  const std::size_t C = static_cast<std::size_t>(num_classes_), Cp = static_cast<std::size_t>(padded_classes_);
  const std::size_t M = compact_roots_.size();
  s.leaf.resize(n * M + detail::kChunkPixels);  // (SimdKernels::leaf_rows' room past the last tree)
  s.labels.resize(n);
  s.dists.resize(with_dists ? n * C : 0);
  const bool walked = !tile && simd_ && !textons_ &&
                      simd_->walk(compact_.data(), compact_roots_.data(), M, frame.sats.data(), frame.sats.size(), width_,
                                  height_, s.xs.data(), s.ys.data(), n, s.leaf.data());
  for (std::size_t t = 0; t < M && !walked; ++t) {
    std::int32_t* leaf = s.leaf.data() + t * n;
    const std::uint32_t root = compact_roots_[t];
    if (tile && simd_) {
      partition_chunks(frame, tables, *tile, s, root, leaf);  // every pixel inside (inside == n)
    } else if (tile) {
      partition_tree(frame, tables, s, n, root, leaf);
    } else if (textons_) {
      route_tree<false, true>(frame, tables, s, 0, inside, root, leaf);
      route_tree<true, true>(frame, tables, s, inside, n, root, leaf);
    } else {
      route_tree<false, false>(frame, tables, s, 0, inside, root, leaf);
      route_tree<true, false>(frame, tables, s, inside, n, root, leaf);
    }
  }
  std::uint8_t* labels = s.labels.data();
  float* dists = with_dists ? s.dists.data() : nullptr;
  if (simd_ && Cp <= 16) {
    simd_->sum_votes(leaf_probs_.data(), Cp, C, s.leaf.data(), n, M, labels, dists);
    return;
  }
  // Summed distributions, trees in order (the same float sums as posterior()), then the MAP class.
  float acc[kMaxClasses + 4];
  const float* probs = leaf_probs_.data();
  for (std::size_t i = 0; i < n; ++i) {
    const float* q0 = probs + static_cast<std::size_t>(s.leaf[i]) * Cp;
    for (std::size_t c = 0; c < Cp; ++c) acc[c] = q0[c];  // = 0.0f + q0[c]
    for (std::size_t t = 1; t < M; ++t) {
      const float* q = probs + static_cast<std::size_t>(s.leaf[t * n + i]) * Cp;
      for (std::size_t c = 0; c < Cp; ++c) acc[c] += q[c];
    }
    std::size_t best = 0;
    for (std::size_t c = 1; c < C; ++c)
      if (acc[c] > acc[best]) best = c;
    labels[i] = static_cast<std::uint8_t>(best);
    if (dists) std::copy(acc, acc + C, dists + i * C);
  }
}

Classifier::PaddedTables::~PaddedTables() {
  if (data_) ::munmap(data_, bytes_);
}

void Classifier::PaddedTables::reserve(std::size_t values) {
  constexpr std::size_t kHugePage = std::size_t(2) << 20;
  const std::size_t need = (values * sizeof(double) + kHugePage - 1) / kHugePage * kHugePage;
  if (need <= bytes_) return;
  if (data_) ::munmap(data_, bytes_);
  data_ = nullptr;
  bytes_ = 0;
  void* p = ::mmap(nullptr, need, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (p == MAP_FAILED) throw std::bad_alloc();
  ::madvise(p, need, MADV_HUGEPAGE);  // a hint: without it (or without THP) the copy works the same
  data_ = static_cast<double*>(p);
  bytes_ = need;
}

Classifier::Tables Classifier::PaddedTables::fill(const FrameData& frame, int pad_x, int pad_y) {
  const int W = frame.width, H = frame.height;
  // kChunkPixels more columns on the right: partition_chunks' row-end chunks read past the row.
  const std::ptrdiff_t stride = W + 1 + 2 * pad_x + detail::kChunkPixels, rows = H + 1 + 2 * pad_y, size = rows * stride;
  const std::size_t F = frame.sats.size();
  reserve(F * static_cast<std::size_t>(size));
  at_.resize(F);
  for (std::size_t f = 0; f < F; ++f) at_[f] = data_ + f * static_cast<std::size_t>(size) + pad_y * stride + pad_x;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, F * static_cast<std::size_t>(rows)),
                    [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const std::size_t f = i / static_cast<std::size_t>(rows);
      const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(i % static_cast<std::size_t>(rows));
      const double* src = frame.sats[f] + std::clamp<std::ptrdiff_t>(row - pad_y, 0, H) * (W + 1);
      double* dst = data_ + f * static_cast<std::size_t>(size) + row * stride;
      std::fill(dst, dst + pad_x, src[0]);
      std::copy(src, src + W + 1, dst + pad_x);
      std::fill(dst + pad_x + W + 1, dst + stride, src[W]);
    }
  });
  return {at_.data(), stride};
}

}  // namespace smseg::forest
