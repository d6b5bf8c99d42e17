#pragma once
// What the monocular structure from motion did, as its runs report it: the SfM front end's own part of
// the front-end summary (frontend::SummaryPart), written by itself into tracks.json's summary under
// "sfm" and read back by sfm_summary_part (which stacks::read_tracks passes for every file).

#include <memory>
#include <string>
#include <string_view>

#include "smseg/frontend/motion.hpp"

namespace smseg::sfm {

struct SfmSummary final : frontend::SummaryPart {
  std::string tracker;           ///< "klt" or "descriptors" (the one used)
  double focal = 0;              ///< pixels, the value used (fx = fy)
  std::string focal_source;      ///< "option", "manifest", "estimated" or "fallback" (image width)
  int focal_pairs = 0;           ///< frame pairs that constrained the estimate
  int init_frame_a = -1, init_frame_b = -1;  ///< initial pair (sequence indices); -1: never initialised
  int keyframes = 0;
  int posed_frames = 0;          ///< posed by the initial pair or PnP
  int still_frames = 0;          ///< reused the previous pose (camera standing still)
  int bridged_frames = 0;        ///< essential-matrix fallback, or no pose at all
  long points_3d = 0;            ///< tracks with a 3D point
  long map_joins = 0;            ///< tracks joined to a map point by local-map matching
  long observations = 0;         ///< kept observations (the RMS is over these)
  double reprojection_rms_px = 0;
  double scale = 0;              ///< metres per reconstruction unit (from the camera height)
  int ground_inliers = 0, ground_candidates = 0;
  double seconds_sfm = 0;        ///< per frame: initialisation, PnP, triangulation, BA, scale
  double seconds_ba = 0;         ///< per frame: bundle adjustment alone (included in seconds_sfm)

  std::string_view key() const override { return "sfm"; }
  Json to_json() const override;
};

/// The summary's SfM part back from its JSON (summary.sfm); an Error names the bad field.
std::shared_ptr<const frontend::SummaryPart> sfm_summary_part(const JsonView& part);

/// The SfM part of a front end's summary, or null when another front end made it.
const SfmSummary* sfm_summary_of(const frontend::FrontEndSummary& summary);

}  // namespace smseg::sfm
