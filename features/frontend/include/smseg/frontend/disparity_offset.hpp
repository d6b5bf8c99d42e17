#pragma once
// The disparity offset of a stereo rig, found from its own tracks (self-calibration).
//
// A right image shifted against its calibration adds a constant error to every disparity
// (docs/real-scale.md, "KITTI front end"); the points then bend with their depth (z = f b / d), and no
// rigid motion carries one frame's points onto the next frame's observations as well as with the
// right disparities. So for a trial offset added to every disparity, each consecutive pair of frames
// gets the rigid motion that best reprojects its tracked points (Gauss-Newton on a Huber loss), and
// the trial scores the median reprojection error over all pairs; coarse trials (-3..3 px by 0.5),
// fine ones around the best (by 0.125), and the vertex of the parabola through the best and its
// neighbours give the offset. Both front ends estimate it from the same first frames
// (kOffsetFrames) and hold it for the rest, so the whole-sequence and the streamed front end agree.
//
// The estimate is kept only when it is clearly better than none: the median error at least
// kOffsetMinGain below the error with no extra offset, and the best coarse trial inside the range.
// A rig whose calibration is right (KITTI seq1, the synthetic scenes) keeps its disparities bit for
// bit; a slow camera, whose pairs barely constrain the offset, is left alone too.

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/frontend/tracking.hpp"

namespace smseg::frontend {

struct StereoCamera;

/// How the offset added to every computed disparity is chosen (FrontEndOptions::disparity_offset).
struct DisparityOffsetChoice {
  enum class Mode {
    Auto,         ///< the calibration's, plus what the first frames' tracks ask for (self-calibration)
    Calibration,  ///< the sequence's calibration.disparity_offset as it is
    Pixels        ///< `pixels`, replacing the calibration's
  };
  Mode mode = Mode::Auto;
  double pixels = 0;
  bool operator==(const DisparityOffsetChoice& o) const { return mode == o.mode && pixels == o.pixels; }
};

/// "auto" | "calibration" | a number of pixels in -1000..1000; anything else is an Error naming `field`.
DisparityOffsetChoice parse_disparity_offset(const std::string& text, const std::string& field = "disparity_offset");
std::string disparity_offset_name(const DisparityOffsetChoice& choice);

inline constexpr int kOffsetFrames = 11;           ///< frames (10 pairs) the auto offset is estimated from
inline constexpr double kOffsetMinGain = 0.05;     ///< least relative fall of the median error to keep an estimate

struct OffsetEstimate {
  double extra = 0;           ///< pixels to add on top of the disparities it was estimated from (0 when not kept)
  double best = 0;            ///< the offset of least error, kept or not
  bool kept = false;
  int pairs = 0;              ///< frame pairs with enough correspondences
  double error_none_px = 0;   ///< median reprojection error with no extra offset
  double error_best_px = 0;   ///< the least median error over the trials
};

/// The offset estimated from consecutive frames' observations (disparities as the front end saw
/// them) and the matches between them (matches[t]: queryIdx in frames[t], trainIdx in frames[t + 1]).
OffsetEstimate estimate_disparity_offset(const std::vector<FrameObservations>& frames,
                                         const std::vector<std::vector<cv::DMatch>>& matches, const StereoCamera& camera);

/// `offset` pixels added to the observations' disparities (and their points moved) exactly as
/// apply_disparity_offset adds them to a map the observations are then read from: a disparity that is
/// no longer positive becomes invalid. A no-op for 0.
void offset_observations(FrameObservations& observations, double offset, const sequence::Calibration& calib);

}  // namespace smseg::frontend
