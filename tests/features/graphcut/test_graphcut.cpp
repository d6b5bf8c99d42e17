// Graph cuts: max-flow against brute-force minimum cuts, alpha-expansion against brute-force minima
// and against every expansion move.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "smseg/common/error.hpp"
#include "smseg/graphcut/graphcut.hpp"

using namespace smseg;
using namespace smseg::graphcut;

namespace {

FlowGraph random_flow_graph(std::mt19937_64& g, int n) {
  std::uniform_real_distribution<double> cap(0, 10);
  std::bernoulli_distribution sparse(0.3), edge(0.5);
  FlowGraph fg;
  for (int i = 0; i < n; ++i) {
    fg.source.push_back(sparse(g) ? 0.0 : cap(g));
    fg.sink.push_back(sparse(g) ? 0.0 : cap(g));
  }
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if (edge(g)) fg.edges.push_back({i, j, sparse(g) ? 0.0 : cap(g), sparse(g) ? 0.0 : cap(g)});
  return fg;
}

double brute_force_min_cut(const FlowGraph& fg) {
  const int n = fg.nodes();
  double best = INFINITY;
  std::vector<std::uint8_t> side(static_cast<std::size_t>(n));
  for (unsigned mask = 0; mask < (1u << n); ++mask) {
    for (int i = 0; i < n; ++i) side[std::size_t(i)] = (mask >> i) & 1u;
    best = std::min(best, cut_capacity(fg, side));
  }
  return best;
}

// A w x h 4-connected grid with random unary costs in [0, 10) and random weights in [0, wmax).
PottsEnergy random_grid(std::mt19937_64& g, int w, int h, int labels, double wmax) {
  std::uniform_real_distribution<double> cost(0, 10), weight(0, wmax);
  PottsEnergy e;
  e.nodes = w * h;
  e.labels = labels;
  for (int k = 0; k < e.nodes * labels; ++k) e.unary.push_back(cost(g));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (x + 1 < w) e.edges.push_back({y * w + x, y * w + x + 1, weight(g)});
      if (y + 1 < h) e.edges.push_back({y * w + x, (y + 1) * w + x, weight(g)});
    }
  return e;
}

}  // namespace

TEST(GraphCut, MaxFlowEqualsBruteForceMinCutOnTinyRandomGraphs) {
  std::mt19937_64 g(7);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 1 + trial % 9;
    const FlowGraph fg = random_flow_graph(g, n);
    std::vector<std::uint8_t> side;
    const double flow = max_flow(fg, &side);
    const double brute = brute_force_min_cut(fg);
    ASSERT_NEAR(flow, brute, 1e-9 * (1 + brute)) << "trial " << trial;
    // The cut returned is a minimum cut.
    ASSERT_NEAR(cut_capacity(fg, side), brute, 1e-9 * (1 + brute)) << "trial " << trial;
  }
}

TEST(GraphCut, MaxFlowOfAChainIsItsWeakestLink) {
  FlowGraph fg;
  fg.source = {5, 0, 0, 0};
  fg.sink = {0, 0, 0, 6};
  fg.edges = {{0, 1, 4, 0}, {1, 2, 1.5, 0}, {2, 3, 3, 0}};
  std::vector<std::uint8_t> side;
  EXPECT_DOUBLE_EQ(max_flow(fg, &side), 1.5);
  EXPECT_EQ(side, (std::vector<std::uint8_t>{0, 0, 1, 1}));
}

TEST(GraphCut, BadGraphsAreErrors) {
  FlowGraph fg;
  fg.source = {1, 2};
  fg.sink = {1};
  EXPECT_THROW(max_flow(fg), Error);
  fg.sink = {1, -1};
  EXPECT_THROW(max_flow(fg), Error);
  fg.sink = {1, 1};
  fg.edges = {{0, 2, 1, 1}};
  EXPECT_THROW(max_flow(fg), Error);
  fg.edges = {{0, 1, NAN, 1}};
  EXPECT_THROW(max_flow(fg), Error);

  PottsEnergy e;
  e.nodes = 2;
  e.labels = 2;
  e.unary = {0, 1, 1};
  std::vector<int> l;
  EXPECT_THROW(alpha_expansion(e, l), Error);
  e.unary = {0, 1, 1, INFINITY};
  EXPECT_THROW(alpha_expansion(e, l), Error);
  e.unary = {0, 1, 1, 0};
  e.edges = {{0, 1, -1}};
  EXPECT_THROW(alpha_expansion(e, l), Error);
  e.edges = {{1, 1, 1}};
  EXPECT_THROW(alpha_expansion(e, l), Error);
  e.edges = {{0, 1, 1}};
  l = {0, 5};
  EXPECT_THROW(alpha_expansion(e, l), Error);
  l.clear();
  ExpansionOptions opt;
  opt.max_cycles = 0;
  EXPECT_THROW(alpha_expansion(e, l, opt), Error);
}

TEST(GraphCut, TwoLabelExpansionReachesTheGlobalMinimum) {
  // With two labels one expansion move is the whole binary problem, solved exactly.
  std::mt19937_64 g(3);
  for (int trial = 0; trial < 40; ++trial) {
    const PottsEnergy e = random_grid(g, 4, 3, 2, 8);
    std::vector<int> l;
    const ExpansionReport r = alpha_expansion(e, l);
    const double best = brute_force_minimum(e);
    ASSERT_NEAR(r.energy, best, 1e-9) << "trial " << trial;
    ASSERT_NEAR(e.energy(l), r.energy, 1e-9);
  }
}

TEST(GraphCut, ExpansionNeverRaisesTheEnergyAndStaysWithinTwiceTheOptimum) {
  std::mt19937_64 g(11);
  int optimal = 0;
  const int trials = 60;
  for (int trial = 0; trial < trials; ++trial) {
    const int labels = 3 + trial % 2;
    const PottsEnergy e = random_grid(g, 3, 3, labels, 12);
    // Start from a random labelling.
    std::vector<int> l(9);
    std::uniform_int_distribution<int> pick(0, labels - 1);
    for (int& v : l) v = pick(g);
    const double start = e.energy(l);
    const ExpansionReport r = alpha_expansion(e, l);
    ASSERT_NEAR(r.initial_energy, start, 1e-9);
    ASSERT_LE(r.energy, r.initial_energy);
    double prev = r.initial_energy;
    for (double c : r.per_cycle) {
      ASSERT_LE(c, prev);
      prev = c;
    }
    ASSERT_NEAR(e.energy(l), r.energy, 1e-9);
    const double best = brute_force_minimum(e);
    ASSERT_GE(r.energy, best - 1e-9);
    ASSERT_LE(r.energy, 2 * best + 1e-9) << "trial " << trial;  // Boykov et al. 2001, Potts, D >= 0
    if (r.energy <= best + 1e-9) ++optimal;
  }
  // On these small grids expansion almost always finds the optimum itself.
  EXPECT_GE(optimal, trials * 8 / 10);
}

TEST(GraphCut, ExpansionEndsWhereNoExpansionMoveHelps) {
  // At convergence, no choice of nodes switching to any alpha lowers the energy (checked over every
  // subset): each move was solved exactly.
  std::mt19937_64 g(5);
  for (int trial = 0; trial < 15; ++trial) {
    const PottsEnergy e = random_grid(g, 4, 2, 3, 15);
    std::vector<int> l;
    const ExpansionReport r = alpha_expansion(e, l, {.max_cycles = 50});
    for (int alpha = 0; alpha < e.labels; ++alpha)
      for (unsigned mask = 0; mask < (1u << e.nodes); ++mask) {
        std::vector<int> m = l;
        for (int i = 0; i < e.nodes; ++i)
          if ((mask >> i) & 1u) m[std::size_t(i)] = alpha;
        ASSERT_GE(e.energy(m), r.energy - 1e-9) << "trial " << trial << " alpha " << alpha << " mask " << mask;
      }
  }
}

TEST(GraphCut, OneExpansionMoveIsTheBestOfAllItsSubsets) {
  // From random labellings, one move to alpha reaches the least energy over every subset of nodes
  // switching to alpha (brute force), or keeps the labelling when none lowers it.
  std::mt19937_64 g(13);
  int improved = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int labels = 3 + trial % 2;
    const PottsEnergy e = random_grid(g, 4, 3, labels, 6);
    std::vector<int> l(std::size_t(e.nodes));
    std::uniform_int_distribution<int> pick(0, labels - 1);
    for (int& v : l) v = pick(g);
    const int alpha = trial % labels;
    double best = e.energy(l);
    for (unsigned mask = 0; mask < (1u << e.nodes); ++mask) {
      std::vector<int> m = l;
      for (int i = 0; i < e.nodes; ++i)
        if ((mask >> i) & 1u) m[std::size_t(i)] = alpha;
      best = std::min(best, e.energy(m));
    }
    const double before = e.energy(l);
    const bool changed = expansion_move(e, l, alpha);
    ASSERT_NEAR(e.energy(l), best, 1e-9) << "trial " << trial;
    ASSERT_EQ(changed, best < before - 1e-12);
    improved += changed;
  }
  EXPECT_GT(improved, 100);  // the moves do something
}

TEST(GraphCut, StrongSmoothnessCleansANoisyBlock) {
  // A 12x12 two-region picture whose unaries are flipped at scattered pixels: smoothing restores it.
  const int W = 12, H = 12;
  PottsEnergy e;
  e.nodes = W * H;
  e.labels = 3;
  std::vector<int> truth(std::size_t(W * H));
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int t = x < 6 ? 0 : (y < 6 ? 1 : 2);
      truth[std::size_t(y * W + x)] = t;
      const bool noisy = (x * 7 + y * 3) % 11 == 0;
      const int seen = noisy ? (t + 1) % 3 : t;
      for (int c = 0; c < 3; ++c) e.unary.push_back(c == seen ? 0.0 : 1.0);
      if (x + 1 < W) e.edges.push_back({y * W + x, y * W + x + 1, 0.6});
      if (y + 1 < H) e.edges.push_back({y * W + x, (y + 1) * W + x, 0.6});
    }
  std::vector<int> l;
  alpha_expansion(e, l);
  EXPECT_EQ(l, truth);
}

namespace {

// Plain alpha-expansion as the solver did before it left nodes out of its cuts: every node not at
// alpha in every move's graph, the whole graph cut in double precision (max_flow), moves in label
// order, a move kept when it lowers the energy, until L moves in a row change nothing or max_cycles.
std::vector<double> reference_expansion(const PottsEnergy& e, std::vector<int>& l, int max_cycles) {
  std::vector<double> per_cycle;
  int unchanged_in_a_row = 0;
  for (int cycle = 0; cycle < max_cycles && unchanged_in_a_row < e.labels; ++cycle) {
    bool changed = false;
    for (int alpha = 0; alpha < e.labels && unchanged_in_a_row < e.labels; ++alpha) {
      FlowGraph fg;
      fg.source.assign(std::size_t(e.nodes), 0.0);
      fg.sink.assign(std::size_t(e.nodes), 0.0);
      std::vector<double> e0(std::size_t(e.nodes)), e1(std::size_t(e.nodes));
      for (int i = 0; i < e.nodes; ++i) {
        e0[std::size_t(i)] = e.unary_at(i, l[std::size_t(i)]);
        e1[std::size_t(i)] = l[std::size_t(i)] == alpha ? e0[std::size_t(i)] + 1e9 : e.unary_at(i, alpha);
      }
      for (const auto& ed : e.edges) {  // E(x_i, x_j) = w [label(x_i) != label(x_j)], x = 1: alpha
        const double a = l[std::size_t(ed.i)] != l[std::size_t(ed.j)] ? ed.weight : 0.0;  // E(0,0)
        const double b = l[std::size_t(ed.i)] != alpha ? ed.weight : 0.0;                  // E(0,1)
        const double c = l[std::size_t(ed.j)] != alpha ? ed.weight : 0.0;                  // E(1,0)
        // E(1,1) = 0, so E = a (1 - x_i) + c x_i - c x_j + (b + c - a) (1 - x_i) x_j
        e0[std::size_t(ed.i)] += a;
        e1[std::size_t(ed.i)] += c;
        e1[std::size_t(ed.j)] -= c;
        fg.edges.push_back({ed.i, ed.j, b + c - a, 0.0});  // cut when x_i = 0 (source) and x_j = 1 (sink)
      }
      for (int i = 0; i < e.nodes; ++i) {
        const double m = std::min(e0[std::size_t(i)], e1[std::size_t(i)]);
        fg.source[std::size_t(i)] = e1[std::size_t(i)] - m;  // cut when i is on the sink side (alpha)
        fg.sink[std::size_t(i)] = e0[std::size_t(i)] - m;
      }
      std::vector<std::uint8_t> side;
      max_flow(fg, &side);
      std::vector<int> m = l;
      for (int i = 0; i < e.nodes; ++i)
        if (side[std::size_t(i)]) m[std::size_t(i)] = alpha;
      if (e.energy(m) < e.energy(l) - 1e-12) {
        l = m;
        changed = true;
        unchanged_in_a_row = 1;
      } else {
        ++unchanged_in_a_row;
      }
    }
    per_cycle.push_back(e.energy(l));
    if (!changed) break;
  }
  return per_cycle;
}

}  // namespace

TEST(GraphCut, LeavingProvablyKeptNodesOutOfTheCutsChangesNoMove) {
  // The solver cuts only the nodes that may take alpha (after fixing those that provably keep their
  // label) in the parts that changed since alpha's last move, and after alpha's first move looks only
  // at the nodes those changes reach: cycle by cycle it must reach the
  // energies of plain expansion, from the least-unary start and from random starts (costlier labels),
  // weak and strong smoothing (few and many nodes fixed).
  std::mt19937_64 g(21);
  int fixed_some = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const int labels = 3 + trial % 4;
    const double wmax = trial % 3 == 0 ? 1.0 : (trial % 3 == 1 ? 4.0 : 12.0);
    const PottsEnergy e = random_grid(g, 12, 9, labels, wmax);
    std::vector<int> start;
    if (trial % 2) {
      start.resize(std::size_t(e.nodes));
      std::uniform_int_distribution<int> pick(0, labels - 1);
      for (int& v : start) v = pick(g);
    }
    std::vector<int> fast = start, plain = start;
    if (plain.empty()) {
      plain.resize(std::size_t(e.nodes));
      for (int i = 0; i < e.nodes; ++i) {
        const double* u = e.unary.data() + std::size_t(i) * std::size_t(labels);
        plain[std::size_t(i)] = static_cast<int>(std::min_element(u, u + labels) - u);
      }
    }
    const ExpansionReport r = alpha_expansion(e, fast, {.max_cycles = 20});
    const std::vector<double> want = reference_expansion(e, plain, 20);
    ASSERT_EQ(r.per_cycle.size(), want.size()) << "trial " << trial;
    for (std::size_t c = 0; c < want.size(); ++c)
      ASSERT_NEAR(r.per_cycle[c], want[c], 1e-6 * std::abs(want[c])) << "trial " << trial << " cycle " << c;
    ASSERT_EQ(fast, plain) << "trial " << trial;
    ASSERT_NEAR(e.energy(fast), r.energy, 1e-9);
    fixed_some += r.graph_nodes < std::int64_t(r.moves + 1) * e.nodes;
  }
  EXPECT_GT(fixed_some, 10);  // the cuts did leave nodes out
}
