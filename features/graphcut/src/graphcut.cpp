#include "smseg/graphcut/graphcut.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <maxflow.h>

#include "smseg/common/error.hpp"

namespace smseg::features {

namespace {

// Float capacities: half the memory traffic of double; each move's result is checked against the
// energy recomputed in double, so rounding can at worst reject a move, never raise the energy.
using MaxFlowGraph = maxflow::Graph<float, float, float>;
using ExactGraph = maxflow::Graph<double, double, double>;

[[noreturn]] void maxflow_error(const char* msg) { throw Error("", "max-flow", msg ? msg : "libmaxflow failed"); }

bool finite_nonneg(double v) { return std::isfinite(v) && v >= 0; }

}  // namespace

void FlowGraph::validate() const {
  if (source.size() != sink.size())
    throw Error("", "flow graph", "source and sink capacities differ in count (" + std::to_string(source.size()) +
                                      " vs " + std::to_string(sink.size()) + ")");
  if (source.size() > std::size_t(std::numeric_limits<int>::max() / 2))
    throw Error("", "flow graph", "too many nodes");
  for (std::size_t i = 0; i < source.size(); ++i)
    if (!finite_nonneg(source[i]) || !finite_nonneg(sink[i]))
      throw Error("", "flow graph", "terminal capacity of node " + std::to_string(i) + " is negative or not finite");
  const int n = nodes();
  for (const Edge& e : edges) {
    if (e.i < 0 || e.i >= n || e.j < 0 || e.j >= n || e.i == e.j)
      throw Error("", "flow graph", "edge " + std::to_string(e.i) + "-" + std::to_string(e.j) +
                                        " joins nodes outside 0.." + std::to_string(n - 1) + " or a node to itself");
    if (!finite_nonneg(e.forward) || !finite_nonneg(e.backward))
      throw Error("", "flow graph", "edge " + std::to_string(e.i) + "-" + std::to_string(e.j) +
                                        " has a negative or non-finite capacity");
  }
}

double max_flow(const FlowGraph& graph, std::vector<std::uint8_t>* sink_side) {
  graph.validate();
  const int n = graph.nodes();
  ExactGraph g(std::max(n, 1), std::max<int>(static_cast<int>(graph.edges.size()), 1), maxflow_error);
  if (n > 0) g.add_node(n);
  for (int i = 0; i < n; ++i) g.add_tweights(i, graph.source[std::size_t(i)], graph.sink[std::size_t(i)]);
  for (const auto& e : graph.edges) g.add_edge(e.i, e.j, e.forward, e.backward);
  const double flow = n > 0 ? g.maxflow() : 0.0;
  if (sink_side) {
    sink_side->assign(std::size_t(n), 0);
    for (int i = 0; i < n; ++i) (*sink_side)[std::size_t(i)] = g.what_segment(i) == ExactGraph::SINK ? 1 : 0;
  }
  return flow;
}

double cut_capacity(const FlowGraph& graph, std::span<const std::uint8_t> sink_side) {
  if (sink_side.size() != graph.source.size()) throw Error("", "cut", "one side per node expected");
  double c = 0;
  for (std::size_t i = 0; i < sink_side.size(); ++i) c += sink_side[i] ? graph.source[i] : graph.sink[i];
  for (const auto& e : graph.edges) {
    const bool si = sink_side[std::size_t(e.i)] != 0, sj = sink_side[std::size_t(e.j)] != 0;
    if (!si && sj) c += e.forward;
    if (si && !sj) c += e.backward;
  }
  return c;
}

void PottsEnergy::validate() const {
  if (nodes < 0 || labels < 1) throw Error("", "energy", "needs nodes >= 0 and at least one label");
  if (unary.size() != std::size_t(nodes) * std::size_t(labels))
    throw Error("", "energy", "unary costs: " + std::to_string(unary.size()) + " given, nodes x labels = " +
                                  std::to_string(std::size_t(nodes) * std::size_t(labels)) + " expected");
  for (std::size_t k = 0; k < unary.size(); ++k)
    if (!std::isfinite(unary[k]))
      throw Error("", "energy", "unary cost of node " + std::to_string(k / std::size_t(labels)) + " is not finite");
  for (const Edge& e : edges) {
    if (e.i < 0 || e.i >= nodes || e.j < 0 || e.j >= nodes || e.i == e.j)
      throw Error("", "energy", "edge " + std::to_string(e.i) + "-" + std::to_string(e.j) +
                                    " joins nodes outside the graph or a node to itself");
    if (!finite_nonneg(e.weight))
      throw Error("", "energy", "edge " + std::to_string(e.i) + "-" + std::to_string(e.j) +
                                    " has a negative or non-finite weight");
  }
}

double PottsEnergy::energy(std::span<const int> l) const {
  if (l.size() != std::size_t(nodes)) throw Error("", "labelling", "one label per node expected");
  double e = 0;
  for (int i = 0; i < nodes; ++i) {
    const int li = l[std::size_t(i)];
    if (li < 0 || li >= labels) throw Error("", "labelling", "label " + std::to_string(li) + " outside 0.." + std::to_string(labels - 1));
    e += unary_at(i, li);
  }
  for (const Edge& ed : edges)
    if (l[std::size_t(ed.i)] != l[std::size_t(ed.j)]) e += ed.weight;
  return e;
}

void ExpansionOptions::validate() const {
  if (max_cycles < 1) throw Error("", "max_cycles", "must be at least 1");
  if (!(relative_tolerance >= 0) || !std::isfinite(relative_tolerance))
    throw Error("", "relative_tolerance", "must be a finite number >= 0");
}

/// What expansion moves need, kept across moves and energies: libmaxflow's reset() keeps its memory
/// (and grows it when a larger energy comes), so a solver reused frame after frame allocates nothing.
struct MoveWorkspace {
  MaxFlowGraph g{1, 1, maxflow_error};
  void prepare(const PottsEnergy& e) {
    id.resize(static_cast<std::size_t>(e.nodes));
    incident.assign(static_cast<std::size_t>(e.nodes), 0.0);
    for (const auto& ed : e.edges) {
      incident[std::size_t(ed.i)] += ed.weight;
      incident[std::size_t(ed.j)] += ed.weight;
    }
  }
  std::vector<int> id;           // graph node, or kAlpha (already alpha) or kKept (provably keeps its label)
  std::vector<double> incident;  // sum of the weights of each node's edges
  std::vector<double> e0, e1;  // cost of keeping the current label (source side) / taking alpha (sink side)
  std::vector<int> proposal;
};

namespace {

constexpr int kAlpha = -1, kKept = -2;

/// The optimal alpha-expansion move from `labelling` (one min cut), applied when it lowers `current`
/// (the energy of `labelling`, recomputed for the proposal). Returns true when applied.
bool expand(const PottsEnergy& energy, std::vector<int>& labelling, int alpha, double& current, MoveWorkspace& w) {
  const int n = energy.nodes;
  int free_nodes = 0;
  for (int i = 0; i < n; ++i) {
    const int li = labelling[std::size_t(i)];
    // A node whose unary cost rises by more than all its edges weigh keeps its label in every optimal
    // move (flipping it back would lower the move's energy): it needs no graph node.
    if (li == alpha) w.id[std::size_t(i)] = kAlpha;
    else if (energy.unary_at(i, alpha) - energy.unary_at(i, li) > w.incident[std::size_t(i)]) w.id[std::size_t(i)] = kKept;
    else w.id[std::size_t(i)] = free_nodes++;
  }
  if (free_nodes == 0) return false;
  w.e0.assign(std::size_t(free_nodes), 0.0);
  w.e1.assign(std::size_t(free_nodes), 0.0);
  w.g.reset();
  w.g.add_node(free_nodes);
  for (int i = 0; i < n; ++i) {
    const int v = w.id[std::size_t(i)];
    if (v < 0) continue;
    w.e0[std::size_t(v)] = energy.unary_at(i, labelling[std::size_t(i)]);
    w.e1[std::size_t(v)] = energy.unary_at(i, alpha);
  }
  for (const auto& ed : energy.edges) {
    const int vi = w.id[std::size_t(ed.i)], vj = w.id[std::size_t(ed.j)];
    const double wt = ed.weight;
    if (wt == 0 || (vi < 0 && vj < 0)) continue;
    if (vi < 0 || vj < 0) {
      const int fixed = vi < 0 ? ed.i : ed.j, v = vi < 0 ? vj : vi, node = vi < 0 ? ed.j : ed.i;
      if (w.id[std::size_t(fixed)] == kAlpha) {  // the free end pays wt unless it joins alpha
        w.e0[std::size_t(v)] += wt;
      } else {  // the fixed end keeps a label other than alpha
        if (labelling[std::size_t(fixed)] != labelling[std::size_t(node)]) w.e0[std::size_t(v)] += wt;
        w.e1[std::size_t(v)] += wt;
      }
      continue;
    }
    if (labelling[std::size_t(ed.i)] == labelling[std::size_t(ed.j)]) {
      w.g.add_edge(vi, vj, float(wt), float(wt));  // E = wt [x_i != x_j]
    } else {
      // E(0,0) = wt, E(0,1) = wt, E(1,0) = wt, E(1,1) = 0, which is wt (1 - x_j) + wt (1 - x_i) x_j
      w.e0[std::size_t(vj)] += wt;
      w.g.add_edge(vi, vj, float(wt), 0.0f);
    }
  }
  for (int v = 0; v < free_nodes; ++v) {
    const double m = std::min(w.e0[std::size_t(v)], w.e1[std::size_t(v)]);
    w.g.add_tweights(v, float(w.e1[std::size_t(v)] - m), float(w.e0[std::size_t(v)] - m));
  }
  w.g.maxflow();
  w.proposal.resize(std::size_t(n));
  bool any = false;
  for (int i = 0; i < n; ++i) {
    const int v = w.id[std::size_t(i)];
    const bool take = v >= 0 && w.g.what_segment(v) == MaxFlowGraph::SINK;
    w.proposal[std::size_t(i)] = take ? alpha : labelling[std::size_t(i)];
    any = any || take;
  }
  if (!any) return false;
  const double e = energy.energy(w.proposal);
  if (!(e < current)) return false;
  current = e;
  labelling.swap(w.proposal);
  return true;
}

void initial_labelling(const PottsEnergy& energy, std::vector<int>& labelling) {
  if (!labelling.empty() || energy.nodes == 0) return;
  const int L = energy.labels;
  labelling.resize(std::size_t(energy.nodes));
  for (int i = 0; i < energy.nodes; ++i) {
    const double* u = energy.unary.data() + std::size_t(i) * std::size_t(L);
    labelling[std::size_t(i)] = static_cast<int>(std::min_element(u, u + L) - u);
  }
}

}  // namespace

bool expansion_move(const PottsEnergy& energy, std::vector<int>& labelling, int alpha) {
  energy.validate();
  if (alpha < 0 || alpha >= energy.labels) throw Error("", "alpha", "label outside the energy's labels");
  initial_labelling(energy, labelling);
  double current = energy.energy(labelling);
  if (energy.nodes == 0) return false;
  MoveWorkspace w;
  w.prepare(energy);
  return expand(energy, labelling, alpha, current, w);
}

ExpansionSolver::ExpansionSolver() : w_(std::make_unique<MoveWorkspace>()) {}
ExpansionSolver::~ExpansionSolver() = default;

ExpansionReport alpha_expansion(const PottsEnergy& energy, std::vector<int>& labelling, const ExpansionOptions& opt) {
  ExpansionSolver solver;
  return solver.solve(energy, labelling, opt);
}

ExpansionReport ExpansionSolver::solve(const PottsEnergy& energy, std::vector<int>& labelling,
                                       const ExpansionOptions& opt) {
  energy.validate();
  opt.validate();
  initial_labelling(energy, labelling);
  ExpansionReport rep;
  rep.initial_energy = rep.energy = energy.energy(labelling);
  if (energy.nodes == 0 || energy.labels == 1) return rep;
  MoveWorkspace& w = *w_;
  w.prepare(energy);
  // A move from a labelling already tried with the same alpha gives nothing: after L moves in a row
  // that changed nothing, the labelling is a local minimum under expansion moves.
  int unchanged_in_a_row = 0;
  for (int cycle = 0; cycle < opt.max_cycles && unchanged_in_a_row < energy.labels; ++cycle) {
    const double cycle_start = rep.energy;
    bool changed = false;
    for (int alpha = 0; alpha < energy.labels && unchanged_in_a_row < energy.labels; ++alpha) {
      if (expand(energy, labelling, alpha, rep.energy, w)) {
        ++rep.moves;
        changed = true;
        unchanged_in_a_row = 1;  // this alpha has been tried on the new labelling
      } else {
        ++unchanged_in_a_row;
      }
    }
    ++rep.cycles;
    rep.per_cycle.push_back(rep.energy);
    if (!changed) break;
    if (cycle_start - rep.energy <= opt.relative_tolerance * std::abs(rep.energy)) break;
  }
  return rep;
}

double brute_force_minimum(const PottsEnergy& energy, std::vector<int>* best) {
  energy.validate();
  double count = std::pow(double(energy.labels), double(energy.nodes));
  if (count > double(1 << 24)) throw Error("", "energy", "too many labellings for brute force");
  std::vector<int> l(std::size_t(energy.nodes), 0), arg = l;
  double lowest = energy.energy(l);
  while (true) {
    int k = 0;
    while (k < energy.nodes && ++l[std::size_t(k)] == energy.labels) l[std::size_t(k++)] = 0;
    if (k == energy.nodes) break;
    const double e = energy.energy(l);
    if (e < lowest) {
      lowest = e;
      arg = l;
    }
  }
  if (best) *best = arg;
  return lowest;
}

}  // namespace smseg::features
