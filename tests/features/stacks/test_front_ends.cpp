// The front-end registry (front_ends.hpp): options choose front ends by name, "auto" by the sequence's
// kind, and each says what extraction needs to know of it.
#include <gtest/gtest.h>

#include <string>

#include "smseg/common/error.hpp"
#include "smseg/stacks/extract.hpp"
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
  ASSERT_EQ(front_ends().size(), 2u);
  EXPECT_EQ(front_end_choices(), "auto | stereo | sfm");
  EXPECT_EQ(front_end_named("stereo", "motion").name(), "stereo");
  EXPECT_EQ(front_end_named("sfm", "motion").name(), "sfm");
  ExtractOptions o;  // motion "auto"
  EXPECT_EQ(front_end_for(sequence_of_kind(SequenceKind::Stereo), o).name(), "stereo");
  EXPECT_EQ(front_end_for(sequence_of_kind(SequenceKind::Mono), o).name(), "sfm");
  o.motion = "sfm";  // asked for: SfM on the left images of a stereo sequence
  EXPECT_EQ(front_end_for(sequence_of_kind(SequenceKind::Stereo), o).name(), "sfm");
}

TEST(FrontEnds, AnUnknownNameIsRefusedWithTheChoices) {
  EXPECT_NO_THROW(check_motion_name("auto", "--motion"));
  EXPECT_NO_THROW(check_motion_name("sfm", "--motion"));
  try {
    check_motion_name("lidar", "--motion");
    FAIL() << "accepted";
  } catch (const smseg::Error& e) {
    EXPECT_EQ(std::string(e.what()), "--motion: expected auto | stereo | sfm, got 'lidar'");
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
