// Speed of the forest (libforest): training (corpus construction included) and whole-frame
// classification on synthetic 320x240 frames with 6 features (smooth random fields whose level
// depends on a room-like label layout), and CamVid-sized 480x360 frames. Targets (issue): train K = 400, M = 7 on 11 frames <= 0.5 s
// and K = 900 <= 2 s on 2 cores; classify a 320x240 frame with M = 7, K = 400 <= 10 ms.
// The CamVid cases (camvid_setup.hpp) train a CamVid-size forest on the 101 frames of CamVid val
// (Ks = 400, Kt = 20 000, M = 7; counters: nodes, the process's peak resident memory so far) and
// classify a 480x360 val frame with it.
// BM_Simd times the classifier's SIMD targets one by one on this machine (classify.hpp: scalar, avx2,
// avx512; the same labels on each), per pixel and grid voting (B = 20, V = 6 voters), on the synthetic
// 320x240 forest and the CamVid-size one; a target the processor lacks is skipped with a message.
// SMSEG_SIMD does the same for every other case (and for bench_eval).
// Run: bench_forest --benchmark_out=forest.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <algorithm>
#include <map>
#include <numeric>
#include <random>
#include <string>
#include <tuple>

#include <sys/resource.h>

#include <oneapi/tbb/global_control.h>

#include "camvid_setup.hpp"
#include "smseg/stacks/stack.hpp"

#include "smseg/forest/classify.hpp"
#include "smseg/forest/synthetic.hpp"
#include "smseg/forest/train.hpp"

using namespace smseg::forest;

namespace {

// Class signal of the synthetic features relative to their noise: low enough that trees grow to a
// realistic size (a few hundred nodes at K = 400) instead of separating the classes at once.
constexpr double kSignal = 0.25;

const SyntheticData& training_frames() {
  static const SyntheticData s = [] {
    SyntheticOptions o;
    o.frames = 11;
    o.seed = 7;
    o.signal = kSignal;
    return make_synthetic(o);
  }();
  return s;
}

const SyntheticData& test_frame() {
  static const SyntheticData s = [] {
    SyntheticOptions o;
    o.frames = 1;
    o.seed = 99;
    o.signal = kSignal;
    return make_synthetic(o);
  }();
  return s;
}

// CamVid-sized (480x360) frames: 11 to train on, one to classify.
const SyntheticData& frames_480(bool training) {
  static const SyntheticData train = [] {
    SyntheticOptions o;
    o.width = 480;
    o.height = 360;
    o.frames = 11;
    o.seed = 7;
    o.signal = kSignal;
    return make_synthetic(o);
  }();
  static const SyntheticData test = [] {
    SyntheticOptions o;
    o.width = 480;
    o.height = 360;
    o.frames = 1;
    o.seed = 99;
    o.signal = kSignal;
    return make_synthetic(o);
  }();
  return training ? train : test;
}

void add_forest_counters(benchmark::State& state, const Forest& f) {
  double nodes = 0, depth = 0;
  for (const auto& t : f.stats.trees) {
    nodes += t.nodes;
    depth += t.depth;
  }
  state.counters["nodes_per_tree"] = nodes / static_cast<double>(f.stats.trees.size());
  state.counters["max_depth_mean"] = depth / static_cast<double>(f.stats.trees.size());
}

// Times train_forest(data, p) on `threads` workers; the forest's size as counters.
void time_training(benchmark::State& state, const Dataset& data, const TrainParams& p, std::int64_t threads) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  Forest f;
  for (auto _ : state) {
    f = train_forest(data, p);
    benchmark::DoNotOptimize(f.trees.data());
  }
  add_forest_counters(state, f);
}

// Args: K, threads, textons, balance(0/1), window mode (0 uniform, 1 thesis)
void BM_Train(benchmark::State& state) {
  const auto& s = training_frames();
  TrainParams p;
  p.K = static_cast<int>(state.range(0));
  p.M = 7;
  p.textons = state.range(2) != 0;
  p.balance = state.range(3) ? Balance::Classes : Balance::None;
  p.windows.mode = state.range(4) ? WindowSampling::Thesis : WindowSampling::Uniform;
  time_training(state, s.data, p, state.range(1));
}
BENCHMARK(BM_Train)
    ->ArgNames({"K", "threads", "textons", "balance", "windows"})
    ->Args({400, 2, 0, 0, 0})
    ->Args({400, 1, 0, 0, 0})
    ->Args({900, 2, 0, 0, 0})
    ->Args({400, 2, 1, 0, 0})
    ->Args({400, 2, 0, 1, 0})
    ->Args({400, 2, 0, 0, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

const Forest& forest_k(int K, bool textons, int width) {
  static std::map<std::tuple<int, bool, int>, Forest> cache;
  auto it = cache.find({K, textons, width});
  if (it == cache.end()) {
    TrainParams p;
    p.K = K;
    p.M = 7;
    p.textons = textons;
    const Dataset& d = width == 480 ? frames_480(true).data : training_frames().data;
    it = cache.emplace(std::make_tuple(K, textons, width), train_forest(d, p)).first;
  }
  return it->second;
}

// Args: K, threads, with distributions (0/1), textons (0/1), width (320: 320x240, 480: 480x360)
void BM_ClassifyFrame(benchmark::State& state) {
  const int width = static_cast<int>(state.range(4));
  const Forest& f = forest_k(static_cast<int>(state.range(0)), state.range(3) != 0, width);
  const Classifier clf(f);
  const auto& s = width == 480 ? frames_480(false) : test_frame();
  std::vector<std::uint8_t> labels(static_cast<std::size_t>(s.data.width) * s.data.height);
  std::vector<float> dists(state.range(2) ? labels.size() * f.classes.size() : 0);
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(1)));
  for (auto _ : state) {
    clf.classify_frame(s.data.frames[0], labels, dists);
    benchmark::DoNotOptimize(labels.data());
  }
  std::size_t right = 0, counted = 0;
  for (std::size_t i = 0; i < labels.size(); ++i)
    if (s.labels[0][i] != kVoidLabel) {
      ++counted;
      right += labels[i] == s.labels[0][i];
    }
  state.counters["accuracy"] = static_cast<double>(right) / static_cast<double>(counted);
  state.counters["pixels_per_s"] = benchmark::Counter(static_cast<double>(labels.size()), benchmark::Counter::kIsIterationInvariantRate);
  add_forest_counters(state, f);
}
BENCHMARK(BM_ClassifyFrame)
    ->ArgNames({"K", "threads", "dists", "textons", "width"})
    ->Args({400, 2, 0, 0, 320})
    ->Args({400, 1, 0, 0, 320})
    ->Args({400, 2, 1, 0, 320})
    ->Args({900, 2, 0, 0, 320})
    ->Args({400, 2, 0, 1, 320})
    ->Args({400, 2, 0, 0, 480})
    ->Args({400, 1, 0, 0, 480})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Balance: accuracy (global and class-average) on held-out frames, with and without per-class test
// sampling; the synthetic box class covers few pixels. Args: balance (0/1). Counters, not time,
// are the point here.
void BM_BalanceAccuracy(benchmark::State& state) {
  TrainParams p;
  p.K = 400;
  p.balance = state.range(0) ? Balance::Classes : Balance::None;
  static const SyntheticData held_out = [] {
    SyntheticOptions o;
    o.frames = 5;
    o.seed = 1234;
    o.signal = kSignal;
    return make_synthetic(o);
  }();
  Forest f;
  for (auto _ : state) f = train_forest(training_frames().data, p);
  const Classifier clf(f);
  const std::size_t C = f.classes.size();
  std::vector<double> right(C, 0.0), total(C, 0.0);
  std::vector<std::uint8_t> labels(static_cast<std::size_t>(held_out.data.width) * held_out.data.height);
  for (std::size_t fi = 0; fi < held_out.data.frames.size(); ++fi) {
    clf.classify_frame(held_out.data.frames[fi], labels);
    for (std::size_t i = 0; i < labels.size(); ++i) {
      const auto l = held_out.labels[fi][i];
      if (l == kVoidLabel) continue;
      total[l] += 1;
      right[l] += labels[i] == l;
    }
  }
  double g = 0, n = 0, ca = 0;
  for (std::size_t c = 0; c < C; ++c) {
    g += right[c];
    n += total[c];
    ca += total[c] > 0 ? right[c] / total[c] : 0.0;
    state.counters["recall_" + f.classes[c]] = total[c] > 0 ? right[c] / total[c] : 0.0;
  }
  state.counters["global"] = g / n;
  state.counters["class_average"] = ca / static_cast<double>(C);
}
/// Skips the state when CamVid is absent; true when the CamVid cases can run.
bool camvid_available(benchmark::State& state) {
  static const std::optional<std::string> why = camvid_bench::unavailable();
  if (why) state.SkipWithError(why->c_str());
  return !why;
}

double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

// Training a CamVid-size forest on CamVid val (101 frames). Args: threads, memory budget in MB.
void BM_TrainCamVid(benchmark::State& state) {
  if (!camvid_available(state)) return;
  const smseg::stacks::StackSet set = smseg::stacks::open_stacks({camvid_bench::val_work()}, smseg::stacks::FrameRange{}, true, true, {});
  TrainParams p;
  p.K = 400;
  p.Kt = 20000;
  p.M = 7;
  p.memory_mb = static_cast<std::size_t>(state.range(1));
  time_training(state, set.dataset, p, state.range(0));
  state.counters["process_peak_rss_mb"] = peak_rss_mb();
}
BENCHMARK(BM_TrainCamVid)
    ->ArgNames({"threads", "memory_mb"})
    ->Args({2, 2048})
    ->Args({2, 1024})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

// The CamVid-size forest (camvid_setup.hpp) on val frame 50. Args: threads.
void BM_ClassifyFrameCamVid(benchmark::State& state) {
  if (!camvid_available(state)) return;
  static const Forest f = camvid_bench::val_forest();
  static const smseg::stacks::StackSet set =
      smseg::stacks::open_stacks({camvid_bench::val_work()}, smseg::stacks::FrameRange{50, 51}, false, false, f.features);
  const Classifier clf(f);
  const FrameData& frame = set.dataset.frames.front();
  std::vector<std::uint8_t> labels(static_cast<std::size_t>(frame.width) * frame.height);
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    clf.classify_frame(frame, labels);
    benchmark::DoNotOptimize(labels.data());
  }
  state.counters["pixels_per_s"] = benchmark::Counter(static_cast<double>(labels.size()), benchmark::Counter::kIsIterationInvariantRate);
  add_forest_counters(state, f);
}
BENCHMARK(BM_ClassifyFrameCamVid)->ArgNames({"threads"})->Arg(2)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK(BM_BalanceAccuracy)->ArgNames({"balance"})->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(1);

// Grid voting's voters (eval's --grid B --votes V): V pixels drawn uniformly in every B x B cell
// (seeded: the same voters every run).
std::vector<Pixel> grid_voters(int width, int height, int B, int V) {
  std::mt19937 rng(1);
  std::vector<Pixel> voters;
  for (int y0 = 0; y0 < height; y0 += B)
    for (int x0 = 0; x0 < width; x0 += B) {
      std::uniform_int_distribution<int> x(x0, std::min(width, x0 + B) - 1), y(y0, std::min(height, y0 + B) - 1);
      for (int v = 0; v < V; ++v) voters.push_back({x(rng), y(rng)});
    }
  return voters;
}

// One SIMD target on one frame: per pixel (grid false) or the grid's voters (B = 20, V = 6), on
// `threads` workers.
void time_target(benchmark::State& state, const Forest& f, const FrameData& frame, const std::string& target,
                 bool grid, int threads) {
  const std::vector<std::string> runs = Classifier::simd_targets();
  if (std::find(runs.begin(), runs.end(), target) == runs.end()) {
    state.SkipWithError(("this processor lacks the SIMD target " + target).c_str());
    return;
  }
  Classifier clf(f);
  clf.set_simd_target(target);
  const std::vector<Pixel> voters = grid ? grid_voters(frame.width, frame.height, 20, 6) : std::vector<Pixel>{};
  std::vector<std::uint8_t> labels(grid ? voters.size() : static_cast<std::size_t>(frame.width) * frame.height);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  for (auto _ : state) {
    if (grid)
      clf.classify_pixels(frame, voters, labels);
    else
      clf.classify_frame(frame, labels);
    benchmark::DoNotOptimize(labels.data());
  }
  state.counters["pixels"] = static_cast<double>(labels.size());
  state.SetLabel(target);
  add_forest_counters(state, f);
}

// The synthetic 320x240 case (K = 400, M = 7) or the CamVid-size one (camvid_setup.hpp, val frame 50).
void BM_Simd(benchmark::State& state, bool camvid, bool grid, const std::string& target, int threads) {
  if (!camvid) return time_target(state, forest_k(400, false, 320), test_frame().data.frames[0], target, grid, threads);
  if (!camvid_available(state)) return;
  static const Forest f = camvid_bench::val_forest();
  static const smseg::stacks::StackSet set =
      smseg::stacks::open_stacks({camvid_bench::val_work()}, smseg::stacks::FrameRange{50, 51}, false, false, f.features);
  time_target(state, f, set.dataset.frames.front(), target, grid, threads);
}

// BM_Simd/<size>/<mode>/simd:<target>/threads:<n>, every target for every size and mode.
const bool simd_cases = [] {
  for (const char* size : {"synthetic320", "camvid480"})
    for (const char* mode : {"per_pixel", "grid"})
      for (const char* target : {"scalar", "avx2", "avx512"})
        for (const int threads : {2, 1}) {
          const std::string name = std::string("BM_Simd/") + size + "/" + mode + "/simd:" + target + "/threads:" + std::to_string(threads);
          benchmark::RegisterBenchmark(name.c_str(), BM_Simd, std::string(size) == "camvid480", std::string(mode) == "grid",
                                       std::string(target), threads)
              ->Unit(benchmark::kMillisecond)
              ->UseRealTime();
        }
  return true;
}();

}  // namespace

BENCHMARK_MAIN();
