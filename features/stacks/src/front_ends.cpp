// The front ends behind the FrontEnd interface (front_ends.hpp): stereo (frontend's
// run_stereo_front_end), monocular structure from motion (sfm's run_mono_front_end), causal monocular
// visual odometry (sfm's run_mono_stream_front_end, what label-stream runs on a mono sequence), and the
// registry that options choose them from by name.
#include "smseg/stacks/front_ends.hpp"

#include "smseg/common/error.hpp"
#include "smseg/frontend/tracks_io.hpp"
#include "smseg/sfm/mono_stream.hpp"
#include "smseg/sfm/sfm.hpp"
#include "smseg/stacks/extract.hpp"

namespace smseg::stacks {

namespace {

class StereoFrontEnd final : public FrontEnd {
 public:
  std::string_view name() const override { return "stereo"; }
  bool is_default_for(const sequence::Sequence& seq) const override { return seq.kind == sequence::SequenceKind::Stereo; }
  void check(const sequence::Sequence& seq, const ExtractOptions&) const override {
    if (seq.kind != sequence::SequenceKind::Stereo)
      throw Error(seq.manifest.string(), "kind",
                  "stereo motion needs a stereo sequence; this one is mono (use the structure-from-motion path, "
                  "--motion sfm or auto)");
  }
  frontend::FrontEndResult run(const sequence::Sequence& seq, const ExtractOptions& o) const override {
    frontend::FrontEndOptions fe = o.front_end;
    fe.progress = o.progress;
    return frontend::run_stereo_front_end(seq, fe);
  }
  Json options_json(const ExtractOptions& o) const override { return frontend::front_end_options_to_json(o.front_end); }
  std::optional<Json> own_options_json(const ExtractOptions&) const override { return std::nullopt; }
  int min_track_frames(const ExtractOptions& o) const override { return o.front_end.filters.min_frames; }
  HeightReference auto_height_reference() const override { return HeightReference::Plane; }
  bool monocular() const override { return false; }
  std::string_view no_tracks_hint() const override { return "blank frames? too few frames?"; }
  // Its own figures (gravity) are frontend's, which reads them with the shared ones.
  frontend::SummaryPartReader summary_part_reader() const override { return {}; }
};

// What the two monocular front ends share: the SfM's options, its checks and track filter, heights from
// the ground under each camera.
class MonocularFrontEnd : public FrontEnd {
 public:
  void check(const sequence::Sequence& seq, const ExtractOptions& o) const override {
    if (o.front_end.gravity.method != frontend::GravityMethod::Level)
      throw Error(seq.manifest.string(), "gravity",
                  "gravity estimation is for the stereo front end; " + std::string(description()) +
                      " (this run) fits its own ground plane");
    run_options(o).validate();
  }
  Json options_json(const ExtractOptions& o) const override {
    const sfm::SfmOptions s = run_options(o);
    Json fe = {{"method", std::string(name())}, {std::string(name()), sfm::sfm_options_to_json(s)}};
    if (s.camera_height) fe["camera_height"] = *s.camera_height;
    return fe;
  }
  std::optional<Json> own_options_json(const ExtractOptions& o) const override {
    return sfm::sfm_options_to_json(o.sfm);
  }
  int min_track_frames(const ExtractOptions& o) const override { return run_options(o).filters.min_frames; }
  // A long monocular drive's camera path drifts up and down against its one ground plane: heights are
  // measured from the ground under each camera (docs/camvid.md, "Heights from the ground under the
  // camera").
  HeightReference auto_height_reference() const override { return HeightReference::Camera; }
  bool monocular() const override { return true; }
  std::string_view no_tracks_hint() const override { return "a camera that does not move? blank frames?"; }
  frontend::SummaryPartReader summary_part_reader() const override { return sfm::sfm_summary_part; }
  std::string_view summary_part_key() const override { return "sfm"; }  // both write an SfmSummary

  /// The SfM options as run: the camera height from the extraction options when not set.
  virtual sfm::SfmOptions run_options(const ExtractOptions& o) const {
    sfm::SfmOptions s = o.sfm;
    if (!s.camera_height) s.camera_height = o.front_end.camera_height;
    s.progress = o.progress;
    return s;
  }

 protected:
  virtual std::string_view description() const = 0;
};

class SfmFrontEnd final : public MonocularFrontEnd {
 public:
  std::string_view name() const override { return "sfm"; }
  bool is_default_for(const sequence::Sequence& seq) const override { return seq.kind == sequence::SequenceKind::Mono; }
  frontend::FrontEndResult run(const sequence::Sequence& seq, const ExtractOptions& o) const override {
    return sfm::run_mono_front_end(seq, run_options(o));
  }

 private:
  std::string_view description() const override { return "structure from motion"; }
};

// Monocular visual odometry, causal: the same stream label-stream runs on a mono sequence, so that
// extract-features --causal with it gives label-stream's features. Never "auto" (the SfM sees the whole
// run and is the better offline front end).
class VoFrontEnd final : public MonocularFrontEnd {
 public:
  std::string_view name() const override { return "vo"; }
  bool is_default_for(const sequence::Sequence&) const override { return false; }
  void check(const sequence::Sequence& seq, const ExtractOptions& o) const override {
    MonocularFrontEnd::check(seq, o);
    if (!o.sfm.focal && !seq.calibration.fx)  // said before the work folder is started
      throw Error(seq.manifest.string(), "focal",
                  "visual odometry needs the focal length (--focal or the manifest's fx; it cannot self-calibrate: "
                  "extract-features --motion sfm estimates one and prints it)");
  }
  frontend::FrontEndResult run(const sequence::Sequence& seq, const ExtractOptions& o) const override {
    return sfm::run_mono_stream_front_end(seq, run_options(o));
  }
  /// The SfM's options, with KLT tracking of Shi-Tomasi corners unless keypoints are chosen.
  sfm::SfmOptions run_options(const ExtractOptions& o) const override {
    sfm::SfmOptions s = MonocularFrontEnd::run_options(o);
    s.tracker = sfm::SfmTracker::Klt;
    if (o.keypoints == "auto") s.tracking.detector = frontend::KeypointMethod::Gftt;
    return s;
  }

 private:
  std::string_view description() const override { return "visual odometry"; }
};

const VoFrontEnd& vo_front_end() {
  static const VoFrontEnd vo;
  return vo;
}

}  // namespace

sfm::SfmOptions visual_odometry_options(const ExtractOptions& options) { return vo_front_end().run_options(options); }

const std::vector<const FrontEnd*>& front_ends() {
  static const StereoFrontEnd stereo;
  static const SfmFrontEnd sfm;
  static const std::vector<const FrontEnd*> all{&stereo, &sfm, &vo_front_end()};
  return all;
}

std::string front_end_choices() {
  std::string s = "auto";
  for (const FrontEnd* f : front_ends()) s += " | " + std::string(f->name());
  return s;
}

const FrontEnd& front_end_named(const std::string& name, const std::string& field) {
  for (const FrontEnd* f : front_ends())
    if (f->name() == name) return *f;
  throw Error("", field, "expected " + front_end_choices() + ", got '" + name + "'");
}

void check_motion_name(const std::string& name, const std::string& field) {
  if (name != "auto") front_end_named(name, field);
}

const frontend::SummaryPartReaders& summary_part_readers() {
  static const frontend::SummaryPartReaders readers = [] {
    frontend::SummaryPartReaders r;
    for (const FrontEnd* f : front_ends())
      if (auto read = f->summary_part_reader()) r.emplace(std::string(f->summary_part_key()), std::move(read));
    return r;
  }();
  return readers;
}

Json run_options_key(const std::string& motion, const ExtractOptions& options) {
  Json key = {{"front_end", frontend::front_end_options_to_json(options.front_end)}, {"motion", motion}};
  // Under each own-options key (the visual odometry shares the SfM's, "sfm"): the chosen front end's
  // options, null for the others.
  for (const FrontEnd* f : front_ends())
    if (auto own = f->own_options_json(options)) {
      const std::string k(f->summary_part_key());
      if (f->name() == motion) key[k] = *own;
      else if (!key.contains(k)) key[k] = nullptr;
    }
  return key;
}

frontend::TracksFile read_tracks(const fs::path& path) { return frontend::read_tracks(path, summary_part_readers()); }

const FrontEnd& front_end_for(const sequence::Sequence& seq, const ExtractOptions& options) {
  if (options.motion != "auto") return front_end_named(options.motion, "motion");
  for (const FrontEnd* f : front_ends())
    if (f->is_default_for(seq)) return *f;
  throw Error(seq.manifest.string(), "kind", "no front end runs on this kind of sequence");
}

}  // namespace smseg::stacks
