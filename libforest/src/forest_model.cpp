// The forest model: statistics and the "smseg-forest" JSON format (version 1).
#include <cmath>
#include <limits>
#include <new>
#include <set>
#include <utility>

#include "smseg/common/error.hpp"
#include "smseg/forest/forest.hpp"
#include "smseg/common/io.hpp"

namespace smseg::forest {

namespace {
constexpr const char* kFormat = "smseg-forest";
constexpr int kVersion = 1;
constexpr const char* kSplitKeys[] = {"f", "dx", "dy", "w", "h", "t", "left", "right"};

std::vector<std::string> read_names(const JsonView& a, bool allow_empty) {
  std::vector<std::string> names;
  const std::size_t n = a.size();
  if (n == 0 && !allow_empty) a.fail("is empty");
  for (std::size_t i = 0; i < n; ++i) {
    names.push_back(a.at(i).as_str());
    if (names.back().empty()) a.at(i).fail("empty name");
  }
  if (std::set<std::string>(names.begin(), names.end()).size() != names.size()) a.fail("contains a name twice");
  return names;
}

int read_int(const JsonView& j, const char* key, long lo, long hi) {
  const auto v = j.integer(key);
  if (v < lo || v > hi)
    j.fail("is " + std::to_string(v) + ", expected " + std::to_string(lo) + ".." + std::to_string(hi), key);
  return static_cast<int>(v);
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return "[" + s + "]";
}
}  // namespace

std::string Forest::attribute_name(int f) const {
  const int nf = static_cast<int>(features.size());
  if (f >= 0 && f < nf) return features[static_cast<std::size_t>(f)];
  if (textons && f >= nf && f < nf + kNumTextonTests) return texton_names()[static_cast<std::size_t>(f - nf)];
  return "?";
}

void Forest::compute_stats() {
  stats.trees.resize(trees.size());
  stats.nodes_per_feature.assign(static_cast<std::size_t>(num_attributes()), 0);
  stats.windows = WindowHistograms::zeros(WindowBounds::for_image(width, height));
  for (std::size_t t = 0; t < trees.size(); ++t) {
    const auto& nodes = trees[t].nodes;
    TreeStats& s = stats.trees[t];
    s.nodes = static_cast<int>(nodes.size());
    s.leaves = 0;
    s.depth = 0;
    std::vector<int> depth(nodes.size(), 0);
    for (std::size_t i = 0; i < nodes.size(); ++i) {  // children have larger indices than parents
      const Node& n = nodes[i];
      if (n.is_leaf()) {
        ++s.leaves;
        s.depth = std::max(s.depth, depth[i]);
        continue;
      }
      depth[static_cast<std::size_t>(n.left)] = depth[i] + 1;
      depth[static_cast<std::size_t>(n.right)] = depth[i] + 1;
      if (n.feature < num_attributes()) ++stats.nodes_per_feature[static_cast<std::size_t>(n.feature)];
      if (n.feature < static_cast<int>(features.size()) && stats.windows.bounds.contains(n.win))
        stats.windows.add(n.win);
    }
  }
}

nlohmann::json forest_to_json(const Forest& forest) {
  nlohmann::json trees = nlohmann::json::array();
  for (const Tree& tree : forest.trees) {
    nlohmann::json nodes = nlohmann::json::array();
    for (const Node& n : tree.nodes) {
      if (n.is_leaf()) {
        nodes.push_back({{"counts", n.counts}});
      } else {
        nodes.push_back({{"dx", n.win.dx}, {"dy", n.win.dy}, {"w", n.win.w}, {"h", n.win.h},
                         {"f", n.feature}, {"t", n.threshold}, {"left", n.left}, {"right", n.right}});
      }
    }
    trees.push_back({{"nodes", std::move(nodes)}});
  }
  nlohmann::json tree_stats = nlohmann::json::array();
  for (const TreeStats& s : forest.stats.trees)
    tree_stats.push_back({{"nodes", s.nodes}, {"leaves", s.leaves}, {"depth", s.depth}, {"seconds", s.seconds}});
  nlohmann::json per_feature = nlohmann::json::object();
  for (std::size_t f = 0; f < forest.stats.nodes_per_feature.size(); ++f)
    per_feature[forest.attribute_name(static_cast<int>(f))] = forest.stats.nodes_per_feature[f];
  return {{"format", kFormat},
          {"version", kVersion},
          {"image", {{"width", forest.width}, {"height", forest.height}}},
          {"classes", forest.classes},
          {"features", forest.features},
          {"textons", forest.textons},
          {"params", params_to_json(forest.params)},
          {"trees", std::move(trees)},
          {"stats",
           {{"seconds", forest.stats.seconds},
            {"trees", std::move(tree_stats)},
            {"nodes_per_feature", std::move(per_feature)},
            {"windows", histograms_to_json(forest.stats.windows)}}}};
}

Forest forest_from_json(const nlohmann::json& json, const std::filesystem::path& file) {
  const JsonView j(json, file);
  check_format(j, kFormat, {kVersion});
  Forest f;
  const JsonView image = j.at("image");
  f.width = read_int(image, "width", 1, 32000);
  f.height = read_int(image, "height", 1, 32000);
  f.classes = read_names(j.at("classes"), false);
  if (f.classes.size() > 255) j.fail("more than 255 classes", "classes");
  f.features = read_names(j.at("features"), true);
  f.textons = j.boolean("textons");
  if (f.features.empty() && !f.textons) j.fail("is empty (and no texton tests)", "features");
  f.params = params_from_json(j.at("params"));
  const WindowBounds bounds = WindowBounds::for_image(f.width, f.height);
  const int num_attr = f.num_attributes();
  const int nf = static_cast<int>(f.features.size());
  const JsonView trees = j.at("trees");
  if (trees.size() == 0) trees.fail("no trees");
  for (std::size_t t = 0; t < trees.size(); ++t) {
    const JsonView nodes = trees.at(t).at("nodes");
    const std::size_t n = nodes.size();
    if (n == 0) nodes.fail("no nodes");
    if (n > static_cast<std::size_t>(std::numeric_limits<int>::max() / 2)) nodes.fail("too many nodes");
    Tree tree;
    tree.nodes.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const JsonView jn = nodes.at(i);
      Node& node = tree.nodes[i];
      if (auto counts = jn.maybe("counts")) {
        // A leaf holds counts and nothing else: a node with both would be read as a leaf and its split
        // silently dropped, changing every result below it.
        for (const char* key : kSplitKeys)
          if (jn.has(key)) jn.fail("has both \"counts\" (a leaf) and the split field \"" + std::string(key) + "\"");
        if (counts->size() != f.classes.size())
          counts->fail("has " + std::to_string(counts->size()) + " entries, expected one per class (" +
                       std::to_string(f.classes.size()) + ")");
        std::uint64_t total = 0;
        for (std::size_t c = 0; c < counts->size(); ++c) {
          const auto v = counts->at(c).as_integer();
          if (v < 0 || v > std::numeric_limits<std::uint32_t>::max()) counts->at(c).fail("out of range");
          node.counts.push_back(static_cast<std::uint32_t>(v));
          total += static_cast<std::uint64_t>(v);
        }
        if (total == 0) counts->fail("a leaf needs at least one test");
        continue;
      }
      node.feature = read_int(jn, "f", 0, num_attr - 1);
      node.win.dx = read_int(jn, "dx", -bounds.max_dx, bounds.max_dx);
      node.win.dy = read_int(jn, "dy", -bounds.max_dy, bounds.max_dy);
      node.win.w = read_int(jn, "w", 1, bounds.max_w);
      node.win.h = read_int(jn, "h", 1, bounds.max_h);
      if (node.feature >= nf && (node.win.w != 1 || node.win.h != 1))
        jn.fail("a texton test has w = h = 1");
      node.threshold = jn.num("t");
      if (!std::isfinite(node.threshold)) jn.fail("must be finite", "t");
      node.left = read_int(jn, "left", static_cast<long>(i) + 1, static_cast<long>(n) - 1);
      node.right = read_int(jn, "right", static_cast<long>(i) + 1, static_cast<long>(n) - 1);
    }
    f.trees.push_back(std::move(tree));
  }
  f.compute_stats();
  if (auto stats = j.maybe("stats")) {
    if (auto s = stats->maybe("seconds")) f.stats.seconds = s->as_num();
    if (auto st = stats->maybe("trees")) {
      if (st->size() != f.trees.size()) st->fail("expected one entry per tree");
      for (std::size_t t = 0; t < st->size(); ++t)
        if (auto s = st->at(t).maybe("seconds")) f.stats.trees[t].seconds = s->as_num();
    }
  }
  return f;
}

void save_forest(const Forest& forest, const std::filesystem::path& path) {
  write_json_atomic(path, forest_to_json(forest), -1);
}

Forest load_forest(const std::filesystem::path& path) {
  const nlohmann::json doc = read_json(path, kMaxLargeFileBytes);
  try {
    return forest_from_json(doc, path);
  } catch (const std::bad_alloc&) {  // the parsed file and the forest side by side did not fit
    throw Error(path.string(), "", "out of memory building the forest it holds");
  }
}

void check_compatible(const Forest& forest, const std::vector<std::string>& classes,
                      const std::vector<std::string>& features, const std::filesystem::path& file) {
  if (forest.classes != classes)
    throw Error(file.string(), "classes",
                "the forest has classes " + join(forest.classes) + " but the data has " + join(classes));
  if (forest.features != features)
    throw Error(file.string(), "features",
                "the forest uses features " + join(forest.features) + " but the data has " + join(features));
}

std::vector<double> class_prior(const Forest& forest) {
  std::vector<double> prior(forest.classes.size(), 0.0);
  for (const Tree& tree : forest.trees)
    for (const Node& node : tree.nodes)
      if (node.is_leaf())
        for (std::size_t c = 0; c < node.counts.size() && c < prior.size(); ++c) prior[c] += node.counts[c];
  double total = 0.0;
  for (double n : prior) total += n;
  if (total > 0.0)
    for (double& p : prior) p /= total;
  return prior;
}

std::vector<double> prior_correction(const Forest& forest, double power) {
  if (!(power >= 0.0) || !std::isfinite(power)) throw Error("", "prior_power", "expected a finite power >= 0");
  const std::vector<double> prior = class_prior(forest);
  double smallest = 0.0;
  for (double p : prior)
    if (p > 0.0 && (smallest == 0.0 || p < smallest)) smallest = p;
  std::vector<double> weights(prior.size(), 1.0);
  for (std::size_t c = 0; c < prior.size(); ++c)
    if (prior[c] > 0.0) weights[c] = std::pow(smallest / prior[c], power);
  return weights;
}

WindowHistograms learned_windows(const std::vector<Forest>& forests) {
  if (forests.empty()) throw Error("", "forests", "no forest to learn windows from");
  WindowHistograms h = WindowHistograms::zeros(forests.front().stats.windows.bounds);
  for (const Forest& f : forests) h.add(f.stats.windows);
  if (h.total() <= 0.0) throw Error("", "forests", "the forests have no window split to learn from");
  return h;
}

}  // namespace smseg::forest
