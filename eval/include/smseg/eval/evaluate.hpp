#pragma once
// Evaluating a forest on the labelled frames of work folders (thesis 2.3.4, 3.2.7; DESIGN section 5):
// per-pixel classification or grid voting, scores, and pictures per test frame.

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "smseg/eval/metrics.hpp"
#include "smseg/features/stack.hpp"
#include "smseg/forest/classify.hpp"
#include "smseg/forest/forest.hpp"

namespace smseg::eval {

struct EvalOptions {
  features::FrameRange frames;  ///< labelled frames inside this range are tested
  int grid = 0;                 ///< 0: per pixel; B > 0: B x B cells, each labelled by `votes` pixels
  int votes = 6;                ///< V: distinct random pixels per cell that vote (summed distributions);
                                ///< V >= the cell's pixel count: every pixel votes
  std::uint64_t seed = 1;       ///< where the voting pixels fall
  fs::path pictures;            ///< folder for the pictures per test frame; empty: none
  bool progress = false;
  void validate() const;
};

struct FrameResult {
  std::string work;
  int frame = 0;
  Confusion confusion;
  double seconds = 0;  ///< classification time of the frame (not pictures, not I/O)
};

struct EvalResult {
  Confusion confusion;
  std::vector<FrameResult> frames;
  double seconds_per_frame = 0;
  /// results.json: global_accuracy, class_average_accuracy, mean_iou, confusion (counts and
  /// normalised), per_frame, accuracy spread, seconds_per_frame, parameters of the run and the forest.
  nlohmann::json to_json(const forest::Forest& forest, const EvalOptions& opt,
                         const std::vector<std::string>& works) const;
};

/// Labels one frame: per pixel, or by grid voting. labels: CV_8UC1 (height x width).
cv::Mat label_frame(const forest::Classifier& classifier, const forest::FrameData& frame, const EvalOptions& opt,
                    int frame_index);

EvalResult evaluate(const forest::Forest& forest, const std::vector<fs::path>& works, const EvalOptions& opt);

}  // namespace smseg::eval
