// A forest trained in parts (tree ranges) and merged is the forest of one training, timing aside;
// ranges and parts that do not fit together are refused by name.
#include <gtest/gtest.h>

#include <algorithm>

#include "error_text.hpp"
#include "forest_test_util.hpp"
#include "smseg/common/error.hpp"
#include "smseg/forest/parts.hpp"
#include "smseg/common/io.hpp"

using namespace forest_test;

using smseg::test::error_of;

namespace {

SyntheticOptions tiny_room() {
  SyntheticOptions o;
  o.width = 64;
  o.height = 48;
  o.frames = 4;
  o.features = 3;
  o.seed = 11;
  return o;
}

TrainParams params(int M, std::uint64_t seed = 1) {
  TrainParams p;
  p.K = 60;
  p.M = M;
  p.seed = seed;
  return p;
}

/// Trains each range into its own part file and returns the files.
std::vector<fs::path> train_parts(const SyntheticData& s, const TrainParams& p, const std::vector<TreeRange>& ranges,
                                  const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& r : ranges) {
    files.push_back(dir / ("part-" + r.to_string() + "-seed" + std::to_string(p.seed) + ".json"));
    save_forest_part(train_forest_trees(s.data, p, r), r, files.back());
  }
  return files;
}

}  // namespace

TEST(TreeRange, ParsesHalfOpenRangesAndRefusesTheRestByOption) {
  EXPECT_EQ(TreeRange::parse("2:5", "--trees", 7), (TreeRange{2, 5}));
  EXPECT_EQ(TreeRange::parse("4:", "--trees", 7), (TreeRange{4, 7}));
  EXPECT_EQ(TreeRange::parse("0:7", "--trees", 7).size(), 7);
  for (const char* bad : {"3", "5:3", "3:3", "0:8", "-1:2", "a:b", ":4", "1:2x", ""}) {
    const std::string e = error_of([&] { TreeRange::parse(bad, "--trees", 7); });
    EXPECT_NE(e.find("--trees"), std::string::npos) << bad << ": " << e;
  }
}

TEST(TreeRange, SplitsTreesIntoNearlyEqualContiguousRanges) {
  const auto r = split_trees(7, 3);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r[0], (TreeRange{0, 3}));
  EXPECT_EQ(r[1], (TreeRange{3, 5}));
  EXPECT_EQ(r[2], (TreeRange{5, 7}));
  EXPECT_EQ(split_trees(4, 4).back(), (TreeRange{3, 4}));
  EXPECT_NE(error_of([] { split_trees(7, 0, "--tasks"); }).find("--tasks"), std::string::npos);
  EXPECT_NE(error_of([] { split_trees(7, 8, "--tasks"); }).find("1..7"), std::string::npos);
}

TEST(ForestParts, MergedPartsAreTheWholeForestTimingAside) {
  const SyntheticData s = make_synthetic(tiny_room());
  const fs::path dir = temp_dir("parts_merge");
  const TrainParams p = params(5);
  const Forest whole = train_forest(s.data, p);
  auto files = train_parts(s, p, {{0, 2}, {2, 3}, {3, 5}}, dir);
  std::reverse(files.begin(), files.end());  // any order
  const Forest merged = merge_forest_parts(files);
  EXPECT_EQ(model_bytes(merged), model_bytes(whole));
  // The comparison can fail: another seed gives another forest.
  const Forest other = merge_forest_parts(train_parts(s, params(5, 2), {{0, 5}}, dir));
  EXPECT_NE(model_bytes(other), model_bytes(whole));
  // Tree timings come along; the total is the parts' sum.
  double sum = 0;
  for (const auto& f : files) sum += load_forest_part(f).forest.stats.seconds;
  EXPECT_DOUBLE_EQ(merged.stats.seconds, sum);
  // Leaf tests are drawn per tree too: parts with them merge to the whole forest with them.
  TrainParams counted = params(5);
  counted.leaf_tests = 2000;
  const Forest whole_counted = train_forest(s.data, counted);
  EXPECT_NE(model_bytes(whole_counted), model_bytes(whole));
  EXPECT_EQ(model_bytes(merge_forest_parts(train_parts(s, counted, {{0, 3}, {3, 5}}, dir))), model_bytes(whole_counted));
  fs::remove_all(dir);
}

TEST(ForestParts, APartIsNotAForest) {
  const SyntheticData s = make_synthetic(tiny_room());
  const fs::path dir = temp_dir("parts_not_forest");
  const auto files = train_parts(s, params(3), {{0, 1}}, dir);
  const std::string e = error_of([&] { load_forest(files[0]); });
  EXPECT_NE(e.find("smseg-forest-part"), std::string::npos) << e;
  fs::remove_all(dir);
}

TEST(ForestParts, OverlapsGapsMissingTreesAndOtherTrainingsAreNamed) {
  const SyntheticData s = make_synthetic(tiny_room());
  const fs::path dir = temp_dir("parts_bad");
  const TrainParams p = params(4);
  const auto a = train_parts(s, p, {{0, 2}, {1, 3}, {2, 4}, {3, 4}}, dir);  // 0:2 1:3 2:4 3:4
  const std::string overlap = error_of([&] { merge_forest_parts(std::vector<fs::path>{a[0], a[1], a[2]}); });
  EXPECT_NE(overlap.find("overlaps"), std::string::npos) << overlap;
  EXPECT_NE(overlap.find(a[1].filename().string()), std::string::npos) << overlap;
  const std::string gap = error_of([&] { merge_forest_parts(std::vector<fs::path>{a[0], a[3]}); });
  EXPECT_NE(gap.find("tree 2 is in no part"), std::string::npos) << gap;
  const std::string tail = error_of([&] { merge_forest_parts(std::vector<fs::path>{a[0]}); });
  EXPECT_NE(tail.find("trees 2..3 are in no part (M = 4"), std::string::npos) << tail;
  const auto seed2 = train_parts(s, params(4, 2), {{2, 4}}, dir);
  const std::string seed = error_of([&] { merge_forest_parts(std::vector<fs::path>{a[0], seed2[0]}); });
  EXPECT_NE(seed.find("params.seed"), std::string::npos) << seed;
  const auto m5 = train_parts(s, params(5), {{2, 5}}, dir);
  const std::string count = error_of([&] { merge_forest_parts(std::vector<fs::path>{a[0], m5[0]}); });
  EXPECT_NE(count.find("params.M"), std::string::npos) << count;
  fs::remove_all(dir);
}

TEST(ForestParts, APartWhoseRangeDoesNotMatchItsTreesIsRefused) {
  const SyntheticData s = make_synthetic(tiny_room());
  const fs::path dir = temp_dir("parts_tampered");
  const auto files = train_parts(s, params(3), {{0, 2}}, dir);
  nlohmann::json j = smseg::read_json(files[0]);
  j["trees"]["end"] = 3;
  smseg::write_json_atomic(files[0], j);
  const std::string e = error_of([&] { load_forest_part(files[0]); });
  EXPECT_NE(e.find("trees"), std::string::npos) << e;
  EXPECT_NE(e.find("0:3"), std::string::npos) << e;
  const std::string r = error_of([&] { train_forest_trees(s.data, params(3), TreeRange{2, 4}); });
  EXPECT_NE(r.find("2:4"), std::string::npos) << r;
  fs::remove_all(dir);
}
