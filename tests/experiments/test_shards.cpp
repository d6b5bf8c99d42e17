// run-experiment --slurm without a cluster: how points are dealt to tasks (a forest's points stay
// together), --points values, and collecting the tasks' records in point order.
#include <gtest/gtest.h>

#include <unistd.h>

#include "error_text.hpp"
#include "jsonl.hpp"
#include "smseg/common/error.hpp"
#include "smseg/eval/sweep.hpp"
#include "smseg/experiments/shards.hpp"
#include "smseg/common/io.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
namespace ex = smseg::experiments;

using smseg::test::error_of;

namespace {

/// K = 20, 30, 40 (three forests) times grid = 0, 10: points 0-1 share a forest, 2-3, 4-5.
ex::Experiment six_points() {
  const json j = json::parse(R"({
    "format": "smseg-experiment", "version": 1, "name": "six",
    "sequences": {"c": {"synthetic": {"scene": "corridor", "seed": 2, "frames": 40, "width": 160, "height": 120}}},
    "fixed": {"train": "c", "train_frames": "0:21", "test_frames": "30:", "M": 2},
    "sweep": {"K": [20, 30, 40], "grid": [0, 10]}
  })");
  return ex::experiment_from_json(j, fs::temp_directory_path() / "six.json", false);
}

}  // namespace

TEST(Shards, PointsSharingAForestStayInOneTaskAndForestsAreDealtInTurn) {
  const auto e = six_points();
  ASSERT_EQ(e.points.size(), 6u);
  ASSERT_EQ(e.points[0].training_key(), e.points[1].training_key());
  EXPECT_EQ(ex::shard_points(e, {0, 1, 2, 3, 4, 5}, 2), (std::vector<std::vector<int>>{{0, 1, 4, 5}, {2, 3}}));
  EXPECT_EQ(ex::shard_points(e, {0, 1, 2, 3, 4, 5}, 3), (std::vector<std::vector<int>>{{0, 1}, {2, 3}, {4, 5}}));
  EXPECT_EQ(ex::shard_points(e, {0, 1, 2, 3, 4, 5}, 1), (std::vector<std::vector<int>>{{0, 1, 2, 3, 4, 5}}));
  // Only the points left: 1 and 4 alone are two forests.
  EXPECT_EQ(ex::shard_points(e, {1, 4}, 2), (std::vector<std::vector<int>>{{1}, {4}}));
  const std::string too_many = error_of([&] { ex::shard_points(e, {0, 1, 2, 3, 4, 5}, 4); });
  EXPECT_NE(too_many.find("--tasks: is 4, expected 1..3"), std::string::npos) << too_many;
  EXPECT_NE(error_of([&] { ex::shard_points(e, {0, 1}, 0); }).find("--tasks: is 0"), std::string::npos);
}

TEST(Shards, PointListsAreIndicesOfTheConfig) {
  EXPECT_EQ(ex::points_from_string("0,3,5", 6), (std::vector<int>{0, 3, 5}));
  EXPECT_EQ(ex::points_to_string({0, 3, 5}), "0,3,5");
  for (const char* bad : {"6", "-1", "a", "1,,2", "", "1.5"}) {
    const std::string e = error_of([&] { ex::points_from_string(bad, 6); });
    EXPECT_NE(e.find("--points"), std::string::npos) << bad << ": " << e;
  }
}

TEST(Shards, TaskRecordsAreAppendedInPointOrderAndMissingOnesReported) {
  const auto e = six_points();
  const fs::path d = fs::temp_directory_path() / ("smseg_shards_" + std::to_string(::getpid()));
  fs::remove_all(d);
  const auto record = [&](int i) { return json{{"format", "smseg-experiment-point"}, {"index", i}, {"point", e.points[i].json}}; };
  // Task 0 ran points 4 and 0, task 1 only point 2 (3 is missing).
  smseg::eval::append_jsonl(ex::task_results(d / "job", 0) / "experiment.jsonl", record(4));
  smseg::eval::append_jsonl(ex::task_results(d / "job", 0) / "experiment.jsonl", record(0));
  smseg::eval::append_jsonl(ex::task_results(d / "job", 1) / "experiment.jsonl", record(2));
  fs::create_directories(d / "out");
  const auto missing = ex::collect_task_records(e, {0, 2, 3, 4}, d / "job", d / "out");
  EXPECT_EQ(missing, std::vector<int>{3});
  const auto recs = smseg::test::read_jsonl(d / "out/experiment.jsonl");
  ASSERT_EQ(recs.size(), 3u);
  EXPECT_EQ(recs[0]["index"], 0);
  EXPECT_EQ(recs[1]["index"], 2);
  EXPECT_EQ(recs[2]["index"], 4);
  fs::remove_all(d);
}
