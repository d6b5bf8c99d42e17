// HOG classes on work folders: the samples learn-hog-classes trains on, the channels add-hog-classes
// writes (hog_classes.hpp).
#include <algorithm>
#include <random>

#include <oneapi/tbb/parallel_for.h>

#include "smseg/common/digest.hpp"
#include "smseg/common/error.hpp"
#include "smseg/common/progress.hpp"
#include "smseg/sequence/sequence.hpp"
#include "smseg/stacks/extension.hpp"
#include "smseg/stacks/hog_classes.hpp"
#include "smseg/stacks/label_check.hpp"
#include "learned_files.hpp"

namespace smseg::stacks {

namespace {

/// One frame's kept grid points: descriptor rows and labels.
struct FrameSamples {
  cv::Mat rows;
  std::vector<int> labels;
};

FrameSamples frame_samples(const cv::Mat& bgr, const std::uint8_t* labels, const std::vector<bool>& whole,
                           const HogLearning& o, std::uint64_t seed) {
  const cv::Mat d = hog_grid_descriptors(bgr, o.window);
  const int nx = hog_grid_size(bgr.size()).width;
  std::mt19937_64 rng(seed);
  FrameSamples s;
  for (int r = 0; r < d.rows; ++r) {
    const int x = std::min((r % nx) * kHogGridStep, bgr.cols - 1), y = std::min((r / nx) * kHogGridStep, bgr.rows - 1);
    const std::uint8_t l = labels[std::size_t(y) * std::size_t(bgr.cols) + std::size_t(x)];
    if (l == forest::kVoidLabel) continue;
    const bool keep = whole[l] || rng() % std::uint64_t(o.negatives) == 0;  // one draw a negative point
    if (!keep) continue;
    s.rows.push_back(d.row(r));
    s.labels.push_back(l);
  }
  return s;
}

}  // namespace

HogSamples hog_samples(const std::vector<fs::path>& works, const FrameRange& range, const HogLearning& o,
                       bool progress) {
  if (works.empty()) throw Error("", "WORK", "name at least one work folder");
  if (o.negatives < 1) throw Error("", "--negatives", "is " + std::to_string(o.negatives) + ", expected >= 1");
  HogSamples all;
  std::vector<cv::Mat> parts;
  for (std::size_t w = 0; w < works.size(); ++w) {
    const StackManifest m = load_stack_manifest(works[w]);
    if (w == 0) all.classes = m.classes;
    if (m.classes != all.classes)
      throw Error(m.manifest_path().string(), "classes", "are not those of " + works[0].string());
    std::vector<bool> whole(m.classes.size(), false);
    for (int c : class_positions(m.classes, o.channels, m.manifest_path().string())) whole[std::size_t(c)] = true;
    const sequence::Sequence seq = sequence::load_sequence(m.sequence);
    std::vector<int> frames;
    for (int f : frames_in_range(m, range))
      if (m.is_labelled(f)) frames.push_back(f);
    std::vector<FrameSamples> samples(frames.size());
    const std::vector<bool> no_tables(m.features.size(), false);
    Progress bar("learn-hog-classes " + m.work.filename().string(), static_cast<long>(frames.size()), progress);
    tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t i) {
      const FrameStack stack = FrameStack::open(m, frames[i], true, no_tables);
      check_labels(stack.view(), m.labels_file(frames[i]), m.classes.size());  // each a class or void
      samples[i] = frame_samples(colour_image(seq, m, frames[i]), stack.labels(), whole, o, frame_seed(o.seed, w, frames[i]));
      bar.tick();
    });
    for (auto& s : samples) {  // in frame order, whatever the threads did
      if (!s.rows.empty()) parts.push_back(s.rows);
      all.labels.insert(all.labels.end(), s.labels.begin(), s.labels.end());
    }
  }
  // One copy of the rows at a time: each frame's part is released once copied.
  if (!parts.empty()) all.descriptors.create(int(all.labels.size()), parts.front().cols, CV_32FC1);
  int row = 0;
  for (cv::Mat& part : parts) {
    part.copyTo(all.descriptors.rowRange(row, row + part.rows));
    row += part.rows;
    part.release();
  }
  return all;
}

int add_hog_class_channels(const HogClassifier& model, const fs::path& model_file, const std::vector<fs::path>& works,
                           const std::vector<fs::path>& outs, const FrameRange& range, bool progress) {
  ColourChannels hog;
  hog.tool = "add-hog-classes";
  hog.names = model.feature_names();
  hog.is_own = is_hog_class_feature;
  hog.options_key = "hog_classes";
  hog.options = {{"model", fs::absolute(model_file).lexically_normal().string()},
                 {"model_fnv1a64", fnv1a64_hex(read_file(model_file))},
                 {"window", {model.window.width, model.window.height}},
                 {"channels", model.channels}};
  hog.check_folder = [&](const StackManifest& m) {
    if (m.classes != model.classes)
      throw Error(m.manifest_path().string(), "classes", "are not those of the model " + model_file.string());
  };
  hog.rasters = [&model](const cv::Mat& bgr) { return hog_class_rasters(bgr, model); };
  return add_colour_channels(hog, works, outs, range, progress);
}

}  // namespace smseg::stacks
