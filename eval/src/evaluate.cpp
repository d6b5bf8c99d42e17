#include "smseg/eval/evaluate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include <opencv2/ximgproc/slic.hpp>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "smseg/common/names.hpp"
#include "smseg/common/options.hpp"
#include "smseg/eval/render.hpp"
#include "smseg/forest/classify.hpp"
#include "smseg/common/progress.hpp"

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

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Appends the voters of one region of n pixels to `out` as indices 0..n-1 into the region's pixels:
/// every pixel when V >= n, else V distinct ones by Floyd's algorithm from a generator keyed by
/// (seed, frame, region).
void draw_voters(int n, const EvalOptions& opt, int frame_index, int region, std::vector<int>& out) {
  out.clear();
  if (opt.votes >= n) {
    for (int i = 0; i < n; ++i) out.push_back(i);
    return;
  }
  std::uint64_t key = mix(opt.seed ^ mix(std::uint64_t(frame_index) * 1000003ull + std::uint64_t(region)));
  for (int j = n - opt.votes; j < n; ++j) {
    key = mix(key);
    const int t = static_cast<int>(key % std::uint64_t(j + 1));
    out.push_back(std::find(out.begin(), out.end(), t) == out.end() ? t : j);
  }
}

/// Classifies the voters (pixels[first[r] .. first[r+1]) of region r) and returns each region's class
/// (255 for a region without voters).
std::vector<std::uint8_t> tally(const forest::Classifier& classifier, const forest::FrameData& frame,
                                const std::vector<forest::Pixel>& pixels, const std::vector<std::size_t>& first,
                                VoteRule rule) {
  const int C = classifier.num_classes();
  const std::size_t regions = first.size() - 1;
  std::vector<std::uint8_t> labels(pixels.size());
  std::vector<float> dists(rule == VoteRule::Sum ? pixels.size() * std::size_t(C) : 0);
  // One call: the classifier cuts the voters into sets for the threads itself.
  classifier.classify_pixels(frame, pixels, labels, dists);
  std::vector<std::uint8_t> winner(regions, 255);
  std::vector<double> sum(static_cast<std::size_t>(C));
  for (std::size_t r = 0; r < regions; ++r) {
    if (first[r] == first[r + 1]) continue;
    std::fill(sum.begin(), sum.end(), 0.0);
    for (std::size_t v = first[r]; v < first[r + 1]; ++v) {
      if (rule == VoteRule::Sum) {
        for (int c = 0; c < C; ++c) sum[std::size_t(c)] += dists[v * std::size_t(C) + std::size_t(c)];
      } else {
        sum[labels[v]] += 1.0;
      }
    }
    winner[r] = static_cast<std::uint8_t>(std::max_element(sum.begin(), sum.end()) - sum.begin());
  }
  return winner;
}

/// Touches every page of a frame's memory-mapped tables and images, so that the timed classification
/// measures classification, not reading the stack from disk.
void prefault(const forest::FrameData& frame) {
  volatile double sink = 0;
  const std::size_t sat_size = std::size_t(frame.width + 1) * std::size_t(frame.height + 1);
  constexpr std::size_t kStep = 4096 / sizeof(double);
  for (const double* sat : frame.sats) {
    for (std::size_t i = 0; i < sat_size; i += kStep) sink = sink + sat[i];
    sink = sink + sat[sat_size - 1];
  }
  const std::size_t n = std::size_t(frame.width) * std::size_t(frame.height);
  for (const std::uint8_t* img : {frame.gray, frame.labels})
    if (img)
      for (std::size_t i = 0; i < n; i += 4096) sink = sink + img[i];
}

}  // namespace

constexpr std::array<EnumName<VoteRule>, 2> kVoteRuleNames{{{VoteRule::Sum, "sum"}, {VoteRule::Majority, "majority"}}};

std::string to_string(VoteRule v) { return name_of(kVoteRuleNames, v); }
VoteRule vote_rule_from_string(const std::string& s, const std::string& option) {
  return value_named(kVoteRuleNames, s, option);
}

int superpixels_from_string(const std::string& s, const std::string& option) {
  if (s == "small") return kSmallSuperpixels;
  if (s == "large") return kLargeSuperpixels;
  std::size_t used = 0;
  int n = 0;
  try {
    n = std::stoi(s, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != s.size() || n < 4 || n > 1000)
    throw Error("", option, "\"" + s + "\" is not small, large or a region size of 4..1000 pixels");
  return n;
}

void EvalOptions::validate() const {
  if (grid < 0 || grid > 10000) throw Error("", "--grid", "must be 0 (no grid) or a cell size of 1..10000 pixels");
  if (superpixels != 0 && (superpixels < 4 || superpixels > 1000))
    throw Error("", "--superpixels", "region size must be 4..1000 pixels");
  if (grid > 0 && superpixels > 0) throw Error("", "--superpixels", "cannot be combined with --grid");
  if (votes < 1) throw Error("", "--votes", "must be at least 1 (the region's size or more: every pixel votes)");
  if (trees < 0) throw Error("", "--trees", "must be 0 (every tree) or a number of trees");
  if (tolerance < 0 || tolerance > 1000) throw Error("", "--tolerance", "must be 0..1000 pixels");
  if (!(prior_power >= 0 && prior_power <= 4)) throw Error("", "--prior-power", "must be 0..4");
  smooth.validate();
  if (smooth.enabled() && voting()) throw Error("", "--smooth", "smooths the per-pixel output: no --grid or --superpixels");
}

forest::Classifier make_classifier(const forest::Forest& forest, const EvalOptions& opt) {
  if (opt.prior_power == 0) return forest::Classifier(opt.trees > 0 ? first_trees(forest, opt.trees) : forest);
  const std::vector<double> weights = forest::prior_correction(forest, opt.prior_power);
  return forest::Classifier(opt.trees > 0 ? first_trees(forest, opt.trees) : forest, weights);
}

forest::Forest first_trees(const forest::Forest& forest, int m, const std::string& option) {
  if (m < 1 || m > static_cast<int>(forest.trees.size()))
    throw Error("", option, std::to_string(m) + " trees asked, the forest has " + std::to_string(forest.trees.size()));
  forest::Forest f = forest;
  f.trees.resize(static_cast<std::size_t>(m));
  f.stats.trees.resize(std::min(f.stats.trees.size(), static_cast<std::size_t>(m)));
  return f;
}

cv::Mat superpixels(const cv::Mat& gray, int region_size, int* count) {
  CV_Assert(gray.type() == CV_8UC1 && !gray.empty());
  cv::Ptr<cv::ximgproc::SuperpixelSLIC> slic =
      cv::ximgproc::createSuperpixelSLIC(gray, cv::ximgproc::SLICO, region_size, 10.0f);
  slic->iterate(10);
  slic->enforceLabelConnectivity(25);
  cv::Mat ids;
  slic->getLabels(ids);
  double lo = 0, hi = 0;
  cv::minMaxLoc(ids, &lo, &hi);
  if (lo < 0) throw Error("", "superpixels", "SLIC returned a negative region id");
  if (count) *count = static_cast<int>(hi) + 1;
  return ids;
}

cv::Mat vote_regions(const forest::Classifier& classifier, const forest::FrameData& frame, const cv::Mat& regions,
                     int count, const EvalOptions& opt, int frame_index) {
  CV_Assert(regions.type() == CV_32SC1 && regions.rows == frame.height && regions.cols == frame.width);
  // Each region's pixels in raster order (counting sort by id).
  std::vector<std::size_t> start(std::size_t(count) + 1, 0);
  for (int y = 0; y < regions.rows; ++y) {
    const std::int32_t* id = regions.ptr<std::int32_t>(y);
    for (int x = 0; x < regions.cols; ++x) {
      if (id[x] < 0 || id[x] >= count) throw Error("", "regions", "region id outside 0.." + std::to_string(count - 1));
      ++start[std::size_t(id[x]) + 1];
    }
  }
  for (std::size_t r = 0; r < std::size_t(count); ++r) start[r + 1] += start[r];
  std::vector<forest::Pixel> members(start.back());
  {
    std::vector<std::size_t> next(start.begin(), start.end() - 1);
    for (int y = 0; y < regions.rows; ++y) {
      const std::int32_t* id = regions.ptr<std::int32_t>(y);
      for (int x = 0; x < regions.cols; ++x) members[next[std::size_t(id[x])]++] = {x, y};
    }
  }
  std::vector<forest::Pixel> voters;
  std::vector<std::size_t> first(std::size_t(count) + 1, 0);
  std::vector<int> chosen;
  for (int r = 0; r < count; ++r) {
    const int n = static_cast<int>(start[std::size_t(r) + 1] - start[std::size_t(r)]);
    if (n > 0) {
      draw_voters(n, opt, frame_index, r, chosen);
      for (int i : chosen) voters.push_back(members[start[std::size_t(r)] + std::size_t(i)]);
    }
    first[std::size_t(r) + 1] = voters.size();
  }
  const std::vector<std::uint8_t> winner = tally(classifier, frame, voters, first, opt.vote);
  cv::Mat labels(frame.height, frame.width, CV_8UC1);
  for (int y = 0; y < regions.rows; ++y) {
    const std::int32_t* id = regions.ptr<std::int32_t>(y);
    std::uint8_t* out = labels.ptr<std::uint8_t>(y);
    for (int x = 0; x < regions.cols; ++x) out[x] = winner[std::size_t(id[x])];
  }
  return labels;
}

cv::Mat label_frame(const forest::Classifier& classifier, const forest::FrameData& frame, const EvalOptions& opt,
                    int frame_index, LabelTimes* times) {
  LabelTimes t;
  cv::Mat labels;
  if (opt.superpixels > 0) {
    if (!frame.gray) throw Error("", "--superpixels", "the frame has no greyscale image to cut into superpixels");
    auto t0 = std::chrono::steady_clock::now();
    const cv::Mat gray(frame.height, frame.width, CV_8UC1, const_cast<std::uint8_t*>(frame.gray));
    int count = 0;
    const cv::Mat regions = superpixels(gray, opt.superpixels, &count);
    t.regions = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    labels = vote_regions(classifier, frame, regions, count, opt, frame_index);
    t.classify = seconds_since(t0);
  } else if (opt.smooth.enabled()) {
    labels = smooth_frame(classifier, frame, opt.smooth, &t.classify, &t.smooth);
  } else if (opt.grid <= 0) {
    const auto t0 = std::chrono::steady_clock::now();
    labels.create(frame.height, frame.width, CV_8UC1);
    classifier.classify_frame(frame, std::span<std::uint8_t>(labels.data, labels.total()));
    t.classify = seconds_since(t0);
  } else {
    // Grid: cells in raster order; a cell's pixels in raster order (the same draws as vote_regions
    // would make on the grid's region map, without building it).
    const auto t0 = std::chrono::steady_clock::now();
    const int B = opt.grid;
    const int cells_x = (frame.width + B - 1) / B, cells_y = (frame.height + B - 1) / B;
    const int cells = cells_x * cells_y;
    std::vector<forest::Pixel> voters;
    std::vector<std::size_t> first(std::size_t(cells) + 1, 0);
    voters.reserve(std::size_t(cells) * std::size_t(std::min(opt.votes, B * B)));
    std::vector<int> chosen;
    for (int cy = 0; cy < cells_y; ++cy)
      for (int cx = 0; cx < cells_x; ++cx) {
        const int cell = cy * cells_x + cx;
        const int x0 = cx * B, y0 = cy * B;
        const int w = std::min(B, frame.width - x0), h = std::min(B, frame.height - y0);
        draw_voters(w * h, opt, frame_index, cell, chosen);
        for (int i : chosen) voters.push_back({x0 + i % w, y0 + i / w});
        first[std::size_t(cell) + 1] = voters.size();
      }
    const std::vector<std::uint8_t> winner = tally(classifier, frame, voters, first, opt.vote);
    labels.create(frame.height, frame.width, CV_8UC1);
    for (int y = 0; y < frame.height; ++y) {
      std::uint8_t* row = labels.ptr<std::uint8_t>(y);
      const std::uint8_t* w = winner.data() + std::size_t(y / B) * std::size_t(cells_x);
      for (int cx = 0; cx < cells_x; ++cx)
        std::fill(row + cx * B, row + std::min(frame.width, (cx + 1) * B), w[cx]);
    }
    t.classify = seconds_since(t0);
  }
  if (times) *times = t;
  return labels;
}

void check_forest_fits(const forest::Forest& forest, const stacks::StackManifest& m) {
  forest::check_compatible(forest, m.classes, forest.features, m.manifest_path());
  if (forest.width != m.size.width || forest.height != m.size.height)
    throw Error(m.manifest_path().string(), "image_size",
                "stacks are " + std::to_string(m.size.width) + "x" + std::to_string(m.size.height) +
                    ", the forest was trained on " + std::to_string(forest.width) + "x" + std::to_string(forest.height));
}

void check_forest_fits(const forest::Forest& forest, const stacks::StackSet& set) {
  check_forest_fits(forest, set.manifests.front());
}

namespace {

/// Frames without a tracked point are labelled from the forest's class prior alone: scores on them say
/// nothing of the features. None with a point stops the run (a camera that does not move, blank frames);
/// some without: returned as a warning for the user (empty when every frame has points).
std::string check_points(const stacks::StackSet& set) {
  const auto empty = stacks::frames_without_points(set);
  if (empty.empty()) return {};
  const std::string which = stacks::frames_without_points_message(set, empty);
  if (empty.size() == set.dataset.frames.size())
    throw Error("", "", which + ": no test frame holds a tracked point (a camera that does not move? blank frames?), "
                                "so the scores would say nothing of the forest");
  return which;
}

/// How many frames evaluate() labels at once. With --smooth, one per thread: a frame's classification
/// is parallel but its smoothing runs on one thread, so one frame at a time leaves the other cores idle
/// for most of the frame. Otherwise one (classification alone keeps every core busy).
std::size_t frames_in_flight(const EvalOptions& opt) {
  if (!opt.smooth.enabled()) return 1;
  const std::size_t allowed = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  return std::max<std::size_t>(1, std::min(allowed, static_cast<std::size_t>(tbb::this_task_arena::max_concurrency())));
}

/// Labels frames [first, first + count) of the set (fewer at the end), in parallel: labels[k] and
/// times[k] for frame first + k. Each frame's labels are what label_frame gives it alone.
void label_batch(const forest::Classifier& classifier, const stacks::StackSet& set, const EvalOptions& opt,
                 std::size_t first, std::size_t count, std::vector<cv::Mat>& labels, std::vector<LabelTimes>& times) {
  const std::size_t n = std::min(count, set.stacks.size() - first);
  labels.assign(n, cv::Mat());
  times.assign(n, LabelTimes{});
  for (std::size_t k = 0; k < n; ++k) prefault(set.dataset.frames[first + k]);
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t k) {
    labels[k] = label_frame(classifier, set.dataset.frames[first + k], opt, set.origin[first + k].second, &times[k]);
  });
}

}  // namespace

EvalResult evaluate(const forest::Forest& forest, const std::vector<fs::path>& works, const EvalOptions& opt) {
  opt.validate();
  stacks::StackSet set = stacks::open_stacks(works, opt.frames, true, true, forest.features);
  stacks::lighten_frames(set, forest.params.lightness);
  return evaluate(forest, set, works, opt);
}

EvalResult evaluate(const forest::Forest& forest, const stacks::StackSet& set, const std::vector<fs::path>& works,
                    const EvalOptions& opt) {
  opt.validate();
  check_forest_fits(forest, set);
  const std::string without_points = check_points(set);
  if (opt.costs && opt.costs->classes != forest.classes)
    throw Error(opt.costs_file, "classes", "the cost matrix was not made for this forest's classes");
  const forest::Classifier classifier = make_classifier(forest, opt);
  const int C = static_cast<int>(forest.classes.size());

  // Pictures need the sequences (input images, class colours).
  std::vector<std::optional<sequence::Sequence>> sequences(set.manifests.size());
  if (!opt.pictures.empty())
    for (std::size_t k = 0; k < set.manifests.size(); ++k) sequences[k] = sequence::load_sequence(set.manifests[k].sequence);

  EvalResult result;
  result.frames_without_points = without_points;
  result.confusion = Confusion(C);
  Progress progress("eval-forest", static_cast<long>(set.stacks.size()), opt.progress);
  double total_seconds = 0, total_regions = 0, total_smooth = 0;
  const std::size_t in_flight = frames_in_flight(opt);
  std::vector<cv::Mat> batch_labels;
  std::vector<LabelTimes> batch_times;
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < set.stacks.size(); ++i) {
    const auto [work_index, frame] = set.origin[i];
    const forest::FrameData& data = set.dataset.frames[i];
    if (i % in_flight == 0) label_batch(classifier, set, opt, i, in_flight, batch_labels, batch_times);
    const LabelTimes& times = batch_times[i % in_flight];
    const cv::Mat& predicted = batch_labels[i % in_flight];
    const cv::Mat truth(data.height, data.width, CV_8UC1, const_cast<std::uint8_t*>(data.labels));
    FrameResult fr;
    fr.work = works[work_index].string();
    fr.frame = frame;
    fr.confusion = Confusion(C);
    fr.confusion.add(truth, predicted);
    fr.near_misses = near_misses(truth, predicted, opt.tolerance);
    fr.seconds = times.classify;
    fr.superpixel_seconds = times.regions;
    fr.smooth_seconds = times.smooth;
    fr.boundary = boundary_counts(truth, predicted, opt.tolerance);
    result.boundary.merge(fr.boundary);
    total_smooth += times.smooth;
    total_seconds += times.classify;
    total_regions += times.regions;
    result.confusion.merge(fr.confusion);
    result.near_misses += fr.near_misses;
    result.frames.push_back(std::move(fr));

    if (!opt.pictures.empty()) {
      const sequence::Sequence& seq = *sequences[work_index];
      const cv::Mat input = seq.load_left(frame);
      const cv::Mat coloured = sequence::colour_labels(predicted, seq);
      const cv::Mat truth_coloured = sequence::colour_labels(truth, seq);
      const std::string base = (set.manifests.size() > 1 ? seq.name + "_" : std::string()) + stem(frame);
      sequence::write_image_atomic(opt.pictures / (base + "_labels.png"), coloured);
      sequence::write_image_atomic(opt.pictures / (base + "_overlay.png"), overlay(input, coloured));
      sequence::write_image_atomic(opt.pictures / (base + "_error.png"), error_map(input, truth, predicted));
      sequence::write_image_atomic(opt.pictures / (base + "_montage.png"),
                                   side_by_side({input, truth_coloured, coloured}));
    }
    progress.tick();
  }
  progress.finish();
  result.frames_in_flight = static_cast<int>(in_flight);
  result.wall_seconds_per_frame = seconds_since(start) / double(set.stacks.size());
  result.seconds_per_frame = total_seconds / double(set.stacks.size());
  result.superpixel_seconds_per_frame = total_regions / double(set.stacks.size());
  result.smooth_seconds_per_frame = total_smooth / double(set.stacks.size());
  return result;
}

double EvalResult::tolerant_accuracy() const {
  const auto total = confusion.total();
  if (total == 0) return std::nan("");
  std::int64_t right = 0;
  for (int c = 0; c < confusion.classes(); ++c) right += confusion.at(c, c);
  return double(right + near_misses) / double(total);
}

namespace {

using nlohmann::json;

json number_or_null(double v) { return std::isnan(v) ? json(nullptr) : json(v); }

// One frame's scores and times in results.json.
json frame_json(const FrameResult& f, const EvalOptions& opt) {
  const auto total = f.confusion.total();
  double right = 0;
  for (int c = 0; c < f.confusion.classes(); ++c) right += double(f.confusion.at(c, c));
  json rec = {{"work", f.work},
              {"frame", f.frame},
              {"global_accuracy", number_or_null(f.confusion.global_accuracy())},
              {"class_average_accuracy", number_or_null(f.confusion.class_average_accuracy())},
              {"mean_iou", number_or_null(f.confusion.mean_iou())},
              {"boundary_tolerant_accuracy", number_or_null(total ? (right + double(f.near_misses)) / double(total) : NAN)},
              {"pixels", total},
              {"seconds", f.seconds},
              {"superpixel_seconds", f.superpixel_seconds},
              {"smooth_seconds", f.smooth_seconds},
              {"boundary_f1", number_or_null(f.boundary.f1())}};
  if (opt.costs) rec["mean_cost"] = number_or_null(mean_cost(f.confusion, *opt.costs));
  return rec;
}

// Min, max, median, mean and standard deviation of the frames' global accuracies (null without any).
json accuracy_spread(std::vector<double> accs) {
  if (accs.empty()) return nullptr;
  std::sort(accs.begin(), accs.end());
  double mean = 0, var = 0;
  for (double a : accs) mean += a;
  mean /= double(accs.size());
  for (double a : accs) var += (a - mean) * (a - mean);
  var /= double(accs.size());
  const std::size_t n = accs.size();
  const double median = n % 2 ? accs[n / 2] : 0.5 * (accs[n / 2 - 1] + accs[n / 2]);
  return {{"min", accs.front()}, {"max", accs.back()}, {"median", median}, {"mean", mean}, {"std", std::sqrt(var)}};
}

json per_class_json(const Confusion& confusion, const std::vector<std::string>& classes) {
  json per_class = json::array();
  const auto rec = confusion.recall();
  const auto iou = confusion.iou();
  for (std::size_t c = 0; c < classes.size(); ++c)
    per_class.push_back({{"class", classes[c]}, {"accuracy", number_or_null(rec[c])}, {"iou", number_or_null(iou[c])},
                         {"pixels", confusion.row_total(static_cast<int>(c))}});
  return per_class;
}

// How the evaluation ran: the options as declared (eval_options_table) where they ran as given; the
// voting's only when voting, the trees used, the region size as a number, the smoothing as one object.
json params_json(const forest::Forest& forest, const EvalOptions& opt, const std::vector<std::string>& works) {
  const auto declared = [&opt](const char* key) { return eval_options_table().find(key)->write(opt); };
  json j = {{"works", works},
            {"test_frames", opt.frames.str()},
            {"mode", opt.mode()},
            {"superpixels", opt.superpixels > 0 ? json(opt.superpixels) : json(nullptr)},
            {"trees", opt.trees > 0 ? opt.trees : static_cast<int>(forest.trees.size())},
            {"costs", opt.costs ? json(opt.costs_file) : json(nullptr)},
            {"smooth", opt.smooth.to_json()}};
  for (const char* key : {"grid", "tolerance", "seed"}) j[key] = declared(key);
  for (const char* key : {"votes", "vote"}) j[key] = opt.voting() ? declared(key) : json(nullptr);
  if (opt.prior_power != 0) j["prior_power"] = declared("prior_power");  // absent: none (as older results)
  return j;
}

json forest_json(const forest::Forest& forest) {
  int nodes = 0;
  for (const auto& t : forest.stats.trees) nodes += t.nodes;
  return {{"params", forest::params_to_json(forest.params)},
          {"image", {{"width", forest.width}, {"height", forest.height}}},
          {"classes", forest.classes},
          {"features", forest.features},
          {"textons", forest.textons},
          {"trees", forest.trees.size()},
          {"nodes", nodes},
          {"training_seconds", forest.stats.seconds}};
}

}  // namespace

nlohmann::json EvalResult::to_json(const forest::Forest& forest, const EvalOptions& opt,
                                   const std::vector<std::string>& works) const {
  json per_frame = json::array();
  std::vector<double> accs;
  for (const auto& f : frames) {
    per_frame.push_back(frame_json(f, opt));
    if (!std::isnan(f.confusion.global_accuracy())) accs.push_back(f.confusion.global_accuracy());
  }
  json j = {{"format", "smseg-results"},
            {"version", 1},
            {"global_accuracy", number_or_null(confusion.global_accuracy())},
            {"class_average_accuracy", number_or_null(confusion.class_average_accuracy())},
            {"mean_iou", number_or_null(confusion.mean_iou())},
            {"boundary_tolerant_accuracy", number_or_null(tolerant_accuracy())},
            {"mean_cost", opt.costs ? number_or_null(mean_cost(confusion, *opt.costs)) : json(nullptr)},
            {"classes", forest.classes},
            {"per_class", per_class_json(confusion, forest.classes)},
            {"confusion", {{"counts", confusion.counts_json()}, {"normalised", confusion.normalised_json()}}},
            {"per_frame", per_frame},
            {"accuracy_spread", accuracy_spread(accs)},
            {"seconds_per_frame", seconds_per_frame},
            {"superpixel_seconds_per_frame", superpixel_seconds_per_frame},
            {"smooth_seconds_per_frame", smooth_seconds_per_frame},
            {"wall_seconds_per_frame", wall_seconds_per_frame},
            {"boundary_f1", number_or_null(boundary.f1())},
            {"boundary_precision", number_or_null(boundary.precision())},
            {"boundary_recall", number_or_null(boundary.recall())},
            {"frames_without_points", frames_without_points.empty() ? json(nullptr) : json(frames_without_points)},
            {"params", params_json(forest, opt, works)},
            {"forest", forest_json(forest)}};
  if (opt.costs) j["costs"] = {{"classes", opt.costs->classes}, {"matrix", opt.costs->cost}};
  return j;
}

}  // namespace smseg::eval
