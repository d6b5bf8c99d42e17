// segment-cloud as a user runs it: a synthetic tabletop, centroid min-cut and the MRF with their F1 in
// the summary JSON, and one-line errors for bad input.
#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <cstdio>

#include "run_tool.hpp"
#include "smseg/io.hpp"

namespace fs = std::filesystem;

namespace {

using smseg::test::Outcome;
using smseg::test::run;
using smseg::test::tool;

const std::string kTool = tool("segment-cloud");

}  // namespace

TEST(SegmentCloudTool, TabletopCentroidMinCutAndMrf) {
  const fs::path dir = fs::temp_directory_path() / ("smseg_segcloud_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string cloud = (dir / "tab.pcd").string();
  Outcome r = run(kTool + " --make-tabletop 8000 --objects 2 -o " + cloud);
  ASSERT_EQ(r.status, 0) << r.out;

  // Centroid min-cut wants one object at the centre of the cloud.
  const std::string one = (dir / "one.ply").string();
  r = run(kTool + " --make-tabletop 8000 --objects 1 -o " + one);
  ASSERT_EQ(r.status, 0) << r.out;
  r = run(kTool + " " + one + " --method centroid-mincut --radius 0.35 -o " + (dir / "mc.pcd").string());
  ASSERT_EQ(r.status, 0) << r.out;
  const smseg::Json mc = smseg::read_json(dir / "mc.pcd.json");
  EXPECT_GE(mc["f1_object"].get<double>(), 0.9) << r.out;
  EXPECT_GT(mc["params"]["sigma_used"].get<double>(), 0);

  r = run(kTool + " " + cloud + " --method mrf -o " + (dir / "mrf.ply").string());
  ASSERT_EQ(r.status, 0) << r.out;
  const smseg::Json mrf = smseg::read_json(dir / "mrf.ply.json");
  ASSERT_EQ(mrf["f1"].size(), 3u);  // table and two objects
  for (const auto& f : mrf["f1"]) EXPECT_GE(f["f1"].get<double>(), 0.9) << r.out;
  EXPECT_EQ(mrf["labels"].get<int>(), 3);
  EXPECT_TRUE(fs::exists(dir / "mrf.ply"));

  // Bad input: one line naming the file, exit 1.
  r = run(kTool + " " + (dir / "missing.pcd").string() + " --radius 0.3 -o " + (dir / "x.pcd").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("missing.pcd"), std::string::npos) << r.out;
  r = run(kTool + " " + cloud + " --radius 0.001 -o " + (dir / "x.pcd").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("seed"), std::string::npos) << r.out;
  r = run(kTool + " " + cloud + " --method mrf --seeds " + (dir / "noseeds.json").string() + " -o " +
               (dir / "x.pcd").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("noseeds.json"), std::string::npos) << r.out;
  r = run(kTool + " " + cloud + " --method watershed -o " + (dir / "x.pcd").string());
  EXPECT_EQ(r.status, 1);
  fs::remove_all(dir);
}
