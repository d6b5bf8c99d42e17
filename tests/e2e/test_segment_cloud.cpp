// segment-cloud as a user runs it: a synthetic tabletop, centroid min-cut and the MRF with their F1 in
// the summary JSON, and one-line errors for bad input.
#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <cstdio>

#include "smseg/io.hpp"

namespace fs = std::filesystem;

namespace {

struct Outcome {
  int status = -1;
  std::string out;
};

Outcome run_tool(const std::string& args) {
  Outcome r;
  FILE* p = ::popen((args + " 2>&1").c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  while (std::fgets(buf.data(), buf.size(), p)) r.out += buf.data();
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

const std::string kTool = (fs::path(SMSEG_BIN_DIR) / "segment-cloud").string();

}  // namespace

TEST(SegmentCloudTool, TabletopCentroidMinCutAndMrf) {
  const fs::path dir = fs::temp_directory_path() / ("smseg_segcloud_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string cloud = (dir / "tab.pcd").string();
  Outcome r = run_tool(kTool + " --make-tabletop 8000 --objects 2 -o " + cloud);
  ASSERT_EQ(r.status, 0) << r.out;

  // Centroid min-cut wants one object at the centre of the cloud.
  const std::string one = (dir / "one.ply").string();
  r = run_tool(kTool + " --make-tabletop 8000 --objects 1 -o " + one);
  ASSERT_EQ(r.status, 0) << r.out;
  r = run_tool(kTool + " " + one + " --method centroid-mincut --radius 0.35 -o " + (dir / "mc.pcd").string());
  ASSERT_EQ(r.status, 0) << r.out;
  const smseg::Json mc = smseg::read_json(dir / "mc.pcd.json");
  EXPECT_GE(mc["f1_object"].get<double>(), 0.9) << r.out;
  EXPECT_GT(mc["params"]["sigma_used"].get<double>(), 0);

  r = run_tool(kTool + " " + cloud + " --method mrf -o " + (dir / "mrf.ply").string());
  ASSERT_EQ(r.status, 0) << r.out;
  const smseg::Json mrf = smseg::read_json(dir / "mrf.ply.json");
  ASSERT_EQ(mrf["f1"].size(), 3u);  // table and two objects
  for (const auto& f : mrf["f1"]) EXPECT_GE(f["f1"].get<double>(), 0.9) << r.out;
  EXPECT_EQ(mrf["labels"].get<int>(), 3);
  EXPECT_TRUE(fs::exists(dir / "mrf.ply"));

  // Bad input: one line naming the file, exit 1.
  r = run_tool(kTool + " " + (dir / "missing.pcd").string() + " --radius 0.3 -o " + (dir / "x.pcd").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("missing.pcd"), std::string::npos) << r.out;
  r = run_tool(kTool + " " + cloud + " --radius 0.001 -o " + (dir / "x.pcd").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("seed"), std::string::npos) << r.out;
  r = run_tool(kTool + " " + cloud + " --method mrf --seeds " + (dir / "noseeds.json").string() + " -o " +
               (dir / "x.pcd").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("noseeds.json"), std::string::npos) << r.out;
  r = run_tool(kTool + " " + cloud + " --method watershed -o " + (dir / "x.pcd").string());
  EXPECT_EQ(r.status, 1);
  fs::remove_all(dir);
}
