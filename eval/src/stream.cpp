#include "smseg/eval/stream.hpp"

#include <algorithm>
#include <chrono>
#include <memory>

#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

namespace smseg::eval {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

stacks::FeatureOptions causal_features(const StreamOptions& options) {
  stacks::FeatureOptions f;
  f.causal = true;
  if (options.mono) f.height_reference = stacks::HeightReference::Camera;  // the vo front end's
  return f;
}

// Where each of the forest's features is in the stream's stack (structure_feature_names order).
std::vector<int> feature_tables(const forest::Forest& forest, const std::string& forest_file) {
  const auto& names = stacks::structure_feature_names();
  std::vector<int> tables;
  for (const std::string& f : forest.features) {
    const auto it = std::find(names.begin(), names.end(), f);
    if (it == names.end())
      throw Error(forest_file, "features", "the forest reads feature '" + f + "', which a stream does not compute");
    tables.push_back(static_cast<int>(it - names.begin()));
  }
  return tables;
}

// What a stream cannot do, said before anything is built: frames of another size than the forest's,
// a feature it does not compute, the training filters that read the ground truth.
std::vector<int> checked_feature_tables(const forest::Forest& forest, const std::string& forest_file, cv::Size size,
                                        const StreamOptions& options, const std::string& source) {
  if (forest.width != size.width || forest.height != size.height)
    throw Error(source, "image_size",
                "frames are " + std::to_string(size.width) + "x" + std::to_string(size.height) + ", the forest " +
                    forest_file + " was trained on " + std::to_string(forest.width) + "x" + std::to_string(forest.height));
  if (options.front_end.filters.require_label)
    throw Error(source, "filters.require_label", "reads the ground truth: a stream has none");
  return feature_tables(forest, forest_file);
}

}  // namespace

StreamLabeller::StreamLabeller(const forest::Forest& forest, const std::string& forest_file,
                               const sequence::Calibration& calibration, std::optional<double> camera_height,
                               cv::Size size, const StreamOptions& options, const std::string& source)
    : table_of_feature_(checked_feature_tables(forest, forest_file, size, options, source)),
      classifier_(make_classifier(forest, options.eval)),
      eval_(options.eval),
      size_(size),
      features_(size, causal_features(options),
                options.mono ? options.mono->filters.min_frames : options.front_end.filters.min_frames) {
  eval_.validate();
  if (options.mono)
    mono_.emplace(calibration, camera_height, size, *options.mono, source);
  else
    stereo_.emplace(calibration, camera_height, options.front_end, source);
}

frontend::StereoFrontEndStream::Prepared StreamLabeller::prepare(const cv::Mat& left, const cv::Mat& right) const {
  return mono_ ? mono_->prepare(left) : stereo_->prepare(left, right);
}

cv::Mat StreamLabeller::label(frontend::StereoFrontEndStream::Prepared&& pair, int frame_index, StreamStageTimes* times) {
  const cv::Mat left = pair.left;
  if (left.size() != size_)
    throw Error("", "frame " + std::to_string(frame_index),
                "is " + std::to_string(left.cols) + "x" + std::to_string(left.rows) + ", the stream is " +
                    std::to_string(size_.width) + "x" + std::to_string(size_.height));
  frame_ = mono_ ? mono_->advance(std::move(pair)) : stereo_->advance(std::move(pair));
  return label_frame_(left, frame_index, times);
}

void StreamLabeller::calibrate(std::vector<frontend::StereoFrontEndStream::Prepared>&& first,
                               const std::vector<int>& frame_indices, const Labelled& labelled) {
  std::vector<cv::Mat> lefts;
  for (const auto& p : first) {
    if (p.left.size() != size_)
      throw Error("", "frame " + std::to_string(frame_indices[lefts.size()]), "is not of the stream's size");
    lefts.push_back(p.left);
  }
  std::vector<frontend::StreamFrame> frames = stereo_->calibrate(std::move(first));  // needs_calibration(): stereo
  for (std::size_t i = 0; i < frames.size(); ++i) {
    frame_ = std::move(frames[i]);
    StreamStageTimes times;
    const cv::Mat labels = label_frame_(lefts[i], frame_indices[i], &times);
    labelled(i, labels, times);
  }
}

cv::Mat StreamLabeller::label_frame_(const cv::Mat& left, int frame_index, StreamStageTimes* times) {
  auto t0 = Clock::now();
  const std::vector<cv::Mat>& sats = features_.push(frame_);
  const double features_ms = ms_since(t0);

  forest::FrameData data;
  data.width = size_.width;
  data.height = size_.height;
  for (int t : table_of_feature_) data.sats.push_back(sats[t].ptr<double>());
  data.gray = left.ptr<std::uint8_t>();  // prepare() made a continuous copy
  t0 = Clock::now();
  cv::Mat labels = label_frame(classifier_, data, eval_, frame_index);
  if (times) {
    times->front_end = frame_.ms;
    times->features = features_ms;
    times->classify = ms_since(t0);
  }
  return labels;
}

namespace {

struct StreamItem {
  StreamInput input;
  double read_ms = 0;
  frontend::StereoFrontEndStream::Prepared prepared;
  cv::Mat labels;
  StreamStageTimes times;
};

// A labeller that needs its calibration: the first frames read, prepared in parallel, calibrated on,
// labelled and handed to the sink. False when the source ended among them.
bool calibrate_on_first_frames(StreamLabeller& labeller, const StreamSource& source, const StreamSink& sink, int& frames) {
  std::vector<StreamItem> items;
  bool more = true;
  while (more && items.size() < static_cast<std::size_t>(frontend::kOffsetFrames)) {
    StreamItem item;
    item.input.arrived = Clock::now();
    more = source(item.input);
    item.read_ms = ms_since(item.input.arrived);
    if (more) items.push_back(std::move(item));
  }
  tbb::parallel_for(std::size_t{0}, items.size(), [&](std::size_t i) {
    tbb::this_task_arena::isolate([&] { items[i].prepared = labeller.prepare(items[i].input.left, items[i].input.right); });
  });
  std::vector<frontend::StereoFrontEndStream::Prepared> prepared;
  std::vector<int> indices;
  for (auto& item : items) {
    prepared.push_back(std::move(item.prepared));
    indices.push_back(item.input.index);
  }
  labeller.calibrate(std::move(prepared), indices, [&](std::size_t i, const cv::Mat& labels, const StreamStageTimes& t) {
    StreamStageTimes times = t;
    times.read = items[i].read_ms;
    sink(items[i].input, labels, times);
    ++frames;
  });
  return more;
}

}  // namespace

int run_stream(StreamLabeller& labeller, const StreamSource& source, const StreamSink& sink, std::size_t in_flight) {
  using Item = StreamItem;
  using ItemPtr = std::shared_ptr<Item>;
  int frames = 0;
  if (labeller.needs_calibration() && !calibrate_on_first_frames(labeller, source, sink, frames)) return frames;
  tbb::parallel_pipeline(
      std::max<std::size_t>(1, in_flight),
      tbb::make_filter<void, ItemPtr>(tbb::filter_mode::serial_in_order,
                                      [&](tbb::flow_control& fc) {
                                        auto item = std::make_shared<Item>();
                                        item->input.arrived = Clock::now();
                                        if (!source(item->input)) {
                                          fc.stop();
                                          return ItemPtr();
                                        }
                                        item->read_ms = ms_since(item->input.arrived);
                                        return item;
                                      }) &
          tbb::make_filter<ItemPtr, ItemPtr>(tbb::filter_mode::parallel,
                                             [&](ItemPtr item) {
                                               // Isolated: while its own parallel loops wait, this thread
                                               // takes no other frame's stage (which would hold them up).
                                               tbb::this_task_arena::isolate([&] {
                                                 item->prepared = labeller.prepare(item->input.left, item->input.right);
                                               });
                                               return item;
                                             }) &
          tbb::make_filter<ItemPtr, ItemPtr>(tbb::filter_mode::serial_in_order,
                                             [&](ItemPtr item) {
                                               tbb::this_task_arena::isolate([&] {
                                                 item->labels = labeller.label(std::move(item->prepared),
                                                                               item->input.index, &item->times);
                                               });
                                               item->times.read = item->read_ms;
                                               return item;
                                             }) &
          // The sink (the label PNG, the summary's figures) is its own in-order stage: it writes frame t
          // while the labeller tracks frame t + 1, and sees the frames in order.
          tbb::make_filter<ItemPtr, void>(tbb::filter_mode::serial_in_order, [&](ItemPtr item) {
            sink(item->input, item->labels, item->times);
            ++frames;
          }));
  return frames;
}

}  // namespace smseg::eval
