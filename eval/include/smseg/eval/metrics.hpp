#pragma once
// Scores of a labelling against ground truth (DESIGN section 5). Void pixels never count.
//   global accuracy         share of (non-void) pixels labelled right ("correctness" in the thesis)
//   class-average accuracy  mean over classes present in the ground truth of per-class recall
//   mean IoU                mean over classes present in ground truth or prediction of TP/(TP+FP+FN)

#include <cstdint>
#include <string>
#include <vector>

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

}  // namespace smseg::eval
