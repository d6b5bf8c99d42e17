#pragma once
// Graph-cut smoothing of the forest's per-pixel output (beyond the thesis: its 4.2 complains of ragged,
// noisy boundaries). Every pixel runs through every tree; the summed leaf distribution, normalised, is
// the pixel's class posterior p. The labelling minimises
//   E(l) = sum_i -log max(p_i(l_i), p_min)
//        + lambda * sum_{i~j} exp(-beta (I_i - I_j)^2) / dist(i, j) [l_i != l_j]
// over the 4- or 8-connected image grid (dist 1, or sqrt 2 for diagonal neighbours), a contrast-sensitive
// Potts term (Boykov & Jolly 2001, as in GrabCut) on the frame's greyscale image I, with
// beta = 1 / (2 <(I_i - I_j)^2>) averaged over the neighbour pairs of the frame (0 on a flat image).
// Minimised by alpha-expansion (smseg/graphcut/graphcut.hpp) from the per-pixel MAP labelling, so the
// energy is never above that of the unsmoothed output; lambda = 0 gives the MAP labels.
// With a label window of radius r > 0, a pixel may take only the labels that are the MAP label of a pixel
// within r of it: the moves are alpha-expansions restricted to the pixels near alpha's MAP regions, the
// rest of the frame keeps its label without being looked at (the expansion moves' work follows the
// labels' borders instead of every uncertain pixel once per label).

#include <algorithm>
#include <cstdint>
#include <span>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "smseg/forest/classify.hpp"

namespace smseg::eval {

enum class SmoothMethod { None, GraphCut };
std::string to_string(SmoothMethod m);
SmoothMethod smooth_method_from_string(const std::string& s, const std::string& option);  ///< none | graphcut

struct SmoothOptions {
  SmoothMethod method = SmoothMethod::None;
  double lambda = 1.0;       ///< weight of the smoothness term (unary costs are in nats), >= 0
  int connectivity = 8;      ///< 4 or 8
  /// At most this many alpha-expansion cycles, 1..100. One by default: on CamVid val the first cycle
  /// gave ~99.8 % of the energy drop of three and the same scores to 0.05 points (docs/graphcuts.md).
  int cycles = 1;
  double p_min = 1e-3;       ///< posterior floor of the unary cost (caps it at -log p_min), in (0, 1)
  /// A pixel may take only the labels that are some pixel's MAP label within this many pixels of it
  /// (Chebyshev distance); 0: every label everywhere (plain alpha-expansion). 0..1000. The default 5
  /// gave the plain expansion's accuracy on CamVid val to 0.01 points (docs/graphcuts.md).
  int label_window = 5;
  /// Label window only: the frame's rows are cut into this many bands, solved at once (one per core),
  /// each with the rest of the frame held at its MAP labels, then the seams between them (seam_reach()
  /// rows either side of each cut, at most half a band), each with the rest held at the bands' result.
  /// 1: the whole frame in one energy. 1..64; the labels depend on it, not on the thread count. The
  /// default 2 halves a frame's time on two cores; on CamVid val it kept the scores (docs/graphcuts.md).
  int bands = 2;
  /// Rows either side of a cut between bands that the seams relabel: twice the label window, at least
  /// 8. On a held-out CamVid frame a reach of 10 gave a lower energy than the whole frame's one energy
  /// (5: the same, 3: 0.01 % above), and on CamVid val scores closer to it (docs/graphcuts.md).
  int seam_reach() const { return std::max(8, 2 * label_window); }
  /// The Potts weight falls with the image's contrast across the edge (lambda exp(-beta dI^2) / dist);
  /// false: plain Potts (lambda / dist), which reads nothing of the image, so that a structure-and-motion
  /// run stays free of appearance (docs/camvid.md, "The benchmark's defaults").
  bool contrast = true;

  bool enabled() const { return method != SmoothMethod::None; }
  void validate() const;  ///< Error naming the option (--lambda, --connectivity, ...)
  nlohmann::json to_json() const;
};

struct SmoothReport {
  double beta = 0;
  double energy_before = 0;  ///< of the per-pixel MAP labelling
  double energy_after = 0;
  int cycles = 0;
  int moves = 0;
  std::int64_t allowed_labels = 0;  ///< pixel-label pairs the label window allows, summed over the pixels
  std::int64_t graph_nodes = 0;  ///< nodes of the expansion moves' max-flow graphs, summed over the moves
};

/// beta of the contrast term for an image (CV_8UC1 or CV_8UC3; squared colour distance for colour).
double contrast_beta(const cv::Mat& image, int connectivity);

/// Smoothed labels (CV_8UC1, image size) from per-pixel class distributions: dists holds
/// rows x cols x classes non-negative values (any scale; a pixel's are normalised by their sum; an
/// all-zero pixel is uniform), image is the frame (CV_8UC1 or CV_8UC3) the contrast term reads.
cv::Mat smooth_labels(std::span<const float> dists, int classes, const cv::Mat& image, const SmoothOptions& opt,
                      SmoothReport* report = nullptr);

/// Per-pixel classification of a whole frame, then smooth_labels on its greyscale image (Error when the
/// frame has none). classify_seconds / smooth_seconds (optional) receive the two times apart.
cv::Mat smooth_frame(const forest::Classifier& classifier, const forest::FrameData& frame, const SmoothOptions& opt,
                     double* classify_seconds = nullptr, double* smooth_seconds = nullptr,
                     SmoothReport* report = nullptr);

}  // namespace smseg::eval
