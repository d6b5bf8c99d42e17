#pragma once
// Dense depth of a monocular frame from its posed neighbours: a plane sweep (Collins 1996; Gallup et
// al. 2007), the monocular source of the dense geometry channels (extract-features --dense on a
// structure-from-motion run).
//
// For each of a set of fronto-parallel planes of the reference camera, uniform in inverse depth
// between 1/max_depth and 1/min_depth (as many as it takes for a point to move at most max_step_px
// between consecutive planes in the widest neighbour, f |t| (1/Z_1 - 1/Z_2), within [min_planes,
// max_planes]: 1 Hz video needs hundreds, 15 Hz a few dozen), each neighbour image is warped onto
// the reference image through the plane's homography H = K (R + t n^T / d) K^-1 (R, t: reference
// camera to neighbour camera) and compared with it by zero-mean normalised cross-correlation over
// window x window pixels. Per pixel:
//   - the depth is the plane of the best mean score over the neighbours (a parabola through it and
//     its two neighbouring planes refines it between planes);
//   - it is valid only when that score is at least min_score and at least min_score_range above the
//     worst plane's (a still camera, or a pixel at the focus of expansion, fits every plane), the
//     reference window has texture (grey-level standard deviation >= min_texture: flat sky and road
//     give flat costs), and the neighbours agree: each neighbour's own best plane is within
//     `consistency_planes` planes of the joint one (a moving object, an occlusion or a repetitive
//     pattern seen from two sides rarely gives the same wrong depth in both).
// Near the focus of expansion of a forward-moving camera the parallax vanishes and the scores are
// flat: those pixels rarely pass the checks, which is what the validity mask is for.
//
// `scale` < 1 sweeps images shrunk by that factor (area averaging; the camera's focal length and
// principal point scaled with them, so the number of planes falls with the pixels a plane step moves)
// and brings the depth back to the reference's size: bilinear where the four source pixels around a
// pixel all have a depth, else the nearest one's (so a depth is never blended with "none"). The
// window, texture and score thresholds apply at the sweep's resolution. Each warp is most of the
// sweep's time (docs/camvid.md, "Dense geometry from the plane sweep"), so 0.5 costs a quarter of 1
// where the number of planes is at its cap (1 Hz video) and an eighth where it is not.

#include <vector>

#include <opencv2/core.hpp>

#include "smseg/sequence/sequence.hpp"

namespace smseg::stacks {

struct PlaneSweepOptions {
  double max_step_px = 1.5;     ///< largest image motion between consecutive planes (sets their number)
  int min_planes = 32, max_planes = 256;  ///< bounds on the number of depth hypotheses
  double min_depth = 2.0;       ///< metres (the world of the poses)
  double max_depth = 80.0;      ///< metres
  int window = 9;               ///< ZNCC window side, pixels (odd)
  double min_score = 0.6;       ///< ZNCC of the chosen plane, mean over the neighbours
  double min_texture = 3.0;     ///< grey-level standard deviation of the reference window
  double min_score_range = 0.2; ///< best minus worst plane score: flat scores (no parallax) say nothing
  int consistency_planes = 2;   ///< each neighbour's best plane within this many planes of the joint one
  double scale = 1.0;           ///< resolution of the sweep against the images' (0.1..1, see above)
  void validate() const;        ///< Error("", "plane_sweep.<field>", reason)
};

/// A neighbour: its grey image (CV_8UC1, the reference's size) and camera-to-world pose.
struct SweepView {
  cv::Mat gray;
  sequence::Pose pose;
};

/// The number of planes the sweep uses for these neighbours (see the header comment).
int sweep_plane_count(const sequence::Pose& reference_pose, const std::vector<SweepView>& neighbours, double focal,
                      const PlaneSweepOptions& options);

/// Depth (CV_32FC1, metres along the optical axis, 0 where invalid) of the reference frame. Needs at
/// least two neighbours for the consistency check (fewer: every pixel invalid). `camera` (fx, fy,
/// cx, cy) is shared by all the frames: for an SfM run, sfm_camera (sfm.hpp). Error without fx.
cv::Mat plane_sweep_depth(const cv::Mat& reference_gray, const sequence::Pose& reference_pose,
                          const std::vector<SweepView>& neighbours, const sequence::Calibration& camera,
                          const PlaneSweepOptions& options = {});

struct SweepNeighbourOptions {
  int reach = 4;                 ///< frames either side to look at
  double target_baseline = 0.5;  ///< metres: the nearest frame this far away is taken
  double min_baseline = 0.05;    ///< metres: nearer frames are never taken (no parallax)
};

/// Which frames a plane sweep of frame f reads. `usable[g]` says frame g has a camera pose (frames
/// outside the reconstructed range do not). On each side, within `reach` frames, the nearest usable
/// frame at least target_baseline from f's camera, else the widest at least min_baseline; at the
/// ends of a sequence, the one side's choice and the next qualifying frame beyond it (else the
/// nearest one short of it). Empty when f is not usable or
/// fewer than two qualify.
std::vector<int> sweep_neighbours(int f, const std::vector<bool>& usable, const std::vector<sequence::Pose>& poses,
                                  const SweepNeighbourOptions& options = {});

}  // namespace smseg::stacks
