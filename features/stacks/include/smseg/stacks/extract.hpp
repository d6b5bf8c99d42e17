#pragma once
// The whole front end of a sequence into feature stacks (`extract-features`): tracks and camera
// motion from the front end that ExtractOptions::motion names (front_ends.hpp: stereo, or monocular
// structure from motion on the left images alone; "auto": stereo for stereo sequences, SfM for mono
// ones), then the structure-and-motion features of each frame as summed-area
// tables, written as a work folder (stack.hpp), plus WORK/tracks.json (tracks, camera path and the
// front-end summary, tracks_io.hpp) and WORK/path.png (top-down camera path and cloud; the ground-truth
// path too when the sequence has one, aligned at the first frame). Parallel over frames; resumable.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "smseg/stacks/track_cloud.hpp"
#include "smseg/frontend/motion.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/sfm/sfm.hpp"
#include "smseg/stacks/front_ends.hpp"
#include "smseg/stacks/stack.hpp"

namespace smseg::stacks {

struct ExtractOptions {
  /// The front end tracks and camera motion come from, by name (front_ends.hpp: "stereo", "sfm"), or
  /// "auto": the one for the sequence's kind (stereo for stereo sequences, SfM for mono ones).
  std::string motion = "auto";
  /// What the user chose for both front ends, by name ("auto": each front end's own default), made
  /// into front_end's and sfm's options by resolve().
  std::string keypoints = "auto";  ///< auto | sift | orb | akaze | gftt
  std::string tracker = "auto";    ///< auto | klt | descriptors
  /// The stereo front end's tracker alone, when not "auto" (run-experiment's "tracker", which leaves
  /// the SfM's at `tracker`).
  std::string stereo_tracker = "auto";
  std::optional<int> max_keypoints;  ///< unset: each front end's default
  bool no_refine = false;          ///< stereo motion without the reprojection refinement
  frontend::FrontEndOptions front_end;   ///< stereo, tracking, filters, motion (the stereo front end)
  sfm::SfmOptions sfm;              ///< the monocular front end (its camera_height defaults to front_end's)
  FeatureOptions features;     ///< causal fC, future frames
  FrameRange frames;           ///< frames whose stacks are written (the front end always sees all)
  bool force = false;          ///< rewrite frames already done
  std::vector<int> preview;    ///< frames to write false-colour PNGs of (WORK/preview/)
  bool progress = true;

  /// Makes the choices above into front_end's and sfm's options (the surfaces call it after reading).
  /// Error naming the choice ("keypoints") when they do not go together.
  void resolve();
  /// The front ends' and the features' validate(): Error naming the library's field.
  void validate() const;
};

/// ExtractOptions' fields, declared once (options.hpp): extract-features' options, the keywords of
/// Python's extract_features, run-experiment's extraction keys (the features' own also on stacks.json).
const options::Table<ExtractOptions>& extract_options_table();

struct ExtractReport {
  int frames_written = 0, frames_skipped = 0;
  double front_end_seconds = 0, features_seconds_per_frame = 0;
  std::size_t bytes_per_frame = 0;
  frontend::FrontEndSummary summary;
  std::vector<CloudPoint> cloud;  ///< one point per track (cloud.hpp); the tool writes it with PCL
};

/// The point observations of each frame, from the front end's tracks (track id = index in tracks).
/// causal_min_frames > 0 is the causal rule (FeatureOptions::causal): a track's observations are used
/// from its causal_min_frames-th on, the frame at which it is known to pass the track-length filter
/// (TrackFilterOptions::min_frames), as a live stream sees it (stream.hpp).
PointCloudVideo video_from_tracks(const frontend::FrontEndResult& front_end, int frame_count, int causal_min_frames = 0);

/// The feature options as recorded in stacks.json (and in run-experiment's cache keys).
Json feature_options_json(const FeatureOptions& options);

/// Runs everything for `seq` into the work folder `work`. A work folder made with other options is an
/// Error unless force is set (then it is rebuilt). A front end that cannot run on the sequence (stereo on
/// a mono one) is an Error. Frames whose stacks exist are skipped unless force.
ExtractReport extract_features(const sequence::Sequence& seq, const fs::path& work, const ExtractOptions& options);

/// What extract-features prints of a run into `work`: one summary (two lines), and one line of the
/// structure from motion when it ran. Each line ends with a newline.
std::string report_text(const ExtractReport& report, const std::string& work);

/// A false-colour picture of one frame's six rasters (2 x 3 tiles, each named), for people.
cv::Mat feature_preview(const std::vector<cv::Mat>& rasters, const std::vector<std::string>& names);

}  // namespace smseg::stacks
