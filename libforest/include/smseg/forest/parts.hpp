#pragma once
// A forest trained in parts: each part holds a contiguous range of the M trees, trained on its own
// (another process or machine, e.g. one Slurm array task each), and the parts are merged into the
// whole forest. Tree t depends only on (data, params, t), so the merged forest is the forest one
// train_forest call gives for the same seed, byte for byte, except the timing fields (stats.seconds,
// stats.trees[i].seconds).
//
// File format "smseg-forest-part" version 1 (JSON):
//   { "format": "smseg-forest-part", "version": 1,
//     "trees": {"begin": A, "end": B},   // this part holds trees A..B-1 of forest.params.M
//     "forest": {...},                   // an "smseg-forest" holding only those trees
//     "training_data": {...} }           // optional: what the trainer says it trained on
// A part is not a forest: load_forest refuses it (its format differs), so a part is never taken for
// the whole.

#include <filesystem>
#include <string>
#include <vector>

#include "smseg/forest/forest.hpp"

namespace smseg::forest {

/// Trees begin..end-1 (half-open, like frame ranges).
struct TreeRange {
  int begin = 0, end = 0;

  int size() const { return end - begin; }
  /// Error(file, field, ...) unless 0 <= begin < end <= M.
  void validate(int M, const std::string& field, const std::string& file = {}) const;
  /// "A:B" (or "A:", up to M) as given to an option; Error naming `option` when malformed or outside
  /// 0..M.
  static TreeRange parse(const std::string& text, const std::string& option, int M);
  std::string to_string() const;  ///< "A:B"
  bool operator==(const TreeRange&) const = default;
};

/// M trees split into `parts` contiguous ranges whose sizes differ by at most one (earlier ranges
/// get the extra trees). Error unless 1 <= parts <= M.
std::vector<TreeRange> split_trees(int M, int parts, const std::string& option = "parts");

/// One part as read from its file.
struct ForestPart {
  std::filesystem::path file;
  TreeRange range;
  Forest forest;  ///< only the range's trees; forest.params.M is the whole forest's
  /// What the part was trained on, as its trainer recorded it (say, each work folder's identity and
  /// the frames taken from it); null when the part records nothing. The forest itself cannot tell: two
  /// parts trained on other frames have the same image, classes, features and parameters.
  nlohmann::json training_data;
};

/// Writes the part atomically; training_data, when not null, is recorded beside it for the merge.
void save_forest_part(const Forest& part, TreeRange range, const std::filesystem::path& path,
                      const nlohmann::json& training_data = nullptr);
/// Validates the part (format, the forest inside, its tree count against the range).
ForestPart load_forest_part(const std::filesystem::path& path);

/// The whole forest from its parts (in any order): every part must come from the same training
/// (image, classes, features, textons, params including seed and M, and the same training_data, or
/// none recorded by any) and the ranges must cover 0..M-1 exactly once; otherwise one Error naming the
/// part file and the problem (the differing field, the overlapping part, the missing trees). Tree timings are kept; stats.seconds is the sum
/// of the parts' training times (the work done, not a wall time).
Forest merge_forest_parts(const std::vector<ForestPart>& parts);
Forest merge_forest_parts(const std::vector<std::filesystem::path>& files);

}  // namespace smseg::forest
