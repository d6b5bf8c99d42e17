// A cloud seen from one frame (paper 000's saliency seeding): projection with a z-buffer, salient regions,
// saliency seeds, instance scores.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "smseg/cloud/cloud_view.hpp"

namespace {

using namespace smseg::cloud;

ViewCamera camera() {
  ViewCamera c;
  c.fx = c.fy = 100;
  c.cx = 79.5;
  c.cy = 59.5;
  c.size = cv::Size(160, 120);
  // Camera-to-world: camera x right = world x, camera y down = world -Y, camera z forward = world -Z.
  c.pose.R = {1, 0, 0, 0, -1, 0, 0, 0, -1};
  c.pose.t = {0, 1, 0};
  return c;
}

TEST(CloudView, ProjectionFollowsThePoseAndHidesPointsBehindOthers) {
  ColouredCloud cloud;
  cloud.points = {{0, 1, -2},      // straight ahead, 2 m: the principal point
                  {0, 1, -4},      // behind the first one: hidden
                  {0.5f, 0.5f, -2},  // right and below: pixel (cx + 25, cy + 25)
                  {0, 1, 1},       // behind the camera
                  {3, 1, -2}};     // outside the image (x = cx + 150)
  const CloudProjection p = project_cloud(cloud, camera(), ProjectionParams{});
  EXPECT_EQ(p.visible, (std::vector<int>{0, 2}));
  EXPECT_EQ(p.pixel[0], cv::Point(80, 60));  // 79.5 rounds away from zero
  EXPECT_EQ(p.pixel[2], cv::Point(105, 85));
  EXPECT_EQ(p.pixel[1], cv::Point(80, 60));  // projected, but hidden by point 0
  EXPECT_EQ(p.pixel[3], cv::Point(-1, -1));
  EXPECT_EQ(p.pixel[4], cv::Point(-1, -1));
  EXPECT_FLOAT_EQ(p.depth[1], 4.0f);
  // A point just behind another one (within the depth tolerance) stays visible.
  cloud.points[1] = {0, 1, -2.02f};
  EXPECT_EQ(project_cloud(cloud, camera(), ProjectionParams{}).visible, (std::vector<int>{0, 1, 2}));

  // The splatted picture: the nearer point's colour at the shared pixel, black elsewhere.
  cloud.points[1] = {0, 1, -4};
  const CloudProjection q = project_cloud(cloud, camera(), ProjectionParams{});
  const std::vector<int> labels{1, 2, 0, 0, 0};
  const cv::Mat img = splat_labels(q, labels, cv::Size(160, 120), 2);
  EXPECT_EQ(img.at<cv::Vec3b>(60, 80), label_colour(1));
  EXPECT_EQ(img.at<cv::Vec3b>(85, 105), label_colour(0));
  EXPECT_EQ(img.at<cv::Vec3b>(10, 10), cv::Vec3b(0, 0, 0));
}

TEST(CloudView, SalientRegionsFindColouredObjectsOnAPlainBackground) {
  cv::Mat img(120, 160, CV_8UC3, cv::Scalar(120, 125, 130));
  cv::rectangle(img, cv::Rect(20, 40, 24, 30), cv::Scalar(30, 30, 220), cv::FILLED);   // red
  cv::rectangle(img, cv::Rect(110, 50, 20, 26), cv::Scalar(220, 80, 20), cv::FILLED);  // blue
  const SalientRegions sr = salient_regions(img, SaliencyParams{});
  ASSERT_GE(sr.count, 2);
  // Each square's centre lies in a region, and the two are different regions; the far corner is not salient.
  const int a = sr.regions.at<int>(55, 32), b = sr.regions.at<int>(63, 120);
  EXPECT_GT(a, 0);
  EXPECT_GT(b, 0);
  EXPECT_NE(a, b);
  EXPECT_EQ(sr.regions.at<int>(5, 80), 0);

  // Seeds: points in the squares seed labels 1 and 2, points on the plain background label 0.
  std::vector<cv::Point> px;
  std::vector<Eigen::Vector3f> pos;
  for (int k = 0; k < 6; ++k) {
    px.emplace_back(28 + k, 50 + k);
    px.emplace_back(115 + k, 58 + k);
    px.emplace_back(70 + 3 * k, 5 + k);
  }
  for (std::size_t i = 0; i < px.size(); ++i) pos.emplace_back(float(i), 0, 0);
  std::vector<int> region_of_label;
  const MrfSeeds s = saliency_seeds(px, pos, sr, 0.5, 3, &region_of_label);
  ASSERT_EQ(s.regions.size(), 3u);
  EXPECT_EQ(s.method, "saliency");
  EXPECT_EQ(region_of_label[0], 0);
  for (int i : s.regions[0]) EXPECT_EQ(i % 3, 2);
  EXPECT_EQ(s.regions[0].size(), 6u);
  EXPECT_EQ(s.regions[1].size() + s.regions[2].size(), 12u);

  // A plain image has no salient region: the seeds are an error saying so.
  const cv::Mat plain(120, 160, CV_8UC3, cv::Scalar(100, 100, 100));
  const SalientRegions none = salient_regions(plain, SaliencyParams{});
  EXPECT_EQ(none.count, 0);
  try {
    saliency_seeds(px, pos, none, 0.5, 3);
    ADD_FAILURE() << "no error";
  } catch (const smseg::Error& e) {
    EXPECT_NE(std::string(e.what()).find("no salient region"), std::string::npos) << e.what();
  }
  SaliencyParams bad;
  bad.method = "itti";
  EXPECT_THROW(salient_regions(img, bad), smseg::Error);
}

// A salient region over two objects that touch in the image but not in space, or differ in colour, seeds
// one label per object after the split; the background label stays whole; tiny groups are dropped.
TEST(CloudView, SeedRegionsSplitByPlaceAndColour) {
  ColouredCloud view;
  auto add = [&](float x, float z, std::array<std::uint8_t, 3> c) {
    view.points.emplace_back(x, 0.8f, z);
    view.colours.push_back(c);
  };
  for (int k = 0; k < 10; ++k) add(0.01f * k, 0, {200, 30, 30});          // red object, 0..9 cm
  for (int k = 0; k < 10; ++k) add(0.2f + 0.01f * k, 0, {200, 30, 30});   // red object 20 cm away
  for (int k = 0; k < 10; ++k) add(0.01f * k, 0.02f, {30, 30, 200});      // blue object touching the first
  add(0.5f, 0.5f, {10, 200, 10});                                          // a lone green point
  for (int k = 0; k < 5; ++k) add(2, 0.01f * k, {120, 120, 120});         // background
  MrfSeeds seeds;
  seeds.method = "saliency";
  seeds.regions.push_back({31, 32, 33, 34, 35});
  seeds.regions.emplace_back();
  for (int i = 0; i < 31; ++i) seeds.regions.back().push_back(i);
  seeds.positions.assign(2, Eigen::Vector3f::Zero());
  std::vector<int> region_of_label{0, 7};
  split_seed_regions(view, seeds, 0.05, 80, 3, &region_of_label);
  ASSERT_EQ(seeds.regions.size(), 4u);
  EXPECT_EQ(seeds.regions[0], (std::vector<int>{31, 32, 33, 34, 35}));
  EXPECT_EQ(region_of_label, (std::vector<int>{0, 7, 7, 7}));
  for (std::size_t l = 1; l < 4; ++l) {
    ASSERT_EQ(seeds.regions[l].size(), 10u);
    const int group = seeds.regions[l][0] / 10;
    for (int i : seeds.regions[l]) EXPECT_EQ(i / 10, group) << "label " << l << " mixes objects";
  }
  EXPECT_NEAR(seeds.positions[1].y(), 0.8f, 1e-6);
  // Nothing left of the objects: an error.
  MrfSeeds only_lone;
  only_lone.regions = {{31, 32}, {30}};
  only_lone.positions.assign(2, Eigen::Vector3f::Zero());
  EXPECT_THROW(split_seed_regions(view, only_lone, 0.05, 80, 3), smseg::Error);
}

TEST(CloudView, InstanceScoresMapEachLabelToTheObjectItOverlapsMost) {
  // Truth: 4 background, 3 of object 1, 3 of object 2, one unknown. Labels: 0 background, 1 and 2 both
  // on object 1 (over-segmented), object 2 mostly labelled 0, once 3.
  const std::vector<int> truth{0, 0, 0, 0, 1, 1, 1, 2, 2, 2, -1};
  const std::vector<int> pred{0, 0, 0, 0, 1, 2, 2, 0, 0, 3, 1};
  const InstanceScore s = score_instances(truth, pred, 3, 4);
  EXPECT_EQ(s.label_to_truth, (std::vector<int>{0, 1, 1, 2}));
  EXPECT_EQ(s.truth_points, (std::vector<long>{4, 3, 3}));
  // Background: mapped 0 at {0,1,2,3,7,8}, truth {0,1,2,3}: tp 4, fp 2 -> 8 / 10.
  EXPECT_NEAR(s.f1[0], 0.8, 1e-12);
  // Object 1: labels 1 and 2 both stand for it: exact.
  EXPECT_NEAR(s.f1[1], 1.0, 1e-12);
  // Object 2: mapped {9}, truth {7,8,9}: tp 1, fn 2 -> 2 / 4.
  EXPECT_NEAR(s.f1[2], 0.5, 1e-12);
  EXPECT_EQ(s.confusion[1], (std::vector<long>{0, 1, 2, 0}));
  // A label split evenly stands for the smaller id.
  EXPECT_EQ(score_instances(std::vector<int>{0, 2}, std::vector<int>{0, 0}, 3, 1).label_to_truth[0], 0);
  EXPECT_THROW(score_instances(truth, std::vector<int>(3, 0), 3, 4), smseg::Error);
}

}  // namespace
