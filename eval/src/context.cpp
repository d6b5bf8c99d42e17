#include "smseg/eval/context.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <utility>

#include "smseg/common/error.hpp"
#include "smseg/common/progress.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/eval/evaluate.hpp"
#include "smseg/forest/train.hpp"

namespace smseg::eval {

std::vector<std::string> context_feature_names(const std::vector<std::string>& classes) {
  std::vector<std::string> names;
  for (const auto& c : classes) names.push_back(kContextPrefix + c);
  return names;
}

bool is_context_feature(const std::string& name) { return name.rfind(kContextPrefix, 0) == 0; }

std::vector<int> contiguous_folds(std::size_t frames, int folds) {
  if (folds < 2 || static_cast<std::size_t>(folds) > frames)
    throw Error("", "--folds", "is " + std::to_string(folds) + ", expected 2.." + std::to_string(frames) +
                                   " (at most one fold per labelled frame; there are " + std::to_string(frames) + ")");
  std::vector<int> fold(frames);
  const std::size_t base = frames / folds, longer = frames % folds;
  std::size_t i = 0;
  for (int k = 0; k < folds; ++k)
    for (std::size_t n = base + (static_cast<std::size_t>(k) < longer ? 1 : 0); n > 0; --n) fold[i++] = k;
  return fold;
}

std::vector<cv::Mat> posterior_rasters(const forest::Classifier& classifier, const forest::FrameData& frame,
                                       int trees) {
  const int W = frame.width, H = frame.height, C = classifier.num_classes();
  std::vector<std::uint8_t> labels(static_cast<std::size_t>(W) * H);
  std::vector<float> dists(labels.size() * C);
  classifier.classify_frame(frame, labels, dists);
  std::vector<cv::Mat> rasters(C);
  for (cv::Mat& r : rasters) r.create(H, W, CV_64FC1);
  const double scale = 1.0 / trees;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const float* d = dists.data() + (static_cast<std::size_t>(y) * W + x) * C;
      for (int c = 0; c < C; ++c) rasters[c].ptr<double>(y)[x] = d[c] * scale;
    }
  return rasters;
}

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Where each name is among the manifest's features; Error naming the stacks.json otherwise.
std::vector<int> feature_indices(const stacks::StackManifest& m, const std::vector<std::string>& names,
                                 const std::string& who) {
  std::vector<int> idx;
  for (const auto& n : names) {
    const auto it = std::find(m.features.begin(), m.features.end(), n);
    if (it == m.features.end())
      throw Error(m.manifest_path().string(), "features", "has no feature \"" + n + "\" (" + who + ")");
    idx.push_back(static_cast<int>(it - m.features.begin()));
  }
  return idx;
}

/// The forests that label each labelled frame out of fold: fold forest k trained on every labelled frame
/// (of all work folders, inside the range) outside fold k, with the given forest's parameters.
struct OutOfFold {
  std::vector<forest::Forest> forests;
  std::map<std::pair<int, int>, int> fold_of;  ///< (work folder index, frame) -> fold
  std::vector<int> frames_per_fold;
};

OutOfFold train_fold_forests(const forest::Forest& forest, const std::vector<fs::path>& works,
                             const ContextOptions& options) {
  stacks::StackSet set = stacks::open_stacks(works, options.frames, true, true, forest.features);
  stacks::lighten_frames(set, forest.params.lightness);
  const std::vector<int> fold = contiguous_folds(set.dataset.frames.size(), options.folds);
  OutOfFold oof;
  oof.frames_per_fold.assign(options.folds, 0);
  for (std::size_t i = 0; i < fold.size(); ++i) {
    oof.fold_of[set.origin[i]] = fold[i];
    ++oof.frames_per_fold[fold[i]];
  }
  forest::TrainParams params = forest.params;
  params.memory_mb = options.memory_mb;
  params.progress = options.progress;
  for (int k = 0; k < options.folds; ++k) {
    forest::Dataset others = set.dataset;
    others.frames.clear();
    for (std::size_t i = 0; i < fold.size(); ++i)
      if (fold[i] != k) others.frames.push_back(set.dataset.frames[i]);
    if (options.progress)
      std::fprintf(stderr, "add-context: fold %d of %d: training on %zu frames, labelling %d\n", k + 1, options.folds,
                   others.frames.size(), oof.frames_per_fold[k]);
    oof.forests.push_back(forest::train_forest(others, params));
  }
  return oof;
}

/// stacks.json's record of how the context was made (the source, the forest, the folds).
Json context_record(const fs::path& forest_file, const fs::path& source, const ContextOptions& options,
                    const std::vector<std::string>& keep) {
  return {{"source_work", fs::absolute(source).lexically_normal().string()},
          {"forest", fs::absolute(forest_file).lexically_normal().string()},
          {"folds", options.folds},
          {"frames", options.frames.str()},
          {"kept_features", keep},
          {"channels", "per class, the mean over the trees of the leaf distributions (posterior), as a SAT"}};
}

/// A work folder to write: its manifest and where the forest's features are in its tables.
struct Source {
  fs::path work;
  stacks::StackManifest manifest;
  std::vector<int> reads;
};

/// Every check before any work: the forest fits each folder, each has the features read and kept, and a
/// frame inside the range.
std::vector<Source> open_sources(const forest::Forest& forest, const std::vector<fs::path>& works,
                                 const std::vector<std::string>& keep, const stacks::FrameRange& frames) {
  std::vector<Source> sources;
  for (const auto& w : works) {
    Source s{w, stacks::load_stack_manifest(w), {}};
    check_forest_fits(forest, s.manifest);
    s.reads = feature_indices(s.manifest, forest.features, "the forest reads it");
    feature_indices(s.manifest, keep, "--features keeps it");
    stacks::frames_in_range(s.manifest, frames);  // at least one frame in range
    sources.push_back(std::move(s));
  }
  return sources;
}

}  // namespace

ContextReport add_context(const forest::Forest& forest, const fs::path& forest_file, const std::vector<fs::path>& works,
                          const std::vector<fs::path>& outs, const ContextOptions& options) {
  if (works.empty()) throw Error("", "WORK", "name at least one work folder");
  if (works.size() != outs.size()) throw Error("", "WORK", "one output folder per work folder");
  const std::vector<std::string> keep = options.keep.empty() ? forest.features : options.keep;
  const std::vector<std::string> context = context_feature_names(forest.classes);
  for (const auto& k : keep)
    if (std::find(context.begin(), context.end(), k) != context.end())
      throw Error("", "--features", "\"" + k + "\" is a context channel this run writes anew; leave it out");
  const std::vector<Source> sources = open_sources(forest, works, keep, options.frames);

  ContextReport report;
  const auto t0 = std::chrono::steady_clock::now();
  OutOfFold oof;
  if (options.folds != 0) oof = train_fold_forests(forest, works, options);
  report.frames_per_fold = oof.frames_per_fold;
  report.train_seconds = seconds_since(t0);

  const auto t1 = std::chrono::steady_clock::now();
  const forest::Classifier whole(forest);
  std::vector<forest::Classifier> by_fold;
  for (const auto& f : oof.forests) by_fold.emplace_back(f);
  const int trees = static_cast<int>(forest.trees.size());
  for (std::size_t w = 0; w < sources.size(); ++w) {
    const Source& src = sources[w];
    const stacks::StackManifest& m = src.manifest;
    stacks::StackManifest out = stacks::extending_manifest(m, outs[w], keep, context);
    out.options["context"] = context_record(forest_file, src.work, options, keep);
    Progress progress("add-context " + src.work.filename().string(), static_cast<long>(m.frames.size()),
                      options.progress);
    std::vector<bool> read(m.features.size(), false);  // only the forest's tables are built
    for (int i : src.reads) read[static_cast<std::size_t>(i)] = true;
    for (int f : m.frames) {
      progress.tick();
      if (!options.frames.contains(f)) continue;
      const bool labelled = m.is_labelled(f);
      const stacks::FrameStack stack = stacks::FrameStack::open(m, f, labelled, read);
      forest::FrameData input = stack.view();
      input.sats.clear();
      for (int i : src.reads) input.sats.push_back(stack.sat(i));
      std::optional<stacks::FrameStack> lightened;  // owns the mapped tables while `input` is used
      if (forest.params.lightness > 0)
        lightened.emplace(stacks::lighten_frame(input, forest.features, forest.params.lightness, f,
                                                m.manifest_path().string()));
      const auto fold = oof.fold_of.find({static_cast<int>(w), f});
      const bool out_of_fold = fold != oof.fold_of.end();
      const forest::Classifier& classifier = out_of_fold ? by_fold[fold->second] : whole;
      stacks::write_frame_values(out.work, f, m.size, posterior_rasters(classifier, input, trees), cv::Mat(), cv::Mat());
      out.frames.push_back(f);
      if (labelled) out.labelled_frames.push_back(f);
      ++report.frames_written;
      report.out_of_fold_frames += out_of_fold;
    }
    stacks::save_stack_manifest(out);
  }
  report.label_seconds = seconds_since(t1);
  return report;
}

}  // namespace smseg::eval
