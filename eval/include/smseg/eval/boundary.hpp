#pragma once
// Boundary F1 (the BF score of Csurka, Larlus & Perronnin 2013): how well the edges between labels of
// an output follow the ground truth's, the quality graph-cut smoothing is meant to improve (thesis 4.2
// complains of ragged, noisy boundaries).
//
// A boundary pixel of a label image is a non-void pixel whose right or lower neighbour is non-void and
// carries another label (in the truth; for the output, only where the truth is not void there either).
// Precision: share of output boundary pixels within T px (Euclidean) of a truth boundary pixel; recall:
// share of truth boundary pixels within T px of an output boundary pixel; F1 their harmonic mean.

#include <cstdint>

#include <opencv2/core.hpp>

namespace smseg::eval {

struct BoundaryCounts {
  std::int64_t output = 0, output_matched = 0;  ///< output boundary pixels, those near a truth boundary
  std::int64_t truth = 0, truth_matched = 0;    ///< truth boundary pixels, those near an output boundary

  void merge(const BoundaryCounts& o) {
    output += o.output, output_matched += o.output_matched, truth += o.truth, truth_matched += o.truth_matched;
  }
  double precision() const;  ///< NaN without output boundaries
  double recall() const;     ///< NaN without truth boundaries
  double f1() const;         ///< NaN when either is NaN; 0 when both are 0
};

/// Counts for one frame: truth and predicted CV_8UC1 class ids (255 = void in truth), tolerance T >= 0.
BoundaryCounts boundary_counts(const cv::Mat& truth, const cv::Mat& predicted, int tolerance);

}  // namespace smseg::eval
