#pragma once
// eval-stereo-path's work: a front end's output (WORK/tracks.json, from the stereo front end or from
// monocular structure from motion) against a synthetic sequence's ground truth: absolute trajectory
// error (rigid and similarity alignment), relative pose error per frame pair, the relative depth error
// of the tracked points; the report, the result file and a top-down plot of both paths.

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/common/io.hpp"
#include "smseg/frontend/motion.hpp"
#include "smseg/frontend/trajectory.hpp"

namespace smseg::experiments {

struct StereoPathEvaluation {
  std::string sequence;                ///< the sequence's manifest
  std::filesystem::path tracks;        ///< the tracks file read
  std::vector<sequence::Pose> estimate, truth;  ///< the front end's path and the ground truth of the same frames
  frontend::PathError rigid, similarity;
  frontend::RelativeError rpe;
  frontend::DepthError depth;
  double end_drift = 0;                ///< metres between the last centres, start-aligned
  frontend::FrontEndSummary summary;  ///< as the tracks file has it (its sfm part is reported)
};

/// Reads the sequence and WORK/tracks.json (or the tracks file `work` itself) and scores the path and
/// the tracked depths. Error when the sequence has no ground-truth poses or fewer frames than the file.
StereoPathEvaluation evaluate_stereo_path(const std::string& sequence, const std::string& work);

/// The report printed on stdout, one line per measure (and one for SfM work folders).
std::string stereo_path_report(const StereoPathEvaluation& e);

/// The result file: format smseg-stereo-path-eval version 1.
Json stereo_path_json(const StereoPathEvaluation& e);

/// Top-down (world X-Z) plot of size x size pixels, ground truth red, estimate black (both as given,
/// aligned at frame 0).
cv::Mat stereo_path_plot(const StereoPathEvaluation& e, int size);

}  // namespace smseg::experiments
