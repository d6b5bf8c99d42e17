// The classifier's fast path against its per-pixel reference on a CamVid-size forest: 480x360 frames
// of CamVid val (SMSEG_SHARED_DIR/data/camvid), appearance features summed into double tables, a
// forest of Kt = 20 000 tests per tree (~2 900 nodes per tree, depth > 15; the structure-and-motion CamVid forest has ~5 600). Skipped with a
// message when the CamVid images are absent.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "smseg/forest/classify.hpp"
#include "smseg/forest/train.hpp"

namespace {

using namespace smseg::forest;
namespace fs = std::filesystem;

const fs::path kCamVid = fs::path(SMSEG_SHARED_DIR) / "data" / "camvid";

/// One CamVid frame as the forest sees it: six features (B, G, R, grey, |d/dx|, |d/dy| of grey) as
/// double summed-area tables, grey, labels (class index; 11 = void becomes kVoidLabel).
struct CamVidFrame {
  std::vector<cv::Mat> sats;
  cv::Mat gray, labels;
  FrameData view() const {
    FrameData d;
    d.width = gray.cols;
    d.height = gray.rows;
    for (const cv::Mat& s : sats) d.sats.push_back(s.ptr<double>());
    d.gray = gray.ptr<std::uint8_t>();
    d.labels = labels.ptr<std::uint8_t>();
    return d;
  }
};

CamVidFrame load_frame(const std::string& name) {
  CamVidFrame f;
  const cv::Mat bgr = cv::imread((kCamVid / "val" / name).string(), cv::IMREAD_COLOR);
  f.labels = cv::imread((kCamVid / "valannot" / name).string(), cv::IMREAD_UNCHANGED);
  if (bgr.empty() || f.labels.empty() || f.labels.type() != CV_8UC1) throw std::runtime_error("cannot read " + name);
  f.labels.setTo(kVoidLabel, f.labels >= 11);
  cv::cvtColor(bgr, f.gray, cv::COLOR_BGR2GRAY);
  std::vector<cv::Mat> planes;
  cv::split(bgr, planes);
  planes.push_back(f.gray);
  cv::Mat dx, dy;
  cv::Sobel(f.gray, dx, CV_32F, 1, 0);
  cv::Sobel(f.gray, dy, CV_32F, 0, 1);
  planes.push_back(cv::abs(dx));
  planes.push_back(cv::abs(dy));
  for (const cv::Mat& p : planes) {
    cv::Mat sat;
    cv::integral(p, sat, CV_64F);
    f.sats.push_back(sat);
  }
  return f;
}

TEST(ClassifierCamVid, FastPathEqualsThePerPixelReferenceOnACamVidSizeForest) {
  if (!fs::exists(kCamVid / "val" / "0016E5_07959.png"))
    GTEST_SKIP() << "CamVid val images not found under " << kCamVid << " (SMSEG_SHARED_DIR)";
  std::vector<CamVidFrame> frames;
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(kCamVid / "val")) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  ASSERT_GE(names.size(), 90u);
  // Eight frames 12 apart (1.6 s at 15 Hz) to train on, one in between them to label.
  for (std::size_t k = 0; k < 8; ++k) frames.push_back(load_frame(names[12 * k]));
  frames.push_back(load_frame(names[42]));
  Dataset train;
  train.width = frames[0].gray.cols;
  train.height = frames[0].gray.rows;
  train.features = {"B", "G", "R", "grey", "gx", "gy"};
  for (int c = 0; c < 11; ++c) train.classes.push_back("class" + std::to_string(c));
  for (std::size_t i = 0; i + 1 < frames.size(); ++i) train.frames.push_back(frames[i].view());
  TrainParams p;
  p.Ks = 60;
  p.Kt = 20000;
  p.M = 7;
  p.n_min = 2;  // appearance separates these frames more easily than structure and motion: deeper trees
  const Forest forest = train_forest(train, p);
  for (const TreeStats& t : forest.stats.trees) {
    EXPECT_GT(t.nodes, 2500) << "not a CamVid-size tree";
    EXPECT_GT(t.depth, 15);
  }

  Classifier clf(forest);
  const FrameData frame = frames.back().view();
  const std::size_t C = forest.classes.size(), n = static_cast<std::size_t>(frame.width) * frame.height;
  // Every SIMD target the processor runs (the scalar loops, AVX2 and AVX-512 on an AVX-512 machine)
  // splitting a whole frame's pixels, each against the per-pixel reference.
  for (const std::string& target : Classifier::simd_targets()) {
    clf.set_simd_target(target);
    SCOPED_TRACE("whole frame, SIMD target " + target);
    std::vector<std::uint8_t> labels(n);
    std::vector<float> dists(n * C), ref(C);
    clf.classify_frame(frame, labels, dists);
    std::size_t label_mismatches = 0, dist_mismatches = 0;
    for (int y = 0; y < frame.height; ++y)
      for (int x = 0; x < frame.width; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * frame.width + x;
        label_mismatches += clf.posterior(frame, x, y, ref.data()) != labels[i];
        for (std::size_t c = 0; c < C; ++c) dist_mismatches += ref[c] != dists[i * C + c];
      }
    // The same double sums and float thresholds: bit for bit, on every pixel.
    EXPECT_EQ(label_mismatches, 0u);
    EXPECT_EQ(dist_mismatches, 0u);
  }

  // Pixel lists (grid and superpixel voters: the lanes of route_tree, or of each target's vector
  // walk), every pixel of the frame in a scattered order, so that each lane meets pixels near the
  // borders (corners clipped) and inside.
  std::vector<Pixel> pixels;
  for (int y = 0; y < frame.height; ++y)
    for (int x = 0; x < frame.width; ++x) pixels.push_back({x, y});
  std::shuffle(pixels.begin(), pixels.end(), std::mt19937(7));
  for (const std::string& target : Classifier::simd_targets()) {
    clf.set_simd_target(target);
    SCOPED_TRACE("pixel list, SIMD target " + target);
    std::vector<std::uint8_t> labels(pixels.size());
    std::vector<float> dists(pixels.size() * C), ref(C);
    clf.classify_pixels(frame, pixels, labels, dists);
    std::size_t label_mismatches = 0, dist_mismatches = 0;
    for (std::size_t i = 0; i < pixels.size(); ++i) {
      label_mismatches += clf.posterior(frame, pixels[i].x, pixels[i].y, ref.data()) != labels[i];
      for (std::size_t c = 0; c < C; ++c) dist_mismatches += ref[c] != dists[i * C + c];
    }
    EXPECT_EQ(label_mismatches, 0u);
    EXPECT_EQ(dist_mismatches, 0u);
  }
}

}  // namespace
