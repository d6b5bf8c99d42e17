#pragma once
// Graph cuts: minimum s-t cuts by the Boykov-Kolmogorov max-flow algorithm (libmaxflow, Debian's
// libmaxflow-dev), and multi-label energies with a Potts smoothness term minimised by alpha-expansion
// (Boykov, Veksler & Zabih 2001). Every graph-cut method of the toolkit goes through here: the forest
// smoothing of eval-forest, the point-cloud MRF of segment-cloud.
//
// The energy of a labelling l over nodes 0..n-1 and labels 0..L-1 is
//   E(l) = sum_i D_i(l_i) + sum_{(i,j) in edges} w_ij [l_i != l_j]
// with unary costs D (finite, any sign) and edge weights w_ij >= 0. For the Potts term every expansion
// move is solved exactly by one min cut, and a local minimum under expansion moves is within a factor 2
// of the global minimum (Boykov et al. 2001, theorem 6.1).

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace smseg::graphcut {

/// A directed s-t graph: node i is joined to the source with capacity source[i] and to the sink with
/// capacity sink[i]; an edge {i, j, forward, backward} has capacity `forward` from i to j and `backward`
/// from j to i. Capacities >= 0.
struct FlowGraph {
  struct Edge {
    int i = 0, j = 0;
    double forward = 0, backward = 0;
  };
  std::vector<double> source, sink;  ///< terminal capacities per node (same size)
  std::vector<Edge> edges;

  int nodes() const { return static_cast<int>(source.size()); }
  void validate() const;  ///< Error on mismatched sizes, node ids outside the graph, negative or non-finite capacities
};

/// Maximum flow from source to sink (= the capacity of a minimum cut). sink_side (optional) receives 1 for
/// the nodes on the sink side of a minimum cut, 0 for the source side.
double max_flow(const FlowGraph& graph, std::vector<std::uint8_t>* sink_side = nullptr);

/// Capacity of the cut that puts the nodes with sink_side[i] = 1 on the sink side (what max_flow minimises).
double cut_capacity(const FlowGraph& graph, std::span<const std::uint8_t> sink_side);

/// A multi-label Potts energy (see the top of the file).
struct PottsEnergy {
  struct Edge {
    int i = 0, j = 0;
    double weight = 0;
  };
  int nodes = 0;
  int labels = 0;
  std::vector<double> unary;  ///< nodes x labels, unary[i * labels + l] = D_i(l)
  std::vector<Edge> edges;    ///< each unordered pair once

  double unary_at(int i, int l) const { return unary[std::size_t(i) * std::size_t(labels) + std::size_t(l)]; }
  void validate() const;  ///< Error on sizes, node ids, self-loops, non-finite costs, negative weights
  /// E(labelling); labelling.size() == nodes, every label in 0..labels-1.
  double energy(std::span<const int> labelling) const;
};

struct ExpansionOptions {
  int max_cycles = 10;  ///< at most this many passes over every label, >= 1
  /// stop when a full cycle lowers the energy by less than this fraction of its magnitude, >= 0
  double relative_tolerance = 0;
  void validate() const;
};

struct ExpansionReport {
  double initial_energy = 0;
  double energy = 0;              ///< of the returned labelling, never above initial_energy
  int cycles = 0;                 ///< cycles run
  int moves = 0;                  ///< expansion moves that lowered the energy (and were kept)
  std::int64_t graph_nodes = 0;   ///< nodes of the moves' max-flow graphs, summed over the moves
  std::vector<double> per_cycle;  ///< energy after each cycle
};

/// Alpha-expansion from the labelling given (empty: the label of least unary cost per node, ties to the
/// lowest label). Each move is one min cut; a move is kept only when it lowers the energy (its change,
/// computed afresh in double over the nodes that change and their edges), so the energy never rises.
/// Stops when a cycle changes nothing (a local minimum under expansion moves), after max_cycles, or when
/// a cycle gains less than the tolerance. Deterministic: labels are expanded in order 0..L-1.
/// A move's cut leaves out the nodes that provably keep their label in every optimal move (unary rise
/// beyond what their edges can save, spread by the edges to nodes so fixed) and the parts of the graph
/// in and around which no label changed since alpha's last move (that move's optimum still holds
/// there): the moves are those of cutting the whole graph, at a fraction of the work.
ExpansionReport alpha_expansion(const PottsEnergy& energy, std::vector<int>& labelling,
                                const ExpansionOptions& opt = {});

struct MoveWorkspace;

/// alpha_expansion with its working memory (the max-flow graph and per-node arrays) kept from one call
/// to the next: solving frame after frame of the same size allocates nothing. Not thread-safe: one
/// solver per thread.
class ExpansionSolver {
 public:
  ExpansionSolver();
  ~ExpansionSolver();
  ExpansionSolver(const ExpansionSolver&) = delete;
  ExpansionSolver& operator=(const ExpansionSolver&) = delete;
  ExpansionReport solve(const PottsEnergy& energy, std::vector<int>& labelling, const ExpansionOptions& opt = {});

 private:
  std::unique_ptr<MoveWorkspace> w_;
};

/// One alpha-expansion move: the labelling of least energy among those where every node keeps its label
/// or takes alpha (one min cut), applied when it lowers the energy. `labelling` empty: starts from the
/// least-unary labelling. Returns whether the labelling changed.
bool expansion_move(const PottsEnergy& energy, std::vector<int>& labelling, int alpha);

/// Brute-force minimum of a Potts energy over all labels^nodes labellings (for tests; Error when that
/// is more than 2^24 labellings).
double brute_force_minimum(const PottsEnergy& energy, std::vector<int>* best = nullptr);

}  // namespace smseg::graphcut
