#pragma once
// The parts of `segment-cloud`, one per method, behind the one command line of segment_cloud.cpp: what
// each run needs (filled from the options) and the function that runs it, writes its outputs and returns
// the exit status.
#include <cmath>
#include <cstdio>
#include <string>

#include "smseg/cloud/cloud_options.hpp"
#include "smseg/cloud/cloud_segment.hpp"
#include "smseg/cloud/cloud_view.hpp"
#include "smseg/cloud/grabcut_sfm.hpp"
#include "smseg/common/cli.hpp"
#include "smseg/common/io.hpp"
#include "smseg/common/output.hpp"

namespace segment_cloud {

/// Called before a run writes the first file of its set (the cloud or mask, pictures beside it, and the
/// summary OUT.json last): removes the old summary, so that a summary is only ever beside the files of
/// its own run. A run killed while writing leaves complete files (each is written atomically) but no
/// summary; the next run writes the whole set again. Also removes the temporaries killed runs left.
inline void begin_output_set(const std::string& out) {
  const smseg::fs::path summary = out + ".json";
  smseg::remove_stale_temporaries(summary.has_parent_path() ? summary.parent_path() : smseg::fs::path("."));
  std::error_code ec;
  smseg::fs::remove(summary, ec);
  if (ec) throw smseg::Error(summary.string(), "", "cannot remove the last run's summary: " + ec.message());
}

/// A number for the one-line summary ("n/a" for NaN).
inline std::string fmt(double v, const char* f = "%.4f") {
  if (std::isnan(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

/// NaN (an undefined F1) as JSON null.
inline smseg::Json nan_null(double v) { return std::isnan(v) ? smseg::Json(nullptr) : smseg::Json(v); }

/// --method mrf --seeds plane|FILE on a cloud file (mrf_on_cloud.cpp).
struct MrfCloudRun {
  std::string input, out, seeds;  ///< seeds: plane or a seed file
  smseg::cloud::MrfParams mrf;
  smseg::cloud::PlaneSeedParams plane;
};
int run_mrf_on_cloud(const MrfCloudRun& run);

/// --method centroid-mincut on a cloud file (centroid_mincut.cpp).
struct CentroidRun {
  std::string input, out;
  std::string solver = "maxflow", up = "y";  ///< solver: maxflow or pcl; up: x, y or z
  int truth_object = 1;
  smseg::cloud::CentroidMinCutParams mc;
};
int run_centroid_mincut(const CentroidRun& run);
/// Its options: the method's parameters, the solver, the up axis, the truth (centroid_mincut.cpp).
const smseg::options::Table<CentroidRun>& centroid_run_table();

/// What --seeds saliency needs besides the MRF parameters.
struct SaliencyRun {
  std::string input;  ///< cloud file; empty: WORK/cloud.pcd
  std::string out, sequence, work;
  int frame = -1;
  int min_seed_points = 3;
  double split_distance = 0.05;  ///< split seed regions by 3D distance and colour (0: no split)
  double split_colour = 80;
  smseg::cloud::SaliencyParams saliency;
  smseg::cloud::ProjectionParams projection;
};
int run_saliency_mrf(const SaliencyRun& run, const smseg::cloud::MrfParams& mrf);  ///< saliency_mrf.cpp
/// Its options: the saliency map and regions, the seeds' split, the z-buffer (saliency_mrf.cpp).
const smseg::options::Table<SaliencyRun>& saliency_run_table();

struct GrabCutSfmCli {
  std::string sequence, work, cloud, out;  // cloud: empty = WORK/cloud.pcd
  int frame = -1;
  std::string truth_label, truth_region = "largest", truth_mask, truth_instance;
  int truth_value = 0;  // --truth-mask: 0 = any non-zero pixel is the object, else pixels == value
  int dense_cloud = 0;  // > 0: the cloud of the frame's dense depth, every this-many pixels (stereo)
  int window = -1;      // >= 0: the cloud of the tracks seen within this many frames (tracks.json)
  int plane_window = -1;  // >= 0: the first plane is fitted to the tracks seen within this many frames
  std::string support = "table";  // --support table|plane
  std::string cluster = "auto", nearest = "auto", up = "auto";  // up: --plane-up camera|world|estimate|auto
  bool box_to_plane_given = false;  // --box-to-plane on the command line (support plane: off unless given)
  bool mask_depth_share_given = false;  // --mask-depth-share on the command line (clouds of tracks: 0 unless given)
  smseg::cloud::GrabCutSfmParams params;
};
int run_grabcut_sfm(const GrabCutSfmCli& o);  ///< grabcut_sfm.cpp
/// Its options: the truth, the cloud, the words that choose the support, clusters, nearest and up, and
/// the method's parameters; find_table()'s rules are in the summary but take their flags from
/// cloud::table_params_table() (grabcut_sfm.cpp).
const smseg::options::Table<GrabCutSfmCli>& grabcut_sfm_cli_table();

/// Everything segment-cloud's command line fills (options.cpp).
struct SegmentCloudOptions {
  std::string input, out, method = "centroid-mincut", seeds = "plane";
  CentroidRun centroid;
  smseg::cloud::TabletopCloudOptions tab;
  smseg::cloud::MrfParams mrf;
  smseg::cloud::PlaneSeedParams plane;
  int make_tabletop = 0, threads = 0;
  SaliencyRun sal;
  GrabCutSfmCli gc;
};
/// The command line: the run's inputs and outputs (the cloud, -o, --method, --make-tabletop, --sequence,
/// ...), then every method's options from their tables.
void add_options(CLI::App& app, SegmentCloudOptions& o);
/// Runs the method the options ask for (or writes a synthetic tabletop cloud); the exit status.
int run_method(const CLI::App& app, SegmentCloudOptions& o);

}  // namespace segment_cloud
