#pragma once
// The tracks-and-poses file (docs/design.md 3.2), format "smseg-tracks" version 1, e.g. work/tracks.json:
//
// {
//   "format": "smseg-tracks", "version": 1,
//   "sequence": "<name>", "image_size": [W, H], "first_frame": f0, "frame_count": n,
//   "pose_convention": "...", "options": {...front-end options...},
//   "poses": [{"R": [9 numbers, row-major camera-to-world], "t": [camera centre]}, ...]      (n)
//   "pair_motions": [{"R": [9], "t": [3], "points": p, "inliers": k, "ok": b, "bridged": b,
//                     "rms": m}, ...]                     (n-1; X_{t+1} = R X_t + t, camera frames)
//   "tracks": [{"frames": [...], "x": [...], "y": [...], "d": [...],
//               "P": [X0, Y0, Z0, X1, ...] (camera frame, metres), "labels": [...] (-1 = none),
//               "label": c}, ...]
//   "summary": {...filter counts, valid points per frame, track lengths, inliers, seconds...,
//               "<front end>": {...that front end's own figures, as it writes them...}}
// }
//
// Parallel arrays per track keep it compact (about 60 bytes per observation): pixels and disparities
// are rounded to 1/1000 pixel, points to 1/100 mm. The reader validates format, version and every
// field (types, lengths, ascending frames inside the frame range) and names the file and field.

#include <string>
#include <vector>

#include "smseg/frontend/motion.hpp"

namespace smseg::frontend {

inline constexpr const char* kTracksFormat = "smseg-tracks";
inline constexpr int kTracksVersion = 1;

struct TracksFile {
  std::string sequence_name;
  cv::Size image_size;
  Json options = Json::object();  ///< the front-end options as written (free-form provenance)
  FrontEndResult result;
};

Json front_end_options_to_json(const FrontEndOptions& options);
/// `expected` whole numbers, an Error naming the place otherwise (the readers of summary parts share it).
std::vector<long> integers(const JsonView& v, std::size_t expected);

/// The summary as tracks.json records it: the shared figures, and the front end's own part (if any)
/// as that part writes itself.
Json summary_to_json(const FrontEndSummary& summary);
/// The summary back: the shared figures, and the own part of the front end whose reader in `parts`
/// finds its key (stacks::summary_part_readers() has every front end's).
FrontEndSummary summary_from_json(const JsonView& j, const SummaryPartReaders& parts);

/// Writes the file atomically.
void write_tracks(const fs::path& path, const FrontEndResult& result, const std::string& sequence_name,
                  cv::Size image_size, const Json& options = Json::object());
/// Reads and checks the file; the summary's own parts through `parts` (stacks::read_tracks passes every
/// front end's readers).
TracksFile read_tracks(const fs::path& path, const SummaryPartReaders& parts);
/// Error naming `path` unless its tracks were made from `seq`: the same sequence name and image size,
/// and no posed frame past the sequence's end (a work folder given with another sequence).
void check_made_from(const TracksFile& tracks, const fs::path& path, const sequence::Sequence& seq);

}  // namespace smseg::frontend
