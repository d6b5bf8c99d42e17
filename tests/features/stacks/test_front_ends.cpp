// The front-end registry (front_ends.hpp): options choose front ends by name, "auto" by the sequence's
// kind, and each says what extraction needs to know of it.
#include <gtest/gtest.h>

#include <string>

#include "smseg/common/error.hpp"
#include "smseg/stacks/extract.hpp"
#include "smseg/sfm/sfm.hpp"
#include "smseg/stacks/front_ends.hpp"

using namespace smseg::sequence;
using namespace smseg::frontend;
using namespace smseg::stacks;

namespace {

Sequence sequence_of_kind(SequenceKind kind) {
  Sequence seq;
  seq.manifest = "seq/sequence.json";
  seq.kind = kind;
  return seq;
}

}  // namespace

TEST(FrontEnds, ChosenByNameAndAutoByTheSequencesKind) {
  ASSERT_EQ(front_ends().size(), 3u);
  EXPECT_EQ(front_end_choices(), "auto | stereo | sfm | vo");
  EXPECT_EQ(front_end_named("stereo", "motion").name(), "stereo");
  EXPECT_EQ(front_end_named("sfm", "motion").name(), "sfm");
  ExtractOptions o;  // motion "auto"
  EXPECT_EQ(front_end_for(sequence_of_kind(SequenceKind::Stereo), o).name(), "stereo");
  EXPECT_EQ(front_end_for(sequence_of_kind(SequenceKind::Mono), o).name(), "sfm");
  o.motion = "sfm";  // asked for: SfM on the left images of a stereo sequence
  EXPECT_EQ(front_end_for(sequence_of_kind(SequenceKind::Stereo), o).name(), "sfm");
  o.motion = "vo";  // the causal visual odometry is only ever asked for
  EXPECT_EQ(front_end_for(sequence_of_kind(SequenceKind::Mono), o).name(), "vo");
}

TEST(FrontEnds, AnUnknownNameIsRefusedWithTheChoices) {
  EXPECT_NO_THROW(check_motion_name("auto", "--motion"));
  EXPECT_NO_THROW(check_motion_name("sfm", "--motion"));
  try {
    check_motion_name("lidar", "--motion");
    FAIL() << "accepted";
  } catch (const smseg::Error& e) {
    EXPECT_EQ(std::string(e.what()), "--motion: expected auto | stereo | sfm | vo, got 'lidar'");
  }
  ExtractOptions o;
  o.motion = "auto ";  // not trimmed: a name is exact
  EXPECT_THROW(front_end_for(sequence_of_kind(SequenceKind::Stereo), o), smseg::Error);
}

TEST(FrontEnds, EachSaysWhatExtractionNeedsOfIt) {
  const FrontEnd& stereo = front_end_named("stereo", "motion");
  const FrontEnd& sfm = front_end_named("sfm", "motion");
  EXPECT_FALSE(stereo.monocular());
  EXPECT_TRUE(sfm.monocular());
  EXPECT_EQ(stereo.auto_height_reference(), HeightReference::Plane);
  EXPECT_EQ(sfm.auto_height_reference(), HeightReference::Camera);
  ExtractOptions o;
  o.front_end.filters.min_frames = 4;
  o.sfm.filters.min_frames = 6;
  EXPECT_EQ(stereo.min_track_frames(o), 4);
  EXPECT_EQ(sfm.min_track_frames(o), 6);
  // The SfM records its own options, with the camera height the extraction options give it.
  o.front_end.camera_height = 1.25;
  const auto j = sfm.options_json(o);
  EXPECT_EQ(j.at("method"), "sfm");
  EXPECT_EQ(j.at("camera_height"), 1.25);
  EXPECT_TRUE(j.contains("sfm"));
  EXPECT_FALSE(stereo.options_json(o).contains("sfm"));
  // The visual odometry: monocular, heights from the ground under each camera, the SfM's options and
  // track filter, KLT on Shi-Tomasi corners unless keypoints are chosen.
  const FrontEnd& vo = front_end_named("vo", "motion");
  EXPECT_TRUE(vo.monocular());
  EXPECT_EQ(vo.auto_height_reference(), HeightReference::Camera);
  EXPECT_EQ(vo.min_track_frames(o), 6);
  EXPECT_EQ(vo.options_json(o).at("method"), "vo");
  EXPECT_EQ(vo.options_json(o).at("camera_height"), 1.25);
  EXPECT_EQ(visual_odometry_options(o).tracking.detector, KeypointMethod::Gftt);
  EXPECT_EQ(visual_odometry_options(o).tracker, smseg::sfm::SfmTracker::Klt);
  // Without a focal length (a mono manifest without fx, no --focal) it is refused before anything runs.
  ExtractOptions level;
  EXPECT_THROW(vo.check(sequence_of_kind(SequenceKind::Mono), level), smseg::Error);
  level.sfm.focal = 500;
  EXPECT_NO_THROW(vo.check(sequence_of_kind(SequenceKind::Mono), level));
  // Stereo motion on a mono sequence, and gravity estimation under SfM, are refused naming the manifest.
  const Sequence mono = sequence_of_kind(SequenceKind::Mono);
  EXPECT_THROW(stereo.check(mono, o), smseg::Error);
  o.front_end.gravity.method = GravityMethod::Estimate;
  try {
    sfm.check(mono, o);
    FAIL() << "accepted";
  } catch (const smseg::Error& e) {
    EXPECT_NE(std::string(e.what()).find("seq/sequence.json"), std::string::npos) << e.what();
  }
}

TEST(FrontEnds, EachReadsBackItsOwnSummaryPartAndNamesItsOwnOptions) {
  // Only the SfM has figures of its own; its reader is registered under its name.
  const SummaryPartReaders& readers = summary_part_readers();
  ASSERT_EQ(readers.size(), 1u);
  ASSERT_EQ(readers.count("sfm"), 1u);
  smseg::sfm::SfmSummary made;
  made.tracker = "klt";
  made.focal = 250;
  made.focal_source = "option";
  made.init_frame_a = 3, made.init_frame_b = 9;
  const smseg::Json written = made.to_json();
  const auto back = readers.at("sfm")(smseg::JsonView(written, "tracks.json", "summary.sfm"));
  ASSERT_NE(back, nullptr);
  EXPECT_EQ(back->key(), "sfm");
  EXPECT_EQ(back->to_json(), written);
  FrontEndSummary summary;
  summary.own = back;
  ASSERT_NE(smseg::sfm::sfm_summary_of(summary), nullptr);
  EXPECT_EQ(smseg::sfm::sfm_summary_of(summary)->init_frame_b, 9);
  EXPECT_EQ(summary_to_json(summary).at("sfm"), written);
  // A run's key names the shared options, the front end, and each front end's own (null unless chosen).
  ExtractOptions o;
  const smseg::Json stereo = run_options_key("stereo", o), sfm = run_options_key("sfm", o);
  EXPECT_TRUE(stereo.at("sfm").is_null());
  EXPECT_EQ(sfm.at("sfm"), smseg::sfm::sfm_options_to_json(o.sfm));
  EXPECT_EQ(stereo.at("front_end"), sfm.at("front_end"));
  EXPECT_EQ(stereo.size(), 3u);
}

TEST(FrontEnds, TheStereoTrackerAloneLeavesTheSfmsTracker) {
  // run-experiment's "tracker" is the stereo front end's: resolve() makes it and its keypoints.
  ExtractOptions o;
  o.stereo_tracker = "descriptors";
  o.resolve();
  EXPECT_EQ(o.front_end.tracker, FrameTracker::Descriptors);
  EXPECT_EQ(o.front_end.tracking.detector, KeypointMethod::Sift);
  EXPECT_EQ(o.sfm.tracker, smseg::sfm::SfmTracker::Auto);
  ExtractOptions klt;
  klt.stereo_tracker = "klt";
  klt.resolve();
  EXPECT_EQ(klt.front_end.tracker, FrameTracker::Klt);
  EXPECT_EQ(klt.front_end.tracking.detector, KeypointMethod::Gftt);
}
