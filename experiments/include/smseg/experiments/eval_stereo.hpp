#pragma once
// eval-stereo's work: the stereo matchers on the Middlebury 2014 quarter-resolution training pairs
// (DATA/images/<Scene>/{im0,im1}.png and calib.txt, DATA/groundtruth/<Scene>/{disp0GT.pfm,
// mask0nocc.png}), scored per scene and matcher (share of pixels with a valid disparity, bad-pixel
// rate over the non-occluded pixels with a valid estimate), and the Markdown table and JSON of the
// results.

#include <filesystem>
#include <string>
#include <vector>

#include "smseg/common/io.hpp"
#include "smseg/frontend/stereo.hpp"

namespace smseg::experiments {

/// One matcher on one scene: its score and the seconds compute_disparity took.
struct StereoEvalRow {
  std::string scene;
  std::string method;
  frontend::DisparityScore score;
  double seconds = 0;
};

/// Every matcher on every scene.
struct StereoEvaluation {
  std::string data;  ///< the data folder as given
  double threshold = 2.0;
  std::vector<frontend::StereoOptions> matchers;
  std::vector<std::string> scenes;  ///< sorted
  std::vector<StereoEvalRow> rows;  ///< scene-major: rows[s * matchers.size() + m]
};

/// The matchers named in `methods` (bm, sgbm, sparse; Error naming --methods otherwise), each
/// validated: BM and sparse as `bm`, SGBM as `sgbm` with BM's uniqueness ratio, left-right tolerance
/// and speckle window.
std::vector<frontend::StereoOptions> stereo_matchers(const std::vector<std::string>& methods,
                                                     const frontend::StereoOptions& bm, frontend::StereoOptions sgbm);

/// Runs every matcher on every scene of `data` (each with the scene's disparity range rounded up to a
/// multiple of 16), with a progress line on stderr. Error when the folder holds no scenes or a scene's
/// images, ground truth and mask differ in size.
StereoEvaluation evaluate_stereo(const std::string& data, const std::vector<frontend::StereoOptions>& matchers,
                                 double threshold);

/// The table: one row per scene, per matcher the valid and bad shares in percent, then the means.
std::string stereo_eval_markdown(const StereoEvaluation& e);

/// The results: format smseg-stereo-eval version 1, per matcher its options and means, per row its score.
Json stereo_eval_json(const StereoEvaluation& e);

}  // namespace smseg::experiments
