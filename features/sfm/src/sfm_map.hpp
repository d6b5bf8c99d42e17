#pragma once
// The tracks of the monocular SfM and their growth by matching against the local map (sfm.cpp, step 5).
// Private to the frontend module.
//
// At CamVid's 1 Hz a point is often matched from one frame to the next and then missed, or seen again
// two frames later under a new track: consecutive matching alone gave tracks of 2.5-3.2 frames, left 92 %
// of the tracked keypoints without a 3D point and a third of the frames without enough 2D-3D matches for
// PnP. Matching each new frame's keypoints against the 3D points seen in the last few posed frames (the
// "track the local map" step of ORB-SLAM, Mur-Artal et al. 2015) joins such tracks to points the
// reconstruction already has.
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace smseg::sfm::sfm_map {

/// Which track each keypoint belongs to and each track's observations.
struct TrackTable {
  std::vector<std::vector<int>> tid;                    ///< [frame][keypoint] -> track
  std::vector<std::vector<std::pair<int, int>>> tobs;   ///< [track] -> (frame, keypoint), frames ascending

  /// Moves every observation of track `from` into track `into` when no frame holds both (a track has at
  /// most one keypoint per frame); returns false, changing nothing, otherwise.
  bool merge(int from, int into);
};

/// A keypoint of the frame and the map track (one with a 3D point) it was matched to.
struct MapCandidate {
  int keypoint = 0;
  int track = 0;
};

/// Candidates for frame t: its keypoints whose track has no 3D point, matched by descriptor to the
/// tracks with a 3D point (has_point) that are observed in the `window` frames (ascending) and not in
/// frame t. A
/// map track's descriptor is that of its latest observation in the window. A match must pass Lowe's
/// ratio test, and a map track goes to one keypoint at most (the nearest). Geometry is not checked here:
/// the caller keeps the candidates that PnP confirms.
std::vector<MapCandidate> match_local_map(int t, const std::vector<int>& window, const TrackTable& tracks,
                                          const std::vector<char>& has_point, const std::vector<cv::Mat>& descriptors,
                                          int norm, double ratio);

}  // namespace smseg::sfm::sfm_map
