#pragma once
// Shared fixture of the eval tests: small work folders written to disk and a forest trained on them.
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "smseg/stacks/point_features.hpp"
#include "smseg/stacks/stack.hpp"
#include "smseg/forest/train.hpp"

namespace eval_test {

namespace fs = std::filesystem;

// A W x H "scene" (default 64x48): class 0 (floor) below a boundary row near 30, class 1 (wall)
// above; sparse points carry fH = 0 on the floor and 1.5 on the wall, fD marks them. Row 0 is void.
// The greyscale image is dark on the floor, bright on the wall, with noise (for superpixels).
// version 1 writes the tables themselves (an older work folder), version 2 the rasters.
inline fs::path make_work(const std::string& name, int frames, std::vector<std::string> classes = {"floor", "wall"},
                          cv::Size size = cv::Size(64, 48), int version = smseg::stacks::kStacksVersion) {
  using namespace smseg;
  const fs::path work = fs::temp_directory_path() / ("smseg_eval_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(work);
  stacks::StackManifest m;
  m.work = work;
  m.sequence = work / "no-sequence";
  m.size = size;
  m.features = {"fH", "fD"};
  m.classes = classes;
  m.version = version;
  cv::RNG rng(3);
  const int W = size.width, H = size.height;
  for (int f = 0; f < frames; ++f) {
    cv::Mat fh = cv::Mat::zeros(H, W, CV_64FC1), fd = cv::Mat::zeros(H, W, CV_64FC1);
    cv::Mat labels(H, W, CV_8UC1), gray(H, W, CV_8UC1);
    const int boundary = H * 26 / 48 + f % 8;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const bool floor = y >= boundary;
        labels.at<std::uint8_t>(y, x) = y == 0 ? 255 : (floor ? 0 : 1);
        gray.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>((floor ? 60 : 180) + rng.uniform(-20, 20));
        if (rng.uniform(0, 6) == 0) {
          fd.at<double>(y, x) = 1;
          fh.at<double>(y, x) = floor ? 0.0 : 1.5;
        }
      }
    if (version == 1)
      stacks::write_frame_stack(work, f, {stacks::summed_area_table(fh), stacks::summed_area_table(fd)}, gray,
                                  labels);
    else
      stacks::write_frame_values(work, f, size, {fh, fd}, gray, labels);
    m.frames.push_back(f);
    m.labelled_frames.push_back(f);
  }
  stacks::save_stack_manifest(m);
  return work;
}

inline smseg::forest::Forest train(const fs::path& work, int frames_end, int M = 5) {
  using namespace smseg;
  const auto set = stacks::open_stacks({work}, stacks::FrameRange{0, frames_end}, true, true, {});
  forest::TrainParams p;
  p.K = 200;
  p.M = M;
  return forest::train_forest(set.dataset, p);
}

}  // namespace eval_test
