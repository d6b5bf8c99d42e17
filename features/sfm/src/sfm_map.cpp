// Tracks of the monocular SfM and local-map matching (see sfm_map.hpp).
#include "sfm_map.hpp"

#include <algorithm>
#include <limits>

#include <opencv2/features2d.hpp>

namespace smseg::sfm::sfm_map {

bool TrackTable::merge(int from, int into) {
  if (from == into) return false;
  auto& a = tobs[from];
  auto& b = tobs[into];
  // Both lists are in frame order: one merge pass finds a shared frame.
  std::vector<std::pair<int, int>> merged;
  merged.reserve(a.size() + b.size());
  std::size_t i = 0, j = 0;
  while (i < a.size() || j < b.size()) {
    if (i < a.size() && j < b.size() && a[i].first == b[j].first) return false;
    if (j == b.size() || (i < a.size() && a[i].first < b[j].first))
      merged.push_back(a[i++]);
    else
      merged.push_back(b[j++]);
  }
  for (const auto& [f, k] : a) tid[f][k] = into;
  b = std::move(merged);
  a.clear();
  return true;
}

std::vector<MapCandidate> match_local_map(int t, const std::vector<int>& window, const TrackTable& tracks,
                                          const std::vector<char>& has_point, const std::vector<cv::Mat>& descriptors,
                                          int norm, double ratio) {
  std::vector<MapCandidate> out;
  // Map tracks: (track, (frame, keypoint) of its latest observation in the window).
  std::vector<int> map_track;
  std::vector<std::pair<int, int>> map_obs;
  std::vector<char> taken(tracks.tobs.size(), 0);
  for (int i = 0; i < static_cast<int>(tracks.tid[t].size()); ++i) taken[tracks.tid[t][i]] = 1;  // already in t
  for (auto it = window.rbegin(); it != window.rend(); ++it) {  // latest first: its observation is kept
    const int f = *it;
    if (descriptors[f].empty()) continue;
    for (int k = 0; k < static_cast<int>(tracks.tid[f].size()); ++k) {
      const int tr = tracks.tid[f][k];
      if (!has_point[tr] || taken[tr]) continue;
      taken[tr] = 1;
      map_track.push_back(tr);
      map_obs.push_back({f, k});
    }
  }
  std::vector<int> query;
  for (int i = 0; i < static_cast<int>(tracks.tid[t].size()); ++i)
    if (!has_point[tracks.tid[t][i]]) query.push_back(i);
  if (map_track.size() < 2 || query.empty() || descriptors[t].empty()) return out;
  cv::Mat qd(static_cast<int>(query.size()), descriptors[t].cols, descriptors[t].type());
  for (std::size_t q = 0; q < query.size(); ++q) descriptors[t].row(query[q]).copyTo(qd.row(static_cast<int>(q)));
  cv::Mat md(static_cast<int>(map_track.size()), descriptors[t].cols, descriptors[t].type());
  for (std::size_t m = 0; m < map_track.size(); ++m)
    descriptors[map_obs[m].first].row(map_obs[m].second).copyTo(md.row(static_cast<int>(m)));
  cv::BFMatcher bf(norm, false);
  std::vector<std::vector<cv::DMatch>> knn;
  bf.knnMatch(qd, md, knn, 2);
  // Each map track to its nearest passing keypoint.
  std::vector<int> best_q(map_track.size(), -1);
  std::vector<float> best_d(map_track.size(), std::numeric_limits<float>::max());
  for (std::size_t q = 0; q < knn.size(); ++q) {
    const auto& m = knn[q];
    if (m.size() < 2 || !(m[0].distance < ratio * m[1].distance)) continue;
    const int j = m[0].trainIdx;
    if (m[0].distance < best_d[j]) {
      best_d[j] = m[0].distance;
      best_q[j] = static_cast<int>(q);
    }
  }
  for (std::size_t j = 0; j < map_track.size(); ++j)
    if (best_q[j] >= 0) out.push_back({query[best_q[j]], map_track[j]});
  std::sort(out.begin(), out.end(), [](const MapCandidate& a, const MapCandidate& b) { return a.keypoint < b.keypoint; });
  return out;
}

}  // namespace smseg::sfm::sfm_map
