#pragma once
// HOG class channels (`learn-hog-classes`, `add-hog-classes`): a linear classifier of the shape around
// each pixel, learned on the training frames, whose class probabilities a forest's windows then read.
// The people detectors (people.hpp) showed that a HOG window's linear score tells people apart better
// than the forest's window means of the gradient channels do; poles, signs, fences and bicyclists have
// no pretrained detector, so this learns one softmax over every class from CamVid's own labels.
//
// Each window (--window, 32x96 by default: a pole is thin and tall) is described by Dalal & Triggs'
// HOG (OpenCV's HOGDescriptor: 16x16 blocks, 8x8 cells and block stride, 9 bins, each block's histogram
// normalised: the same windows under k times the light), at every point of an 8-pixel grid, the image
// padded by half a window so that the grid covers it. A softmax regression over the z-scored
// descriptors, every class of the folders, is trained on the grid points whose pixel is labelled (all of
// --channels' classes, one in --negatives of the others), each class weighted by 1 / sqrt(its count)
// as the forest's `--balance sqrt` does, by mini-batch Adam with an L2 penalty, in one thread and a
// seeded order: the same folders and options give the same file whatever --threads.
//
// add-hog-classes writes one channel per class of the model's `channels`, named fHg<class name>
// (fHgPole, fHgSignSymbol, ...): 255 times the class's probability at each pixel, interpolated bilinearly
// between the four grid points around it, rounded to an integer (0..255: the stack stores a byte).

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/common/io.hpp"
#include "smseg/stacks/stack.hpp"

namespace smseg::stacks {

inline constexpr const char* kHogClassPrefix = "fHg";
inline constexpr const char* kHogClassesFormat = "smseg-hog-classes";
inline constexpr int kHogGridStep = 8;  ///< pixels between window centres, the cell size

/// The learned classifier.
struct HogClassifier {
  cv::Size window{32, 96};
  std::vector<std::string> classes;   ///< every class it scores, the folders' order
  std::vector<std::string> channels;  ///< the classes add-hog-classes writes a channel of
  std::vector<double> mean, scale;    ///< per descriptor entry: z = (d - mean) * scale
  cv::Mat weights;                    ///< classes x descriptor entries, CV_64FC1
  std::vector<double> bias;           ///< per class
  Json provenance = Json::object();

  int descriptor_size() const { return weights.cols; }
  /// "fHg" + each of `channels`.
  std::vector<std::string> feature_names() const;
};

/// Whether a feature name is a HOG class channel.
bool is_hog_class_feature(const std::string& name);

/// The 8-pixel grid of an image: (cols / 8 + 1) x (rows / 8 + 1) points, point (i, j) on pixel (8 i, 8 j).
cv::Size hog_grid_size(cv::Size image);

/// HOG descriptors of the windows centred on the image's grid points (hog_grid_size), one row each in
/// raster order, CV_32FC1. `window`: multiples of 16 (Error naming "window" otherwise).
cv::Mat hog_grid_descriptors(const cv::Mat& bgr, cv::Size window);

/// The position of each of `names` in `classes`; Error naming `file` (or --channels when empty) for a
/// name that is not a class.
std::vector<int> class_positions(const std::vector<std::string>& classes, const std::vector<std::string>& names,
                                 const std::string& file);

struct HogLearning {
  cv::Size window{32, 96};
  std::vector<std::string> channels{"Pole", "SignSymbol", "Fence", "Pedestrian", "Bicyclist"};
  int negatives = 8;        ///< one grid point in this many of the other classes kept
  int epochs = 10;
  double l2 = 1e-4;         ///< penalty on the weights (z-score units), per sample
  double learning_rate = 1e-3;
  std::uint64_t seed = 1;   ///< the negatives kept and the order of the mini-batches
};

/// The grid points of the labelled frames inside `frames` of `works` (their colour images from the
/// sequences): descriptors (CV_32FC1 rows) and labels, in folder, frame and raster order.
struct HogSamples {
  cv::Mat descriptors;
  std::vector<int> labels;
  std::vector<std::string> classes;
};
HogSamples hog_samples(const std::vector<fs::path>& works, const FrameRange& frames, const HogLearning& options,
                       bool progress);

/// The softmax regression of the samples (Error naming --channels for a class the folders do not have; a
/// class they have but no sample holds gets a low probability everywhere: learn-hog-classes records the
/// samples per class). Taken by value: it makes z-scores of the descriptors in place, so
/// move the samples in when they are not needed again.
HogClassifier learn_hog_classifier(HogSamples samples, const HogLearning& options);

/// The model's channel rasters of one image: channels.size() CV_64FC1 rasters of its size.
std::vector<cv::Mat> hog_class_rasters(const cv::Mat& bgr, const HogClassifier& model);

/// Writes the model as JSON (format "smseg-hog-classes" version 1), atomically.
void save_hog_classifier(const fs::path& path, const HogClassifier& model);
/// Reads and checks a model file; Error naming the file and the field.
HogClassifier load_hog_classifier(const fs::path& path);

/// Writes, for each works[i], the work folder outs[i] that extends it with the model's channels of each
/// frame inside `frames`; stacks.json records the model under options.hog_classes. Errors as
/// add_colour_channels (extension.hpp), and a folder whose classes are not the model's.
int add_hog_class_channels(const HogClassifier& model, const fs::path& model_file, const std::vector<fs::path>& works,
                           const std::vector<fs::path>& outs, const FrameRange& frames, bool progress);

}  // namespace smseg::stacks
