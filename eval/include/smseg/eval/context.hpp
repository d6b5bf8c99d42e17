#pragma once
// Auto-context (Tu & Bai, TPAMI 2010): a second forest whose windows also read the
// first forest's class posteriors. `add-context` writes, for each work folder, a new work folder whose
// stacks hold the first forest's features and, per class c, a channel "fCtx:<class c>": the first
// forest's posterior of c at each pixel (the mean over its trees of the leaf distributions, in [0, 1]),
// read as a summed-area table like every other feature. The new folder stores only the context
// channels; its stacks.json names the source folder as its base (with its stacks.json's digest), from
// which readers take the kept features, the greyscale and the labels (stack.hpp). The second forest is an ordinary train-forest /
// eval-forest run on those folders: its windows average the posteriors around the pixel (context: "sky
// above, road below") as they average the structure-and-motion features.
//
// The leak it must avoid: posteriors of a forest that trained on a frame's labels are nearly those labels,
// so a second forest trained on them would learn to trust them far more than it can on a test frame.
// Training folders therefore get out-of-fold posteriors (context_out_of_fold): their labelled frames are
// cut into K contiguous folds, in the order of the work folders and then of the frames (contiguous, so that
// a frame's near neighbours in the video mostly share its fold), and fold k is labelled by a forest trained
// with the first forest's parameters and features on the other K-1 folds only. A frame without labels has
// nothing to leak and gets the first forest's posteriors, as test folders do (context_from_forest).
// With the first forest's seed for every fold forest, the same inputs give the same bytes.

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/stacks/stack.hpp"
#include "smseg/forest/classify.hpp"
#include "smseg/forest/forest.hpp"

namespace smseg::eval {

/// The prefix of the context channels' names: "fCtx:Sky", "fCtx:Road", ...
inline constexpr const char* kContextPrefix = stacks::kContextChannelPrefix;

/// "fCtx:<class>" for each class, in class order.
std::vector<std::string> context_feature_names(const std::vector<std::string>& classes);

/// Whether a feature name is a context channel.
bool is_context_feature(const std::string& name);

/// The fold (0..folds-1) of each of `frames` items taken in order: contiguous runs, as equal as can be
/// (the first frames % folds folds one longer). Error naming "--folds" unless 2 <= folds <= frames.
std::vector<int> contiguous_folds(std::size_t frames, int folds);

/// The context rasters of one frame: per class, the classifier's posterior (summed leaf distributions
/// over `trees`), each CV_64FC1 of the frame's size.
std::vector<cv::Mat> posterior_rasters(const forest::Classifier& classifier, const forest::FrameData& frame,
                                       int trees);

struct ContextOptions {
  stacks::FrameRange frames;       ///< frames of each work folder written (and, in folds, trained on)
  std::vector<std::string> keep;     ///< features copied to the output besides the context (empty: the forest's)
  int folds = 0;                     ///< 0: context_from_forest; >= 2: out-of-fold (context_out_of_fold)
  std::size_t memory_mb = 2048;      ///< training budget of each fold forest (TrainParams::memory_mb)
  bool progress = false;
};

struct ContextReport {
  int frames_written = 0;
  int out_of_fold_frames = 0;         ///< frames labelled by a fold forest (the rest: by the given forest)
  std::vector<int> frames_per_fold;   ///< labelled frames in each fold
  double train_seconds = 0;           ///< fold forests' training, wall
  double label_seconds = 0;           ///< posteriors and writing, wall
};

/// Writes, for each works[i], the work folder outs[i]: the frames of works[i] inside options.frames, with
/// the features options.keep (or the forest's) then the context channels of `forest`'s classes; labels and
/// greyscale as in works[i]. With options.folds >= 2 the labelled frames get out-of-fold posteriors (see
/// the header comment); otherwise every frame gets `forest`'s. stacks.json records the forest, the folds
/// and the source work folder under options.context, and the source as its base. Errors name the file: a forest that does not fit the
/// stacks, fewer labelled frames than folds, a kept feature the stacks lack.
ContextReport add_context(const forest::Forest& forest, const fs::path& forest_file, const std::vector<fs::path>& works,
                          const std::vector<fs::path>& outs, const ContextOptions& options);

}  // namespace smseg::eval
