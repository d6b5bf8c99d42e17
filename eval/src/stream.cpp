#include "smseg/eval/stream.hpp"

#include <algorithm>
#include <chrono>
#include <memory>
#include <optional>

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

StreamLabeller::Tracked StreamLabeller::track(frontend::StereoFrontEndStream::Prepared&& pair, int frame_index) {
  const cv::Mat left = pair.left;
  if (left.size() != size_)
    throw Error("", "frame " + std::to_string(frame_index),
                "is " + std::to_string(left.cols) + "x" + std::to_string(left.rows) + ", the stream is " +
                    std::to_string(size_.width) + "x" + std::to_string(size_.height));
  frame_ = mono_ ? mono_->advance(std::move(pair)) : stereo_->advance(std::move(pair));
  return tracked_(left, frame_index);
}

std::vector<StreamLabeller::Tracked> StreamLabeller::calibrate(
    std::vector<frontend::StereoFrontEndStream::Prepared>&& first, const std::vector<int>& frame_indices) {
  std::vector<cv::Mat> lefts;
  for (const auto& p : first) {
    if (p.left.size() != size_)
      throw Error("", "frame " + std::to_string(frame_indices[lefts.size()]), "is not of the stream's size");
    lefts.push_back(p.left);
  }
  std::vector<frontend::StreamFrame> frames = stereo_->calibrate(std::move(first));  // needs_calibration(): stereo
  std::vector<Tracked> tracked;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    frame_ = std::move(frames[i]);
    tracked.push_back(tracked_(lefts[i], frame_indices[i]));
  }
  return tracked;
}

StreamLabeller::Tracked StreamLabeller::tracked_(const cv::Mat& left, int frame_index) {
  Tracked t;
  t.left = left;
  t.frame_index = frame_index;
  t.front_end_ms = frame_.ms;
  const auto t0 = Clock::now();
  t.points = features_.advance(frame_);
  t.attributes_ms = ms_since(t0);
  return t;
}

cv::Mat StreamLabeller::classify(const Tracked& frame, StreamStageTimes* times) const {
  auto t0 = Clock::now();
  TableBuffers& buffers = buffers_.local();
  features_.tables(frame.points, buffers.rasters, buffers.sats);
  const double tables_ms = ms_since(t0);

  forest::FrameData data;
  data.width = size_.width;
  data.height = size_.height;
  for (int t : table_of_feature_) data.sats.push_back(buffers.sats[t].ptr<double>());
  data.gray = frame.left.ptr<std::uint8_t>();  // prepare() made a continuous copy
  t0 = Clock::now();
  cv::Mat labels = label_frame(classifier_, data, eval_, frame.frame_index);
  if (times) {
    times->front_end = frame.front_end_ms;
    times->features = frame.attributes_ms + tables_ms;
    times->classify = ms_since(t0);
  }
  return labels;
}

namespace {

using Prepared = frontend::StereoFrontEndStream::Prepared;

struct StreamItem {
  StreamInput input;
  double read_ms = 0;
  Prepared prepared;
  std::optional<StreamLabeller::Tracked> tracked;  // none while it waits for the calibration
  cv::Mat labels;
  StreamStageTimes times;
  // At the last of the calibration's first frames: the earlier ones, tracked with it, handed on before it.
  std::vector<std::shared_ptr<StreamItem>> held;
};
using ItemPtr = std::shared_ptr<StreamItem>;

// The stream's first frames, held until the calibration has them all, then tracked together.
class CalibrationGate {
 public:
  explicit CalibrationGate(StreamLabeller& labeller) : labeller_(labeller), open_(!labeller.needs_calibration()) {}

  // Tracks the item and hands it on; or holds it, handing on an empty item in its place (which
  // nothing shares with it); at the last of the first frames, tracks them all and hands the earlier
  // ones on with it.
  ItemPtr track(const ItemPtr& item) {
    if (open_) {
      item->tracked = labeller_.track(std::move(item->prepared), item->input.index);
      return item;
    }
    waiting_.push_back(item);
    if (waiting_.size() < static_cast<std::size_t>(frontend::kOffsetFrames)) return std::make_shared<StreamItem>();
    release(item);
    return item;
  }

  // A stream that ended among its first frames: them, tracked (none otherwise).
  std::vector<ItemPtr> release_rest() {
    std::vector<ItemPtr> rest;
    if (!waiting_.empty()) {
      auto last = waiting_.back();
      release(last);
      rest = std::move(last->held);
      rest.push_back(last);
    }
    return rest;
  }

 private:
  void release(const ItemPtr& last) {
    std::vector<Prepared> prepared;
    std::vector<int> indices;
    for (auto& w : waiting_) {
      prepared.push_back(std::move(w->prepared));
      indices.push_back(w->input.index);
    }
    std::vector<StreamLabeller::Tracked> tracked = labeller_.calibrate(std::move(prepared), indices);
    for (std::size_t i = 0; i < waiting_.size(); ++i) waiting_[i]->tracked = std::move(tracked[i]);
    waiting_.pop_back();
    last->held = std::move(waiting_);
    waiting_.clear();
    open_ = true;
  }

  StreamLabeller& labeller_;
  bool open_;
  std::vector<ItemPtr> waiting_;
};

void classify(const StreamLabeller& labeller, StreamItem& item) {
  item.labels = labeller.classify(*item.tracked, &item.times);
  item.times.read = item.read_ms;
}

// The item's frames (the held ones first), classified in parallel.
void classify_all(const StreamLabeller& labeller, StreamItem& item) {
  if (!item.tracked) return;
  tbb::parallel_for(std::size_t{0}, item.held.size() + 1, [&](std::size_t i) {
    tbb::this_task_arena::isolate([&] { classify(labeller, i < item.held.size() ? *item.held[i] : item); });
  });
}

}  // namespace

int run_stream(StreamLabeller& labeller, const StreamSource& source, const StreamSink& sink, std::size_t in_flight) {
  int frames = 0;
  const auto deliver = [&](const StreamItem& item) {
    sink(item.input, item.labels, item.times);
    ++frames;
  };
  CalibrationGate gate(labeller);
  tbb::parallel_pipeline(
      std::max<std::size_t>(1, in_flight),
      tbb::make_filter<void, ItemPtr>(tbb::filter_mode::serial_in_order,
                                      [&](tbb::flow_control& fc) {
                                        auto item = std::make_shared<StreamItem>();
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
                                               ItemPtr out;
                                               tbb::this_task_arena::isolate([&] { out = gate.track(item); });
                                               return out;
                                             }) &
          tbb::make_filter<ItemPtr, ItemPtr>(tbb::filter_mode::parallel,
                                             [&](ItemPtr item) {
                                               classify_all(labeller, *item);
                                               return item;
                                             }) &
          // The sink (the label PNG, the summary's figures) sees the frames in order.
          tbb::make_filter<ItemPtr, void>(tbb::filter_mode::serial_in_order, [&](ItemPtr item) {
            for (const ItemPtr& held : item->held) deliver(*held);
            if (item->tracked) deliver(*item);
          }));
  for (const ItemPtr& item : gate.release_rest()) {
    classify(labeller, *item);
    deliver(*item);
  }
  return frames;
}

}  // namespace smseg::eval
