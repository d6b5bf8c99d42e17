#pragma once
// The forest model (docs/design.md section 3.4): classes, the image size its windows were sized for, feature
// names, training parameters and seed, per tree a flat node array, and training statistics.
// File format "smseg-forest" version 1 (JSON):
//   { "format": "smseg-forest", "version": 1,
//     "image": {"width": W, "height": H}, "classes": [...], "features": [...], "textons": bool,
//     "params": {...},                       // TrainParams, see params_to_json
//     "trees": [ {"nodes": [ {"dx","dy","w","h","f","t","left","right"}   // split node
//                            | {"counts": [n_0, ..., n_{C-1}]} ] } ],    // leaf: test counts per class
//     "stats": { "seconds", "trees": [{"nodes","leaves","depth","seconds"}],
//                "nodes_per_feature": {name: count}, "windows": {"bounds", "dx","dy","w","h"} } }
// Node "f" indexes the attributes: the features in order, then (with textons) fP, fPs, fPd, fPda.
// A split sends a pixel left when float(value) < t (t a double; value < t goes left). Node 0 is the
// root; children have larger indices than their parent.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "smseg/forest/params.hpp"
#include "smseg/forest/window.hpp"

namespace smseg::forest {

struct Node {
  int feature = -1;        ///< attribute index; -1 for a leaf
  Window win;              ///< window (texton tests: the offset, w = h = 1)
  double threshold = 0.0;  ///< value < threshold goes left
  int left = -1, right = -1;
  std::vector<std::uint32_t> counts;  ///< leaf only: tests per class
  bool is_leaf() const { return feature < 0; }
};

struct Tree {
  std::vector<Node> nodes;  ///< nodes[0] is the root
};

struct TreeStats {
  int nodes = 0, leaves = 0, depth = 0;  ///< depth: longest root-to-leaf path (root alone = 0)
  double seconds = 0.0;
};

struct ForestStats {
  double seconds = 0.0;                          ///< wall time of training
  std::vector<TreeStats> trees;
  std::vector<std::int64_t> nodes_per_feature;   ///< split nodes per attribute (thesis Fig 4.3b)
  WindowHistograms windows;                      ///< chosen windows of window-feature splits (Fig 4.19)
};

struct Forest {
  int width = 0, height = 0;           ///< image size the windows were sized for
  std::vector<std::string> classes;
  std::vector<std::string> features;   ///< summed-area-table features, in the order frames give them
  bool textons = false;
  TrainParams params;
  std::vector<Tree> trees;
  ForestStats stats;

  int num_attributes() const { return static_cast<int>(features.size()) + (textons ? kNumTextonTests : 0); }
  std::string attribute_name(int f) const;
  /// Recomputes the structural statistics (per-tree nodes, leaves, depth; nodes per feature;
  /// window histograms) from the trees, keeping the timings.
  void compute_stats();
};

nlohmann::json forest_to_json(const Forest& forest);
/// Validates everything (format, version, names, node indices and windows, leaf sizes);
/// any problem is one smseg::Error naming `file` and the field.
Forest forest_from_json(const nlohmann::json& j, const std::filesystem::path& file);

void save_forest(const Forest& forest, const std::filesystem::path& path);  ///< atomic
Forest load_forest(const std::filesystem::path& path);

/// Error naming `file` when the forest's classes or features differ from the expected ones.
void check_compatible(const Forest& forest, const std::vector<std::string>& classes,
                      const std::vector<std::string>& features, const std::filesystem::path& file);

/// The class frequencies the trees were grown from: each class's share of the training tests that
/// reached the leaves, over all trees (sums to 1; a class no test had gets 0). With balanced training
/// (TrainParams::balance) it is the balanced sample's prior, the one the leaf distributions carry.
std::vector<double> class_prior(const Forest& forest);

/// Weights that correct the forest's class prior at test time: w[c] = (prior_min / prior[c])^power,
/// so that argmax_c w[c] p(c|x) is argmax_c p(c|x) / prior[c]^power (0: w = 1, no correction; 1: the
/// posterior under a flat prior). The largest weight is 1; a class with no training test gets 1.
std::vector<double> prior_correction(const Forest& forest, double power);

/// The learned window law: the sum of the forests' chosen-window histograms (all must share the
/// same window bounds, else Error). Use as TrainParams::windows.learned with mode Learned.
WindowHistograms learned_windows(const std::vector<Forest>& forests);

}  // namespace smseg::forest
