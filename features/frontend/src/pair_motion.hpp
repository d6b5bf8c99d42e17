#pragma once
// The per-pair steps of the stereo motion (motion.hpp), shared by the whole-sequence front end
// (estimate_pair_motions, chain_poses) and the streamed one (stream.hpp), so that both compute the
// same motion with the same arithmetic. Private to the frontend module.

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "smseg/frontend/motion.hpp"

namespace smseg::frontend::detail {

/// One pair's correspondences, in track order: 3D points in frames t (P) and t+1 (Q) and, for the
/// refinement, their (u, v, d) measurements (ma, mb).
struct PairData {
  std::vector<Eigen::Vector3d> P, Q, ma, mb;
};

/// Per pair of the `npairs` pairs from first_frame, the correspondences of the tracks seen in both
/// of its frames (measurements only when asked).
std::vector<PairData> gather_pairs(const std::vector<Track>& tracks, int first_frame, int npairs, bool measurements);

/// One motion hypothesis of a pair: RANSAC (Arun) then, when asked, the reprojection refinement.
struct Candidate {
  PairMotion pm;
  std::vector<std::uint8_t> inliers;  ///< over the pair's correspondences
};

/// The hypotheses of one pair that do not depend on the other pairs (stages 1 and 2, and the second
/// hypothesis from the first one's outliers). `stream` is the pair's random stream (its first frame).
std::vector<Candidate> pair_candidates(const PairData& d, std::uint64_t stream, const RansacOptions& o,
                                       const StereoCamera* cam, const RefineOptions* ro);

/// Stage 3, in frame order: adds the hypothesis refined from `previous` (the last chosen good motion),
/// picks the candidate closest to it, and updates `previous` when the pick is good.
PairMotion choose_pair_motion(std::vector<Candidate>& candidates, const PairData& d,
                              std::optional<RigidMotion>& previous, const RansacOptions& o, const StereoCamera* cam,
                              const RefineOptions* ro);

/// The camera path, one pair at a time (chain_poses): bad pairs are bridged with the last good motion.
class PathChain {
 public:
  explicit PathChain(double camera_height);
  const sequence::Pose& first() const { return first_; }
  /// The pose of the pair's second frame; marks the pair bridged (and replaces its motion) when bad.
  sequence::Pose step(PairMotion& pm);

 private:
  sequence::Pose first_;
  Eigen::Matrix3d Rw_;
  Eigen::Vector3d c_;
  RigidMotion last_good_;  // identity until a good pair is seen
};

}  // namespace smseg::frontend::detail
