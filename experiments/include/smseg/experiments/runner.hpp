#pragma once
// Running an experiment (`run-experiment`): every point of the config is trained and evaluated with the
// library, one JSON Lines record per point appended to OUT/experiment.jsonl.
//
// Data. Sequences are generated (synthetic) and feature stacks extracted (extract_features) by the
// runner itself, once per (sequence, front-end options), into a cache folder shared by experiments:
//   CACHE/sequences/<scene>-<hash of the make-sequence options>/      (sequence.json written last)
//   CACHE/work/<sequence>-<hash of sequence and extract options>/    (complete.json written last)
// A cache entry without its last file is finished (make_sequence rewrites, extraction resumes). An
// exclusive lock on CACHE/lock serialises preparation between concurrent runs. Prepared work folders
// ({"work": DIR}) are used as they are.
//
// Points run one after the other; each uses both cores (trees, frames and rows in parallel with oneTBB)
// and training keeps its value matrices within RunOptions::memory_mb. Consecutive points with the same
// training parameters share one forest (an M sweep of "trees" trains the largest forest once).
//
// Records and resuming. OUT/config.json records the config (after --quick); a rerun with another
// config is an Error. OUT/experiment.jsonl holds one record per finished point, each appended with one
// write and fsync'd; a rerun skips the points already there (matched by their canonical parameters)
// and cuts a half-written last line left by a kill, so no point is lost or repeated.
// A record ("smseg-experiment-point" version 1):
//   experiment, index, point (the canonical parameters), swept (their names), label,
//   global_accuracy, class_average_accuracy, mean_iou, boundary_tolerant_accuracy, accuracy_spread
//   {min, max, median, mean, std}, accuracy_variance, per_frame_accuracy [...], per_class [...],
//   classes, confusion (counts, rows = truth), test_frames (count), seconds_per_frame (classification),
//   superpixel_seconds_per_frame, eval_seconds (wall, whole evaluation),
//   train_seconds (wall, whole forest), train_frames (count), trees (used), nodes_per_tree (mean over
//   the trees used), leaves_per_tree, depth_per_tree, tree_nodes [...], nodes_per_feature {name: n},
//   windows (chosen-window histograms, thesis Fig 4.19), pilot_seconds (learned windows only).

#include <functional>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "smseg/experiments/config.hpp"
#include "smseg/sequence/sequence.hpp"

namespace smseg::experiments {

inline constexpr const char* kRecordFormat = "smseg-experiment-point";
inline constexpr const char* kRunFormat = "smseg-experiment-run";

struct RunOptions {
  fs::path out;                  ///< results folder: config.json, experiment.jsonl
  fs::path cache;                ///< generated sequences and work folders (empty: OUT/../cache)
  int max_points = 0;            ///< stop after this many new points (0: all); the rest is left for a rerun
  /// Only these points (indices into Experiment::points; run-experiment --points, one Slurm task's
  /// share); nullopt: every point.
  std::optional<std::vector<int>> points;
  std::size_t memory_mb = 2048;  ///< training memory budget (TrainParams::memory_mb)
  bool progress = true;          ///< progress with ETA on stderr
  /// Only look: check the results folder against the config and count the points left, writing
  /// nothing, creating nothing (a Slurm dry run). Runs no point.
  bool look_only = false;
  /// Called after each new record is written.
  std::function<void(const Point&, const nlohmann::json&)> on_point;
};

struct RunReport {
  int total = 0, done_before = 0, run = 0;
  double seconds = 0;
  std::vector<int> left;  ///< the points still to run when this run started (in order), whatever the filters
};

fs::path default_cache(const fs::path& out);

/// The sequence folder of a source (generated into the cache for synthetic ones).
fs::path prepare_sequence(const std::string& name, const SequenceSource& source, const fs::path& cache, bool progress);
/// The work folder of a sequence for one front end (extracted into the cache unless prepared).
fs::path prepare_work(const std::string& name, const SequenceSource& source, const FrontEnd& fe, const fs::path& cache,
                      bool progress);

/// The points already recorded in a results folder's experiment.jsonl (each point's canonical JSON
/// text; none when the file is absent), as a resumed run reads them. Error naming the file and line for
/// a line that is not a run-experiment record, and for a point recorded twice: a run appends each point
/// once, so a copy means the file was edited or merged by hand, and its records cannot be trusted.
std::set<std::string> read_done_points(const fs::path& jsonl);

/// Runs every point not yet in OUT/experiment.jsonl.
RunReport run_experiment(const Experiment& ex, const RunOptions& options);

}  // namespace smseg::experiments
