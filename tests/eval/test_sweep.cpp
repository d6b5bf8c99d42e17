// Sweeps (M, B, V) without retraining: one JSON line per point, resumable after an interruption with
// nothing lost or repeated; the M sweep equals evaluating with the first m trees.
#include <gtest/gtest.h>

#include <fstream>

#include "eval_fixture.hpp"
#include "smseg/eval/sweep.hpp"
#include "smseg/common/io.hpp"

namespace fs = std::filesystem;
using namespace smseg;

TEST(Sweep, SpecsParseWithInclusiveBounds) {
  const auto s = eval::SweepSpec::parse("B=5:95:5", "--sweep");
  EXPECT_EQ(s.param, 'B');
  ASSERT_EQ(s.values().size(), 19u);
  EXPECT_EQ(s.values().back(), 95);
  EXPECT_EQ(eval::SweepSpec::parse("M=1:42", "--sweep").values().size(), 42u);
  EXPECT_EQ(eval::SweepSpec::parse("V=9", "--sweep").values(), std::vector<int>{9});
  for (const char* bad : {"K=1:5", "M=0:5", "M=5:1", "M=1:5:0", "M=a:5", "M1:5", "M=1:2:3:4", "V="}) {
    try {
      eval::SweepSpec::parse(bad, "--sweep");
      ADD_FAILURE() << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.field(), "--sweep");
    }
  }
}

TEST(Sweep, ResumesAfterAKillWithNothingLostOrRepeated) {
  const fs::path work = eval_test::make_work("sweep", 8);
  const forest::Forest f = eval_test::train(work, 6, 4);
  const fs::path out = work / "out";
  eval::EvalOptions opt;
  opt.frames = stacks::FrameRange{6, 8};
  const auto spec = eval::SweepSpec::parse("M=1:4", "--sweep");

  // A full run.
  int called = 0;
  const auto full = eval::run_sweep(f, "forest.json", {work}, opt, spec, out / "full.jsonl",
                                    [&](const Json&) { ++called; });
  EXPECT_EQ(full.run, 4);
  EXPECT_EQ(called, 4);
  const auto reference = eval::read_jsonl(out / "full.jsonl");
  ASSERT_EQ(reference.size(), 4u);
  // The point M = 2 is the evaluation with the first two trees.
  eval::EvalOptions two = opt;
  two.trees = 2;
  EXPECT_DOUBLE_EQ(reference[1]["global_accuracy"].get<double>(), eval::evaluate(f, {work}, two).confusion.global_accuracy());

  // An interrupted run: two full lines and half of the third.
  const std::string text = read_file(out / "full.jsonl");
  std::size_t cut = 0;
  for (int i = 0; i < 2; ++i) cut = text.find('\n', cut) + 1;
  const std::size_t third_end = text.find('\n', cut);
  write_file_atomic(out / "cut.jsonl", text.substr(0, cut + (third_end - cut) / 2));
  const auto resumed = eval::run_sweep(f, "forest.json", {work}, opt, spec, out / "cut.jsonl");
  EXPECT_EQ(resumed.done_before, 2);
  EXPECT_EQ(resumed.run, 2);
  const auto records = eval::read_jsonl(out / "cut.jsonl");
  ASSERT_EQ(records.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(records[i]["value"].get<int>(), static_cast<int>(i) + 1);
    EXPECT_EQ(records[i]["confusion"], reference[i]["confusion"]);
    EXPECT_EQ(records[i]["run"], reference[i]["run"]);
  }
  // A rerun of a finished sweep does nothing; a wider one adds only the new points.
  EXPECT_EQ(eval::run_sweep(f, "forest.json", {work}, opt, spec, out / "cut.jsonl").run, 0);
  EXPECT_EQ(eval::read_jsonl(out / "cut.jsonl").size(), 4u);

  // Points of another run in the same file are refused, not mixed.
  eval::EvalOptions other = opt;
  other.seed = 99;
  EXPECT_THROW(eval::run_sweep(f, "forest.json", {work}, other, spec, out / "cut.jsonl"), Error);
  // A file that is not a sweep file is refused.
  write_file_atomic(out / "junk.jsonl", "not json\n");
  EXPECT_THROW(eval::read_jsonl(out / "junk.jsonl"), Error);
  // M beyond the forest; V without regions; B with superpixels.
  EXPECT_THROW(eval::run_sweep(f, "forest.json", {work}, opt, eval::SweepSpec::parse("M=1:9", "--sweep"), out / "x.jsonl"),
               Error);
  EXPECT_THROW(eval::run_sweep(f, "forest.json", {work}, opt, eval::SweepSpec::parse("V=1:3", "--sweep"), out / "x.jsonl"),
               Error);
  fs::remove_all(work);
}

TEST(Sweep, GridAndVotesSweepsShareAFileAndResume) {
  const fs::path work = eval_test::make_work("sweep_bv", 7);
  const forest::Forest f = eval_test::train(work, 6, 3);
  const fs::path jsonl = work / "out" / "sweep.jsonl";
  eval::EvalOptions opt;
  opt.frames = stacks::FrameRange{6, 7};
  opt.grid = 8;
  opt.votes = 4;
  EXPECT_EQ(eval::run_sweep(f, "forest.json", {work}, opt, eval::SweepSpec::parse("B=4:16:4", "--sweep"), jsonl).run, 4);
  EXPECT_EQ(eval::run_sweep(f, "forest.json", {work}, opt, eval::SweepSpec::parse("V=1:3", "--sweep"), jsonl).run, 3);
  // Half a line appended by a killed writer is dropped; the finished points stay.
  { std::ofstream(jsonl, std::ios::app) << R"({"format": "smseg-sweep-point", "sweep": "V", "val)"; }
  const auto again = eval::run_sweep(f, "forest.json", {work}, opt, eval::SweepSpec::parse("V=1:4", "--sweep"), jsonl);
  EXPECT_EQ(again.done_before, 3);
  EXPECT_EQ(again.run, 1);
  const auto records = eval::read_jsonl(jsonl);
  ASSERT_EQ(records.size(), 8u);
  EXPECT_EQ(records.back()["sweep"], "V");
  EXPECT_EQ(records.back()["value"], 4);
  fs::remove_all(work);
}
