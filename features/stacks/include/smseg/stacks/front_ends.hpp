#pragma once
// The front ends of feature extraction, behind one interface and registered by name: what a front end
// takes (a sequence and the extraction options), what it gives (tracks, poses and a summary:
// FrontEndResult, its own part of the summary writing itself and read back by the front end), and
// what the rest of extraction needs to know of it (the options it records in
// stacks.json, its track-length filter, how heights and dense depth are measured on its output).
// extract-features --motion, the Python extract_features(motion=...), run-experiment's "motion" and
// extract_features() all choose one by name through this registry; "auto" picks by the sequence's
// kind. A new front end is one more implementation in front_ends.cpp.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "smseg/common/io.hpp"
#include "smseg/frontend/motion.hpp"
#include "smseg/frontend/tracks_io.hpp"
#include "smseg/sequence/sequence.hpp"
#include "smseg/sfm/sfm.hpp"
#include "smseg/stacks/point_features.hpp"

namespace smseg::stacks {

struct ExtractOptions;

class FrontEnd {
 public:
  virtual ~FrontEnd() = default;
  /// The name options choose it by ("stereo", "sfm").
  virtual std::string_view name() const = 0;
  /// Whether "auto" picks it for this sequence.
  virtual bool is_default_for(const sequence::Sequence& seq) const = 0;
  /// Error naming the manifest (or the option) when it cannot run on this sequence with these options.
  virtual void check(const sequence::Sequence& seq, const ExtractOptions& o) const = 0;
  virtual frontend::FrontEndResult run(const sequence::Sequence& seq, const ExtractOptions& o) const = 0;
  /// Its options as stacks.json and tracks.json record them ("front_end"), without the camera height
  /// that the sequence gives (extraction adds it).
  virtual Json options_json(const ExtractOptions& o) const = 0;
  /// Its own options beyond the shared FrontEndOptions, as given (before the camera height is filled
  /// in), for keys that name a run's options (run-experiment's cache); none when it has no options
  /// of its own.
  virtual std::optional<Json> own_options_json(const ExtractOptions& o) const = 0;
  /// The track-length filter it applies (the causal rule uses a track from this many frames on).
  virtual int min_track_frames(const ExtractOptions& o) const = 0;
  /// What HeightReference::Auto means on its output.
  virtual HeightReference auto_height_reference() const = 0;
  /// Whether its camera is one (dense depth then comes from a plane sweep over posed neighbour frames,
  /// not from stereo matching).
  virtual bool monocular() const = 0;
  /// What most often leaves it without a single track, for the error that says so.
  virtual std::string_view no_tracks_hint() const = 0;
  /// Reads back the own part of the summary that its runs write (FrontEndSummary::own, under
  /// summary_part_key() in tracks.json's summary); empty when its runs have none.
  virtual frontend::SummaryPartReader summary_part_reader() const = 0;
  /// Where its part is in tracks.json's summary, and its own options in a run's key: its name, unless
  /// it shares another front end's (the visual odometry fills the SfM's figures and takes its options,
  /// under "sfm").
  virtual std::string_view summary_part_key() const { return name(); }
};

/// Every front end, in the order help texts list them.
const std::vector<const FrontEnd*>& front_ends();
/// "auto | stereo | sfm": what a motion option accepts.
std::string front_end_choices();
/// The front end of that name; Error naming `field` and the choices when there is none. "auto" is not
/// a front end (front_end_for resolves it).
const FrontEnd& front_end_named(const std::string& name, const std::string& field);
/// Error naming `field` unless `name` is "auto" or a front end's name.
void check_motion_name(const std::string& name, const std::string& field);
/// Every front end's reader of its own summary part, by its key in the summary (frontend::read_tracks
/// takes them).
const frontend::SummaryPartReaders& summary_part_readers();
/// The options of a run of the front end `motion` as keys name them: the shared front-end options
/// ("front_end"), the name ("motion") and, under each front end's name that has options of its own,
/// those (null for the front ends not chosen).
Json run_options_key(const std::string& motion, const ExtractOptions& options);
/// tracks.json read with every front end's summary part (frontend::read_tracks with
/// summary_part_readers()).
frontend::TracksFile read_tracks(const fs::path& path);
/// The front end that options.motion chooses for this sequence ("auto": the one that is default for its
/// kind).
const FrontEnd& front_end_for(const sequence::Sequence& seq, const ExtractOptions& options);

/// The options the "vo" front end (causal monocular visual odometry) runs with: what label-stream gives
/// its monocular stream, so that its features are extract-features --motion vo --causal's.
sfm::SfmOptions visual_odometry_options(const ExtractOptions& options);

}  // namespace smseg::stacks
