#pragma once
// Evaluating a forest on the labelled frames of work folders (thesis 2.3.4, 3.2.7, 4.5.1; docs/design.md
// section 5): per-pixel classification, grid or superpixel voting, scores, and pictures per test frame.
//
// Regions and votes (thesis 4.5.1). Per pixel: every pixel runs through every tree and takes the class
// of maximum summed leaf distribution. Grid: the image is cut into B x B cells (the last row and column
// of cells may be smaller). Superpixels: OpenCV ximgproc SLIC (SLICO, 10 iterations, connectivity
// enforced) on the stack's greyscale image with a region size of 10 px ("small") or 25 px ("large") or
// any N. In each region V distinct pixels are drawn (a counter-based generator keyed by seed, frame
// and region: the same pixels whatever the thread count; V >= the region's size: every pixel votes),
// classified, and the region takes the class with the largest sum of their distributions (vote "sum",
// the default) or the class most of them were labelled (vote "majority"); ties go to the lowest class
// index.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "smseg/eval/boundary.hpp"
#include "smseg/eval/metrics.hpp"
#include "smseg/eval/smooth.hpp"
#include "smseg/stacks/stack.hpp"
#include "smseg/forest/classify.hpp"
#include "smseg/forest/forest.hpp"

namespace smseg::options {
template <class S>
class Table;  // smseg/common/options.hpp
}

namespace smseg::eval {

enum class VoteRule {
  Sum,      ///< the class of the largest summed distribution over the voters
  Majority  ///< the class most voters were labelled
};
std::string to_string(VoteRule v);
VoteRule vote_rule_from_string(const std::string& s, const std::string& option);  ///< "sum" | "majority"

/// SLIC region sizes of "small" and "large" superpixels, in pixels.
inline constexpr int kSmallSuperpixels = 10;
inline constexpr int kLargeSuperpixels = 25;
/// "small" | "large" | N (region size in pixels, >= 4); Error naming `option` otherwise.
int superpixels_from_string(const std::string& s, const std::string& option);

struct EvalOptions {
  stacks::FrameRange frames;  ///< labelled frames inside this range are tested
  int grid = 0;                 ///< B > 0: B x B cells vote; 0: no grid
  int superpixels = 0;          ///< SLIC region size > 0: superpixels vote; 0: none (exclusive with grid)
  int votes = 6;                ///< V: distinct random pixels per region that vote (>= region size: all)
  VoteRule vote = VoteRule::Sum;
  int trees = 0;                ///< 0: every tree; m: only the first m trees of the forest
  double prior_power = 0;       ///< posterior / prior^power (forest::prior_correction); 0: none
  int tolerance = 3;            ///< T of the boundary-tolerant accuracy, pixels (Euclidean), >= 0
  std::optional<CostMatrix> costs;  ///< class-to-class costs: the mean cost per pixel is reported
  std::string costs_file;       ///< where the costs came from (reported only)
  std::uint64_t seed = 1;       ///< where the voting pixels fall
  fs::path pictures;            ///< folder for the pictures per test frame; empty: none
  SmoothOptions smooth;         ///< graph-cut smoothing of the per-pixel output (smooth.hpp); per pixel only
  bool progress = false;

  bool voting() const { return grid > 0 || superpixels > 0; }
  std::string mode() const { return grid > 0 ? "grid" : superpixels > 0 ? "superpixels" : "pixel"; }
  void validate() const;  ///< Error naming the option
};

/// EvalOptions' fields, declared once (options.hpp): eval-forest's options, the keywords of Python's
/// evaluate, run-experiment's evaluation keys (eval_options.cpp).
const options::Table<EvalOptions>& eval_options_table();

/// Timings of label_frame, seconds.
struct LabelTimes {
  double regions = 0;   ///< superpixel segmentation (0 for grid and per pixel)
  double classify = 0;  ///< drawing voters, classification and voting
  double smooth = 0;    ///< graph-cut smoothing (0 without)
};

struct FrameResult {
  std::string work;
  int frame = 0;
  Confusion confusion;
  std::int64_t near_misses = 0;  ///< wrong pixels within `tolerance` of a true region of the output class
  double seconds = 0;            ///< classification time of the frame (not superpixels, pictures, I/O)
  double superpixel_seconds = 0; ///< superpixel segmentation time of the frame
  double smooth_seconds = 0;     ///< graph-cut smoothing time of the frame
  BoundaryCounts boundary;       ///< boundary F1 counts at `tolerance` (boundary.hpp)
};

struct EvalResult {
  Confusion confusion;
  std::vector<FrameResult> frames;
  std::int64_t near_misses = 0;
  double seconds_per_frame = 0;             ///< classification only (as the thesis times it)
  double superpixel_seconds_per_frame = 0;  ///< superpixel segmentation, apart
  double smooth_seconds_per_frame = 0;      ///< graph-cut smoothing, apart
  /// The whole evaluation loop's wall time per frame (labelling, scoring, pictures), with
  /// frames_in_flight frames labelled at once (--smooth: one per thread, so each frame's own times
  /// above include sharing the cores with the others).
  double wall_seconds_per_frame = 0;
  /// Not in results.json, which must not depend on the thread count (timings aside).
  int frames_in_flight = 1;
  BoundaryCounts boundary;                  ///< summed over the frames
  /// Which test frames hold no tracked point (labelled from the class prior alone), for the user; empty
  /// when all have points (evaluate stops when none has).
  std::string frames_without_points;

  double tolerant_accuracy() const;  ///< (right + near misses) / pixels; NaN when empty
  /// results.json: global_accuracy, class_average_accuracy, mean_iou, boundary_tolerant_accuracy,
  /// mean_cost (with costs), confusion (counts and normalised), per_class, per_frame, accuracy spread,
  /// seconds_per_frame, superpixel_seconds_per_frame, parameters of the run and of the forest.
  nlohmann::json to_json(const forest::Forest& forest, const EvalOptions& opt,
                         const std::vector<std::string>& works) const;
};

/// The classifier an evaluation with `opt` uses: the first opt.trees trees, the class prior corrected by
/// opt.prior_power (from the whole forest's leaves).
forest::Classifier make_classifier(const forest::Forest& forest, const EvalOptions& opt);

/// The forest restricted to its first m trees (1 <= m <= trees; Error naming `option` otherwise).
forest::Forest first_trees(const forest::Forest& forest, int m, const std::string& option = "--trees");

/// SLIC superpixels of a greyscale image: CV_32SC1 region ids 0..n-1 (n returned in *count).
cv::Mat superpixels(const cv::Mat& gray, int region_size, int* count = nullptr);

/// Labels one frame: per pixel, or by grid or superpixel voting. Returns CV_8UC1 (height x width).
/// Superpixels need frame.gray.
cv::Mat label_frame(const forest::Classifier& classifier, const forest::FrameData& frame, const EvalOptions& opt,
                    int frame_index, LabelTimes* times = nullptr);

/// Voting over given regions (CV_32SC1 ids 0..count-1, each id used): what label_frame does after
/// cutting the frame into regions. Exposed for tests.
cv::Mat vote_regions(const forest::Classifier& classifier, const forest::FrameData& frame, const cv::Mat& regions,
                     int count, const EvalOptions& opt, int frame_index);

/// Checks that the forest fits the stacks (classes, features, image size): one Error naming the file.
void check_forest_fits(const forest::Forest& forest, const stacks::StackSet& set);
/// The same against one work folder's manifest (classes and image size; its features are checked where
/// they are selected by name).
void check_forest_fits(const forest::Forest& forest, const stacks::StackManifest& m);

EvalResult evaluate(const forest::Forest& forest, const std::vector<fs::path>& works, const EvalOptions& opt);
/// The same on stacks already open (the forest is checked against them).
EvalResult evaluate(const forest::Forest& forest, const stacks::StackSet& set, const std::vector<fs::path>& works,
                    const EvalOptions& opt);

}  // namespace smseg::eval
