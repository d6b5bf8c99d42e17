#include "smseg/eval/evaluate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include <tbb/parallel_for.h>

#include "smseg/eval/render.hpp"
#include "smseg/forest/classify.hpp"
#include "smseg/forest/rng.hpp"
#include "smseg/progress.hpp"

namespace smseg::eval {

namespace {

std::uint64_t mix(std::uint64_t x) {  // splitmix64 finaliser: counter-based, thread-independent draws
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

std::string stem(int frame) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%06d", frame);
  return buf;
}

}  // namespace

void EvalOptions::validate() const {
  if (grid < 0 || grid > 10000) throw Error("", "--grid", "must be 0 (per pixel) or a cell size in pixels");
  if (grid > 0 && votes < 1) throw Error("", "--votes", "must be at least 1 (B*B or more: every pixel votes)");
}

cv::Mat label_frame(const forest::Classifier& classifier, const forest::FrameData& frame, const EvalOptions& opt,
                    int frame_index) {
  cv::Mat labels(frame.height, frame.width, CV_8UC1);
  if (opt.grid <= 0) {
    classifier.classify_frame(frame, std::span<std::uint8_t>(labels.data, labels.total()));
    return labels;
  }
  const int B = opt.grid, C = classifier.num_classes();
  const int cells_x = (frame.width + B - 1) / B, cells_y = (frame.height + B - 1) / B;
  const int cells = cells_x * cells_y;
  // Each cell's voters: every pixel when V covers the cell, else V distinct pixels drawn with Floyd's
  // algorithm from a counter-based generator keyed by (seed, frame, cell): thread-independent.
  std::vector<forest::Pixel> pixels;
  std::vector<std::size_t> first(cells + 1, 0);
  pixels.reserve(std::size_t(cells) * opt.votes);
  std::vector<int> chosen;
  for (int cy = 0; cy < cells_y; ++cy)
    for (int cx = 0; cx < cells_x; ++cx) {
      const int cell = cy * cells_x + cx;
      const int x0 = cx * B, y0 = cy * B;
      const int w = std::min(B, frame.width - x0), h = std::min(B, frame.height - y0);
      const int n = w * h;
      if (opt.votes >= n) {
        for (int i = 0; i < n; ++i) pixels.push_back({x0 + i % w, y0 + i / w});
      } else {
        std::uint64_t key = mix(opt.seed ^ mix(std::uint64_t(frame_index) * 1000003ull + std::uint64_t(cell)));
        chosen.clear();
        for (int j = n - opt.votes; j < n; ++j) {
          key = mix(key);
          const int t = static_cast<int>(key % std::uint64_t(j + 1));
          chosen.push_back(std::find(chosen.begin(), chosen.end(), t) == chosen.end() ? t : j);
        }
        for (int i : chosen) pixels.push_back({x0 + i % w, y0 + i / w});
      }
      first[cell + 1] = pixels.size();
    }
  std::vector<std::uint8_t> votes(pixels.size());
  std::vector<float> dists(pixels.size() * C);
  classifier.classify_pixels(frame, pixels, votes, dists);
  std::vector<double> sum(C);
  for (int cell = 0; cell < cells; ++cell) {
    std::fill(sum.begin(), sum.end(), 0.0);
    for (std::size_t v = first[cell]; v < first[cell + 1]; ++v)
      for (int c = 0; c < C; ++c) sum[c] += dists[v * C + c];
    const int best = static_cast<int>(std::max_element(sum.begin(), sum.end()) - sum.begin());
    const int cx = cell % cells_x, cy = cell / cells_x;
    const cv::Rect r(cx * B, cy * B, std::min(B, frame.width - cx * B), std::min(B, frame.height - cy * B));
    labels(r).setTo(best);
  }
  return labels;
}

EvalResult evaluate(const forest::Forest& forest, const std::vector<fs::path>& works, const EvalOptions& opt) {
  opt.validate();
  const features::StackSet set = features::open_stacks(works, opt.frames, true, true, forest.features);
  const features::StackManifest& m0 = set.manifests.front();
  forest::check_compatible(forest, m0.classes, forest.features, m0.manifest_path());
  if (forest.width != m0.size.width || forest.height != m0.size.height)
    throw Error(m0.manifest_path().string(), "image_size",
                "stacks are " + std::to_string(m0.size.width) + "x" + std::to_string(m0.size.height) +
                    ", the forest was trained on " + std::to_string(forest.width) + "x" + std::to_string(forest.height));
  const forest::Classifier classifier(forest);
  const int C = static_cast<int>(forest.classes.size());

  // Pictures need the sequences (input images, class colours).
  std::vector<std::optional<features::Sequence>> sequences(set.manifests.size());
  if (!opt.pictures.empty())
    for (std::size_t k = 0; k < set.manifests.size(); ++k) sequences[k] = features::load_sequence(set.manifests[k].sequence);

  EvalResult result;
  result.confusion = Confusion(C);
  Progress progress("eval-forest", static_cast<long>(set.stacks.size()), opt.progress);
  double total_seconds = 0;
  for (std::size_t i = 0; i < set.stacks.size(); ++i) {
    const auto [work_index, frame] = set.origin[i];
    const forest::FrameData& data = set.dataset.frames[i];
    const auto t0 = std::chrono::steady_clock::now();
    const cv::Mat predicted = label_frame(classifier, data, opt, frame);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const cv::Mat truth(data.height, data.width, CV_8UC1, const_cast<std::uint8_t*>(data.labels));
    FrameResult fr;
    fr.work = works[work_index].string();
    fr.frame = frame;
    fr.confusion = Confusion(C);
    fr.confusion.add(truth, predicted);
    fr.seconds = secs;
    total_seconds += secs;
    result.confusion.merge(fr.confusion);
    result.frames.push_back(std::move(fr));

    if (!opt.pictures.empty()) {
      const features::Sequence& seq = *sequences[work_index];
      const cv::Mat input = seq.load_left(frame);
      const cv::Mat coloured = features::colour_labels(predicted, seq);
      const cv::Mat truth_coloured = features::colour_labels(truth, seq);
      const std::string base = (set.manifests.size() > 1 ? seq.name + "_" : std::string()) + stem(frame);
      features::write_image_atomic(opt.pictures / (base + "_labels.png"), coloured);
      features::write_image_atomic(opt.pictures / (base + "_overlay.png"), overlay(input, coloured));
      features::write_image_atomic(opt.pictures / (base + "_error.png"), error_map(input, truth, predicted));
      features::write_image_atomic(opt.pictures / (base + "_montage.png"),
                                   side_by_side({input, truth_coloured, coloured}));
    }
    progress.tick();
  }
  progress.finish();
  result.seconds_per_frame = total_seconds / double(set.stacks.size());
  return result;
}

nlohmann::json EvalResult::to_json(const forest::Forest& forest, const EvalOptions& opt,
                                   const std::vector<std::string>& works) const {
  using nlohmann::json;
  const auto num = [](double v) { return std::isnan(v) ? json(nullptr) : json(v); };
  json per_frame = json::array();
  std::vector<double> accs;
  for (const auto& f : frames) {
    per_frame.push_back({{"work", f.work},
                         {"frame", f.frame},
                         {"global_accuracy", num(f.confusion.global_accuracy())},
                         {"class_average_accuracy", num(f.confusion.class_average_accuracy())},
                         {"mean_iou", num(f.confusion.mean_iou())},
                         {"pixels", f.confusion.total()},
                         {"seconds", f.seconds}});
    if (!std::isnan(f.confusion.global_accuracy())) accs.push_back(f.confusion.global_accuracy());
  }
  json spread = nullptr;
  if (!accs.empty()) {
    std::sort(accs.begin(), accs.end());
    double mean = 0, var = 0;
    for (double a : accs) mean += a;
    mean /= double(accs.size());
    for (double a : accs) var += (a - mean) * (a - mean);
    var /= double(accs.size());
    spread = {{"min", accs.front()}, {"max", accs.back()}, {"median", accs[accs.size() / 2]},
              {"mean", mean}, {"std", std::sqrt(var)}};
  }
  json per_class = json::array();
  const auto rec = confusion.recall();
  const auto iou = confusion.iou();
  for (std::size_t c = 0; c < forest.classes.size(); ++c)
    per_class.push_back({{"class", forest.classes[c]}, {"accuracy", num(rec[c])}, {"iou", num(iou[c])},
                         {"pixels", confusion.row_total(static_cast<int>(c))}});
  int nodes = 0;
  for (const auto& t : forest.stats.trees) nodes += t.nodes;
  return {{"format", "smseg-results"},
          {"version", 1},
          {"global_accuracy", num(confusion.global_accuracy())},
          {"class_average_accuracy", num(confusion.class_average_accuracy())},
          {"mean_iou", num(confusion.mean_iou())},
          {"classes", forest.classes},
          {"per_class", per_class},
          {"confusion", {{"counts", confusion.counts_json()}, {"normalised", confusion.normalised_json()}}},
          {"per_frame", per_frame},
          {"accuracy_spread", spread},
          {"seconds_per_frame", seconds_per_frame},
          {"params",
           {{"works", works},
            {"test_frames", opt.frames.str()},
            {"mode", opt.grid > 0 ? "grid" : "pixel"},
            {"grid", opt.grid},
            {"votes", opt.grid > 0 ? json(opt.votes) : json(nullptr)},
            {"seed", opt.seed}}},
          {"forest",
           {{"params", forest::params_to_json(forest.params)},
            {"features", forest.features},
            {"trees", forest.trees.size()},
            {"nodes", nodes},
            {"training_seconds", forest.stats.seconds}}}};
}

}  // namespace smseg::eval
