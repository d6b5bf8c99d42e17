#include "smseg/graphcut/graphcut.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <maxflow.h>

#include "smseg/common/error.hpp"

namespace smseg::graphcut {

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

namespace {

constexpr int kFixed = -1;      // MoveWorkspace::id of a node not listed in the move (between moves: all)
constexpr int kUnseen = -2;     // ... of a listed node that may take alpha, not looked at closer yet
constexpr int kUndecided = -3;  // ... of a node that may take alpha, not (yet) in the move's graph
constexpr int kKept = -4;       // ... of a listed node found to keep its label in every optimal move
constexpr std::size_t kNever = std::numeric_limits<std::size_t>::max();  // label not expanded yet

}  // namespace

/// What expansion moves need, kept across moves and energies: libmaxflow's reset() keeps its memory
/// (and grows it when a larger energy comes), so a solver reused frame after frame allocates nothing.
/// A move's work is proportional to the nodes that may take alpha, not to the whole energy: per label,
/// the candidate nodes are listed once per energy, and each move reads only their edges (adjacency
/// lists) to build its graph and to price its result.
struct MoveWorkspace {
  struct Neighbour {
    int node;
    double weight;
  };
  MaxFlowGraph g{1, 1, maxflow_error};

  void prepare(const PottsEnergy& e, const std::vector<int>& labelling);
  void note_label(const PottsEnergy& e, int i, int label);  ///< node i takes `label`: keeps `raised` up to date
  std::span<const Neighbour> neighbours(int i) const {
    return {adjacency.data() + adjacency_start[std::size_t(i)],
            adjacency.data() + adjacency_start[std::size_t(i) + 1]};
  }
  struct Candidate {
    int node;
    double rise;  // D(alpha) - least unary cost, kept here so that a move reads its candidates in a row
  };
  std::span<const Candidate> candidates(int alpha) const {
    return {candidate.data() + candidate_start[std::size_t(alpha)],
            candidate.data() + candidate_start[std::size_t(alpha) + 1]};
  }

  // Per energy (prepare).
  std::vector<std::size_t> adjacency_start;  // node i's neighbours: adjacency[start[i] .. start[i + 1])
  std::vector<Neighbour> adjacency;          // every edge twice, once from each end
  std::vector<double> incident;              // sum of the weights of each node's edges
  std::vector<std::size_t> candidate_start;  // label alpha's candidates: candidate[start[alpha] .. start[alpha + 1])
  std::vector<Candidate> candidate;          // nodes at their least-cost label that may take alpha
  std::vector<double> least;                 // least unary cost of each node
  std::vector<std::size_t> candidate_fill;   // where list_candidates places each label's next candidate
  // Per labelling.
  std::vector<int> raised;                 // nodes that may be at a label costlier than their least
  std::vector<std::uint8_t> is_raised;     // per node: listed in `raised`
  std::vector<int> changes;                // nodes whose label the moves changed, in order (repeats allowed)
  std::vector<std::size_t> seen_changes;   // per label: changes.size() after its last move, or kNever
  // Per move.
  std::vector<int> id;           // graph node of each energy node, or kFixed, kUnseen, kUndecided, kKept
  std::vector<int> free_nodes;   // nodes that may take alpha
  std::vector<int> graph_node;   // energy node of each graph node
  std::vector<double> slack;     // per free node: by how much keeping its label provably wins (> 0: kept)
  std::vector<int> newly_kept;   // free nodes found to keep their label, whose neighbours are to update
  std::vector<double> e0, e1;    // cost of keeping the current label (source side) / taking alpha (sink side)
  std::vector<std::uint8_t> takes_alpha;  // per graph node, from the cut
  struct Arc {
    int v, u;
    float forward, backward;
  };
  std::vector<Arc> arcs;  // the move graph's arcs between graph nodes, before they go to libmaxflow
  std::int64_t graph_nodes = 0;           // summed over the moves since prepare
};

namespace {

void build_adjacency(const PottsEnergy& e, MoveWorkspace& w) {
  const auto n = std::size_t(e.nodes);
  w.adjacency_start.assign(n + 1, 0);
  w.incident.assign(n, 0.0);
  for (const auto& ed : e.edges) {
    ++w.adjacency_start[std::size_t(ed.i) + 1];
    ++w.adjacency_start[std::size_t(ed.j) + 1];
    w.incident[std::size_t(ed.i)] += ed.weight;
    w.incident[std::size_t(ed.j)] += ed.weight;
  }
  for (std::size_t i = 0; i < n; ++i) w.adjacency_start[i + 1] += w.adjacency_start[i];
  w.adjacency.resize(w.adjacency_start[n]);
  std::vector<std::size_t>& fill = w.adjacency_start;  // advanced while filling, then shifted back
  for (const auto& ed : e.edges) {
    w.adjacency[fill[std::size_t(ed.i)]++] = {ed.j, ed.weight};
    w.adjacency[fill[std::size_t(ed.j)]++] = {ed.i, ed.weight};
  }
  for (std::size_t i = n; i > 0; --i) fill[i] = fill[i - 1];
  fill[0] = 0;
}

// A node whose unary cost rises by more than all its edges weigh when it takes alpha keeps its label in
// every optimal move (flipping it back would lower the move's energy). For a node at its least-cost
// label that is D(alpha) - min_l D(l) > incident, which does not depend on the labelling: the others,
// the candidates of alpha, are listed once per energy. Nodes at a costlier label are few (those the
// moves have moved, and those of a given starting labelling) and are tested in every move (`raised`).
void list_candidates(const PottsEnergy& e, MoveWorkspace& w) {
  const auto L = std::size_t(e.labels);
  w.candidate_start.assign(L + 1, 0);
  w.candidate.clear();
  w.least.resize(std::size_t(e.nodes));
  for (int i = 0; i < e.nodes; ++i) {
    const double* u = e.unary.data() + std::size_t(i) * L;
    w.least[std::size_t(i)] = *std::min_element(u, u + L);
  }
  // One pass over the unary table (node-major): count each label's candidates, then place them.
  auto for_each_candidate = [&](auto&& f) {
    for (int i = 0; i < e.nodes; ++i) {
      const double* u = e.unary.data() + std::size_t(i) * L;
      for (std::size_t alpha = 0; alpha < L; ++alpha) {
        const double rise = u[alpha] - w.least[std::size_t(i)];
        if (rise <= w.incident[std::size_t(i)]) f(alpha, i, rise);
      }
    }
  };
  for_each_candidate([&](std::size_t alpha, int, double) { ++w.candidate_start[alpha + 1]; });
  for (std::size_t a = 0; a < L; ++a) w.candidate_start[a + 1] += w.candidate_start[a];
  w.candidate.resize(w.candidate_start[L]);
  std::vector<std::size_t>& fill = w.candidate_fill;
  fill.assign(w.candidate_start.begin(), w.candidate_start.end() - 1);
  for_each_candidate([&](std::size_t alpha, int i, double rise) { w.candidate[fill[alpha]++] = {i, rise}; });
}

}  // namespace

void MoveWorkspace::prepare(const PottsEnergy& e, const std::vector<int>& labelling) {
  build_adjacency(e, *this);
  list_candidates(e, *this);
  id.assign(std::size_t(e.nodes), kFixed);
  slack.resize(std::size_t(e.nodes));
  is_raised.assign(std::size_t(e.nodes), 0);
  raised.clear();
  for (int i = 0; i < e.nodes; ++i) note_label(e, i, labelling[std::size_t(i)]);
  changes.clear();
  seen_changes.assign(std::size_t(e.labels), kNever);
  graph_nodes = 0;
}

void MoveWorkspace::note_label(const PottsEnergy& e, int i, int label) {
  if (is_raised[std::size_t(i)] || e.unary_at(i, label) <= least[std::size_t(i)]) return;
  is_raised[std::size_t(i)] = 1;
  raised.push_back(i);
}

namespace {

/// The move's graph nodes: the nodes not at alpha whose unary rise is within their edges' weight (the
/// others provably keep their label), looked for among the candidates of alpha and the raised nodes.
/// Returns their count.
int select_free_nodes(const PottsEnergy& energy, const std::vector<int>& labelling, int alpha, MoveWorkspace& w) {
  w.free_nodes.clear();
  auto consider = [&](int i, double rise) {  // rise: D(alpha) - D(current label)
    if (labelling[std::size_t(i)] == alpha || rise > w.incident[std::size_t(i)]) return;
    w.id[std::size_t(i)] = kUnseen;
    w.slack[std::size_t(i)] = rise;
    w.free_nodes.push_back(i);
  };
  for (const auto& [i, rise] : w.candidates(alpha))
    if (!w.is_raised[std::size_t(i)]) consider(i, rise);  // at its least-cost label
  for (const int i : w.raised) consider(i, energy.unary_at(i, alpha) - energy.unary_at(i, labelling[std::size_t(i)]));
  return static_cast<int>(w.free_nodes.size());
}

/// Whether node i may take alpha in an optimal move: it is not at alpha and its unary rise (`rise`)
/// is within the weight of its edges; every other node keeps its label.
bool is_free(const PottsEnergy& energy, const std::vector<int>& labelling, int alpha, int i,
             const MoveWorkspace& w, double& rise) {
  const int li = labelling[std::size_t(i)];
  if (li == alpha) return false;
  rise = energy.unary_at(i, alpha) - energy.unary_at(i, li);
  return rise <= w.incident[std::size_t(i)];
}

/// Which free nodes a move lists: all of them (alpha's first move), or only those the changes since
/// alpha's last move reach (list_near_changes); then an unlisted neighbour (kFixed) may be free.
enum class Listing { every_free_node, near_changes };

/// Lower bound, over every labelling of the undecided nodes, of what node i (undecided, current label
/// li) loses by taking alpha rather than keeping li: its unary rise, minus w for each edge to a node that
/// may take alpha (taking alpha can save that edge), plus w for each edge to a node that keeps li (taking
/// alpha cuts it); an edge to a node that keeps another label costs w either way.
/// `undecided_neighbour` tells whether a neighbour is kUndecided (whose slack a fix of i would raise).
template <Listing kListing>
double keep_slack(const PottsEnergy& energy, const std::vector<int>& labelling, int alpha, int i,
                  const MoveWorkspace& w, bool& undecided_neighbour) {
  const int li = labelling[std::size_t(i)];
  double slack = w.slack[std::size_t(i)];  // the unary rise (select_free_nodes)
  bool undecided = false;
  for (const auto& [j, wt] : w.neighbours(i)) {
    const int lj = labelling[std::size_t(j)];
    const int state = w.id[std::size_t(j)];
    undecided |= state == kUndecided;
    bool may_take_alpha = state == kUnseen || state == kUndecided || lj == alpha;
    if constexpr (kListing == Listing::near_changes) {
      double rise = 0;
      may_take_alpha = may_take_alpha || (state == kFixed && is_free(energy, labelling, alpha, j, w, rise));
    }
    slack += may_take_alpha ? -wt : (lj == li ? wt : 0.0);
  }
  undecided_neighbour = undecided;
  return slack;
}

/// Node i keeps its label: the undecided neighbours' slack rises (an edge to i no longer helps alpha,
/// and costs w when their labels agree), which may fix them in turn.
void keep(const std::vector<int>& labelling, int i, MoveWorkspace& w) {
  w.id[std::size_t(i)] = kKept;
  w.newly_kept.clear();
  w.newly_kept.push_back(i);
  while (!w.newly_kept.empty()) {
    const int k = w.newly_kept.back(), lk = labelling[std::size_t(k)];
    w.newly_kept.pop_back();
    for (const auto& [j, wt] : w.neighbours(k)) {
      if (w.id[std::size_t(j)] != kUndecided) continue;  // kUnseen ones will see k fixed
      double& slack = w.slack[std::size_t(j)];
      slack += labelling[std::size_t(j)] == lk ? 2 * wt : wt;
      if (slack > 0) {
        w.id[std::size_t(j)] = kKept;
        w.newly_kept.push_back(j);
      }
    }
  }
}

/// Looks closer at listed node i (kUnseen): it keeps its label in every optimal move when its slack is
/// positive (taking alpha loses whatever the others do), which raises its undecided neighbours' slack
/// and may fix them in turn; else it is undecided. Returns whether it is undecided.
template <Listing kListing>
bool decide(const PottsEnergy& energy, const std::vector<int>& labelling, int alpha, int i, MoveWorkspace& w) {
  bool undecided_neighbour = false;
  const double slack = keep_slack<kListing>(energy, labelling, alpha, i, w, undecided_neighbour);
  if (slack > 0) {
    if (undecided_neighbour) keep(labelling, i, w);
    else w.id[std::size_t(i)] = kKept;  // no neighbour to update
    return false;
  }
  w.slack[std::size_t(i)] = slack;
  w.id[std::size_t(i)] = kUndecided;
  return true;
}

/// Fixes the free nodes that keep their label in every optimal move. Fixing spreads through regions
/// where alpha is unlikely. One pass in node order: a node's slack is computed from its neighbours'
/// states so far, and later fixes update it. Every optimal move survives: the cut over the remaining
/// nodes reaches the same energy.
void fix_kept_nodes(const PottsEnergy& energy, const std::vector<int>& labelling, int alpha, MoveWorkspace& w) {
  for (const int i : w.free_nodes) decide<Listing::every_free_node>(energy, labelling, alpha, i, w);
}

/// After alpha's first move, lists and decides only the free nodes that the changes since that move
/// reach: the changed nodes and their neighbours, then, through undecided nodes, every free neighbour.
/// The free nodes left unlisted are cut off from the changes by nodes that keep their label, in a
/// region where nothing changed since alpha's last move, whose optimum (keep every label there) holds
/// again (see select_graph_nodes). So the moves are those of the whole graph, and a cycle after the
/// first costs in proportion to what the previous one changed.
void list_near_changes(const PottsEnergy& energy, const std::vector<int>& labelling, int alpha, MoveWorkspace& w) {
  w.free_nodes.clear();
  auto list = [&](int i) {
    double rise = 0;
    if (w.id[std::size_t(i)] != kFixed || !is_free(energy, labelling, alpha, i, w, rise)) return;
    w.id[std::size_t(i)] = kUnseen;
    w.slack[std::size_t(i)] = rise;
    w.free_nodes.push_back(i);
  };
  for (std::size_t k = w.seen_changes[std::size_t(alpha)]; k < w.changes.size(); ++k) {
    const int c = w.changes[k];
    list(c);
    for (const auto& nb : w.neighbours(c)) list(nb.node);
  }
  for (std::size_t k = 0; k < w.free_nodes.size(); ++k) {  // grows as undecided nodes list their neighbours
    const int i = w.free_nodes[k];
    if (decide<Listing::near_changes>(energy, labelling, alpha, i, w))
      for (const auto& nb : w.neighbours(i)) list(nb.node);
  }
}

void add_graph_node(int i, MoveWorkspace& w) {
  w.id[std::size_t(i)] = static_cast<int>(w.graph_node.size());
  w.graph_node.push_back(i);
}

/// The free nodes whose move needs a cut. The free nodes fall into connected parts, each an independent
/// problem given the fixed nodes around it. A part in which, and around which, no label has changed
/// since alpha's last move is the problem that move solved, restricted to that part with the rest of
/// the graph at that move's optimum; keeping every label (what that move did there) is optimal again.
/// So after alpha's first move, only the parts that touch a node changed since are cut. Returns the
/// graph's node count.
int select_graph_nodes(int alpha, MoveWorkspace& w) {
  w.graph_node.clear();
  if (w.seen_changes[std::size_t(alpha)] == kNever) {
    for (const int i : w.free_nodes)
      if (w.id[std::size_t(i)] == kUndecided) add_graph_node(i, w);
    return static_cast<int>(w.graph_node.size());
  }
  for (std::size_t k = w.seen_changes[std::size_t(alpha)]; k < w.changes.size(); ++k) {
    const int c = w.changes[k];
    if (w.id[std::size_t(c)] == kUndecided) add_graph_node(c, w);
    for (const auto& nb : w.neighbours(c))
      if (w.id[std::size_t(nb.node)] == kUndecided) add_graph_node(nb.node, w);
  }
  for (std::size_t v = 0; v < w.graph_node.size(); ++v)  // grows the parts from those seeds
    for (const auto& nb : w.neighbours(w.graph_node[v]))
      if (w.id[std::size_t(nb.node)] == kUndecided) add_graph_node(nb.node, w);
  return static_cast<int>(w.graph_node.size());
}

/// The move's s-t graph over the free nodes: their unary costs and their edges to fixed nodes go to the
/// terminals, their edges between each other (added once, from the lower node) are arcs.
void build_move_graph(const PottsEnergy& energy, const std::vector<int>& labelling, int alpha, MoveWorkspace& w) {
  const auto nf = w.graph_node.size();
  w.e0.resize(nf);
  w.e1.resize(nf);
  w.g.reset();
  w.g.add_node(static_cast<int>(nf));
  for (std::size_t v = 0; v < nf; ++v) {
    const int i = w.graph_node[v];
    w.e0[v] = energy.unary_at(i, labelling[std::size_t(i)]);
    w.e1[v] = energy.unary_at(i, alpha);
  }
  w.arcs.clear();
  for (std::size_t v = 0; v < nf; ++v) {
    const int i = w.graph_node[v], li = labelling[std::size_t(i)];
    for (const auto& [j, wt] : w.neighbours(i)) {
      if (wt == 0) continue;
      const int vj = w.id[std::size_t(j)], lj = labelling[std::size_t(j)];
      if (vj < 0) {  // keeps its label: kFixed, kKept, or kUndecided in a part left out
        if (lj == alpha) {  // the free end pays wt unless it joins alpha
          w.e0[v] += wt;
        } else {  // the fixed end keeps a label other than alpha
          if (lj != li) w.e0[v] += wt;
          w.e1[v] += wt;
        }
      } else if (j > i) {
        if (lj == li) {
          w.arcs.push_back({static_cast<int>(v), vj, float(wt), float(wt)});  // E = wt [x_i != x_j]
        } else {
          // E(0,0) = wt, E(0,1) = wt, E(1,0) = wt, E(1,1) = 0, which is wt (1 - x_j) + wt (1 - x_i) x_j
          w.e0[std::size_t(vj)] += wt;
          w.arcs.push_back({static_cast<int>(v), vj, float(wt), 0.0f});
        }
      }
    }
  }
  // Terminal capacities: source = cost of taking alpha, sink = cost of keeping, less their minimum.
  for (std::size_t v = 0; v < nf; ++v) {
    const double m = std::min(w.e0[v], w.e1[v]);
    w.e1[v] -= m;
    w.e0[v] -= m;
  }
  // Flow on the paths source -> v -> u -> sink pushed before the search: the same minimum cuts, fewer
  // augmenting paths (and orphans) for libmaxflow to find.
  // push(from, to, there, back): as much flow as source -> from -> to -> sink takes, where `there` is
  // the arc's capacity from `from` to `to` and `back` the other way's.
  const auto push = [&](int from, int to, float& there, float& back) {
    double& source = w.e1[std::size_t(from)];
    double& sink = w.e0[std::size_t(to)];
    const double f = std::min({source, double(there), sink});
    if (!(f > 0)) return;
    source -= f;
    sink -= f;
    there = float(there - f);
    back = float(back + f);
  };
  for (auto& a : w.arcs) {
    push(a.v, a.u, a.forward, a.backward);
    push(a.u, a.v, a.backward, a.forward);
  }
  for (const auto& a : w.arcs) w.g.add_edge(a.v, a.u, a.forward, a.backward);
  for (std::size_t v = 0; v < nf; ++v) w.g.add_tweights(static_cast<int>(v), float(w.e1[v]), float(w.e0[v]));
}

/// Energy change of switching the graph nodes on the sink side to alpha, computed afresh in double
/// from the unary costs and weights of the nodes that change and of their edges (the rest of the
/// energy does not change). The float max-flow may round; this exact price decides.
double move_energy_change(const PottsEnergy& energy, const std::vector<int>& labelling, int alpha,
                          const MoveWorkspace& w) {
  double change = 0;
  for (std::size_t v = 0; v < w.graph_node.size(); ++v) {
    if (!w.takes_alpha[v]) continue;
    const int i = w.graph_node[v], li = labelling[std::size_t(i)];
    change += energy.unary_at(i, alpha) - energy.unary_at(i, li);
    for (const auto& [j, wt] : w.neighbours(i)) {
      const int vj = w.id[std::size_t(j)], lj = labelling[std::size_t(j)];
      const bool j_changes = vj >= 0 && w.takes_alpha[std::size_t(vj)];
      if (j_changes && j < i) continue;  // an edge between two changing nodes is priced once
      const int new_lj = j_changes ? alpha : lj;
      change += (new_lj != alpha ? wt : 0.0) - (lj != li ? wt : 0.0);
    }
  }
  return change;
}

/// Cuts the move's graph and applies the cut when it lowers the energy (`current` is then lowered by
/// the exact change). Returns true when applied.
bool cut_and_apply(const PottsEnergy& energy, std::vector<int>& labelling, int alpha, double& current,
                   MoveWorkspace& w) {
  build_move_graph(energy, labelling, alpha, w);
  w.g.maxflow();
  const auto nodes = w.graph_node.size();
  w.takes_alpha.resize(nodes);
  bool any = false;
  for (std::size_t v = 0; v < nodes; ++v) {
    w.takes_alpha[v] = w.g.what_segment(static_cast<int>(v)) == MaxFlowGraph::SINK ? 1 : 0;
    any = any || w.takes_alpha[v];
  }
  const double change = any ? move_energy_change(energy, labelling, alpha, w) : 0.0;
  if (!(change < 0)) return false;
  for (std::size_t v = 0; v < nodes; ++v) {
    if (!w.takes_alpha[v]) continue;
    const int i = w.graph_node[v];
    labelling[std::size_t(i)] = alpha;
    w.note_label(energy, i, alpha);
    w.changes.push_back(i);
  }
  current += change;
  return true;
}

/// The optimal alpha-expansion move from `labelling` (one min cut over the nodes that may change),
/// applied when it lowers the energy. Returns true when applied.
bool expand(const PottsEnergy& energy, std::vector<int>& labelling, int alpha, double& current, MoveWorkspace& w) {
  if (w.seen_changes[std::size_t(alpha)] == kNever) {
    select_free_nodes(energy, labelling, alpha, w);
    fix_kept_nodes(energy, labelling, alpha, w);
  } else {
    list_near_changes(energy, labelling, alpha, w);
  }
  const int nodes = select_graph_nodes(alpha, w);
  w.graph_nodes += nodes;
  const bool applied = nodes > 0 && cut_and_apply(energy, labelling, alpha, current, w);
  for (const int i : w.free_nodes) w.id[std::size_t(i)] = kFixed;
  w.seen_changes[std::size_t(alpha)] = w.changes.size();
  return applied;
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
  w.prepare(energy, labelling);
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
  w.prepare(energy, labelling);
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
  rep.graph_nodes = w.graph_nodes;
  rep.energy = energy.energy(labelling);  // afresh, rather than the sum of the moves' changes
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

}  // namespace smseg::graphcut
