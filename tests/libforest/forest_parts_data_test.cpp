// Parts of one forest must come from one training's data: a part records what its trainer says it was
// trained on (training_data), and parts that record other data, or that record it and do not, are not
// merged. The forest alone cannot tell: parts trained on other frames share image, classes, features
// and parameters.
#include <gtest/gtest.h>

#include "error_text.hpp"
#include "forest_test_util.hpp"
#include "smseg/forest/parts.hpp"

using namespace forest_test;

using smseg::test::error_of;

namespace {

/// A small synthetic room: 4 frames of 64x48 with 3 features, of the given seed (other frames).
SyntheticOptions room(std::uint64_t seed) { return SyntheticOptions{64, 48, 4, 3, 4, seed}; }

TrainParams two_trees() {
  TrainParams p;
  p.K = 60;
  p.M = 2;
  return p;
}

/// What a trainer records of its data: each work folder's identity and the frames taken from it.
nlohmann::json data_of(const std::string& stacks_digest, std::vector<int> frames) {
  return {{"works", {{{"stacks_json_fnv1a64", stacks_digest}, {"frames", frames}}}}};
}

}  // namespace

TEST(ForestPartsData, PartsOfOtherTrainingDataAreNotMerged) {
  const fs::path dir = temp_dir("parts_data");
  const SyntheticData first_frames = make_synthetic(room(11)), other_frames = make_synthetic(room(12));
  const TrainParams p = two_trees();
  const fs::path a = dir / "a.json", b = dir / "b.json", c = dir / "c.json", d = dir / "d.json";
  save_forest_part(train_forest_trees(first_frames.data, p, {0, 1}), {0, 1}, a, data_of("00aa", {0, 1, 2, 3}));
  save_forest_part(train_forest_trees(first_frames.data, p, {1, 2}), {1, 2}, b, data_of("00aa", {0, 1, 2, 3}));
  save_forest_part(train_forest_trees(other_frames.data, p, {1, 2}), {1, 2}, c, data_of("00aa", {4, 5, 6, 7}));
  save_forest_part(train_forest_trees(other_frames.data, p, {1, 2}), {1, 2}, d);
  // The same data: merged, and the merged forest is the whole one.
  EXPECT_EQ(model_bytes(merge_forest_parts(std::vector<fs::path>{a, b})), model_bytes(train_forest(first_frames.data, p)));
  EXPECT_EQ(load_forest_part(a).training_data, data_of("00aa", {0, 1, 2, 3}));
  // Other frames: the field that differs is named.
  EXPECT_EQ(error_of([&] { merge_forest_parts(std::vector<fs::path>{a, c}); }),
            c.string() + ": training_data.works: differs from " + a.string() +
                "'s: the parts were trained on other data (trees of other data cannot be merged into one forest)");
  // A part that records nothing beside one that does.
  EXPECT_EQ(error_of([&] { merge_forest_parts(std::vector<fs::path>{a, d}); }),
            d.string() + ": training_data: not recorded here, but in " + a.string() +
                " (trees of other data cannot be merged into one forest)");
  // Parts that record nothing (written before the record, or by a trainer that keeps none) merge as before.
  const fs::path e = dir / "e.json";
  save_forest_part(train_forest_trees(first_frames.data, p, {0, 1}), {0, 1}, e);
  EXPECT_EQ(error_of([&] { merge_forest_parts(std::vector<fs::path>{e, d}); }), "(no error)");
  fs::remove_all(dir);
}
