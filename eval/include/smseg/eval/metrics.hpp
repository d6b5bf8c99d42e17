#pragma once
// Scores of a labelling against ground truth (docs/design.md section 5). Void pixels never count.
//   global accuracy         share of (non-void) pixels labelled right ("correctness" in the thesis)
//   class-average accuracy  mean over classes present in the ground truth of per-class recall
//   mean IoU                mean over classes present in ground truth or prediction of TP/(TP+FP+FN)
// Beyond the thesis (its 5.2.2, "output evaluation"):
//   mean cost per pixel     sum over (truth, output) of count x cost(truth, output) / pixels, from a
//                           class-to-class cost matrix (wall taken for floor may be worse than for ceiling)
//   boundary-tolerant accuracy  (right + near misses) / pixels, where a near miss is a wrong pixel within
//                           T pixels (Euclidean) of a ground-truth pixel of the class it was labelled

#include <cstdint>
#include <string>
#include <vector>

#include <filesystem>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace smseg::eval {

class Confusion {
 public:
  explicit Confusion(int classes = 0);

  int classes() const { return n_; }
  /// Adds a labelled frame: truth and predicted are CV_8UC1 class ids; truth 255 (void) is skipped.
  void add(const cv::Mat& truth, const cv::Mat& predicted);
  void add(int truth, int predicted, std::int64_t count = 1);
  void merge(const Confusion& other);

  std::int64_t at(int truth, int predicted) const { return counts_[std::size_t(truth) * n_ + predicted]; }
  std::int64_t total() const;
  std::int64_t row_total(int truth) const;

  double global_accuracy() const;         ///< NaN when empty
  double class_average_accuracy() const;  ///< over classes with ground-truth pixels
  double mean_iou() const;
  std::vector<double> recall() const;     ///< per class, NaN where the class has no pixels
  std::vector<double> iou() const;

  nlohmann::json counts_json() const;      ///< rows = truth
  nlohmann::json normalised_json() const;  ///< row-normalised (NaN rows as null)
  /// The row-normalised matrix as text, like thesis Table 4.1 (rows: truth, columns: output, %).
  std::string table(const std::vector<std::string>& names) const;

 private:
  int n_;
  std::vector<std::int64_t> counts_;
};

/// A class-to-class cost matrix, file format "smseg-costs" version 1 (JSON):
///   { "format": "smseg-costs", "version": 1,
///     "classes": ["floor", "wall", "ceiling", ...],        // every class of the forest, once, any order
///     "costs": [[0, 2, 1, ...], [2, 0, 1, ...], ...] }     // costs[truth][output]: finite, >= 0,
///                                                          // 0 on the diagonal
struct CostMatrix {
  std::vector<std::string> classes;  ///< in the order of `classes` passed to load (the forest's)
  std::vector<double> cost;          ///< classes x classes, row = truth
  double at(int truth, int output) const { return cost[std::size_t(truth) * classes.size() + output]; }
  /// Reads and validates `path`; rows and columns are reordered to `classes`. Error naming the file
  /// and field when malformed or when its class names are not exactly `classes`.
  static CostMatrix load(const std::filesystem::path& path, const std::vector<std::string>& classes);
  static CostMatrix from_json(const nlohmann::json& j, const std::filesystem::path& file,
                              const std::vector<std::string>& classes);
};

/// Mean cost per counted pixel; NaN when the confusion is empty.
double mean_cost(const Confusion& confusion, const CostMatrix& costs);

/// Near misses of a labelling: wrong non-void pixels whose output class has a ground-truth pixel within
/// `tolerance` pixels (Euclidean distance <= tolerance). tolerance 0: none.
std::int64_t near_misses(const cv::Mat& truth, const cv::Mat& predicted, int tolerance);

}  // namespace smseg::eval
