// Speed of evaluation (eval/): eval::label_frame on one 320x240 frame, per pixel, grid voting and
// superpixel voting (superpixel segmentation timed apart). Targets (evaluation issue), M = 7, K = 400
// forest on 2 cores: per pixel <= 10 ms per frame; grid B = 20, V = 6 <= 0.5 ms per frame. The
// cases with width 480 time CamVid-sized (480x360) synthetic frames with their own forest.
//
// By default the forest is trained in the benchmark on synthetic frames (libforest's make_synthetic:
// 6 smooth class-dependent feature fields, as bench_forest uses). To time a real forest and stacks:
//   SMSEG_BENCH_FOREST=work/forest.json SMSEG_BENCH_WORK=work SMSEG_BENCH_FRAME=110 bench_eval
// BM_LabelFrameCamVid times a CamVid-size forest (Kt = 20 000, ~2 700 nodes per tree, trained on
// CamVid val; camvid_setup.hpp) on a 480x360 val frame (issue "real scale": per pixel <= 20 ms,
// grid B = 20, V = 6 <= 1 ms on 2 cores).
// Run: bench_eval --benchmark_out=eval.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <memory>
#include <optional>

#include <oneapi/tbb/global_control.h>
#include <opencv2/core/utility.hpp>

#include "camvid_setup.hpp"
#include "synthetic_setup.hpp"
#include "smseg/eval/evaluate.hpp"
#include "smseg/forest/synthetic.hpp"
#include "smseg/forest/train.hpp"

using namespace smseg;

namespace {

struct Setup {
  forest::Forest forest;
  forest::SyntheticData synthetic;                 // synthetic mode: owns the frame
  std::optional<stacks::StackSet> stacks;        // env mode: owns the mappings
  forest::FrameData frame;
  int frame_index = 0;
  std::string source;
};

// Forest trained on 11 synthetic frames of this size, and one more frame to label (synthetic_setup.hpp).
Setup synthetic_setup(int width, int height) {
  Setup x;
  synthetic_bench::ForestAndFrame made = synthetic_bench::forest_and_frame(width, height);
  x.forest = std::move(made.forest);
  x.synthetic = std::move(made.frame);
  x.frame = x.synthetic.data.frames.front();
  x.source = "synthetic " + std::to_string(width) + "x" + std::to_string(height);
  return x;
}

const Setup& setup() {
  static const Setup* s = [] {
    const char* forest_file = std::getenv("SMSEG_BENCH_FOREST");
    const char* work = std::getenv("SMSEG_BENCH_WORK");
    if (forest_file && work) {
      auto* x = new Setup;
      x->forest = forest::load_forest(forest_file);
      const char* frame = std::getenv("SMSEG_BENCH_FRAME");
      x->frame_index = frame ? std::atoi(frame) : 0;
      x->stacks = stacks::open_stacks({work}, stacks::FrameRange{x->frame_index, x->frame_index + 1}, false,
                                        false, x->forest.features);
      eval::check_forest_fits(x->forest, *x->stacks);
      x->frame = x->stacks->dataset.frames.front();
      x->source = std::string(work);
      return x;
    }
    return new Setup(synthetic_setup(320, 240));
  }();
  return *s;
}

// CamVid-sized synthetic frames (480x360), whatever the environment says.
const Setup& setup_480() {
  static const Setup* s = new Setup(synthetic_setup(480, 360));
  return *s;
}

// The CamVid-size forest and val frame 50 of its run (camvid_setup.hpp); null when CamVid is absent.
const Setup* setup_camvid() {
  static const Setup* s = []() -> const Setup* {
    if (camvid_bench::unavailable()) return nullptr;
    auto* x = new Setup;
    x->forest = camvid_bench::val_forest();
    x->frame_index = 50;
    x->stacks = stacks::open_stacks({camvid_bench::val_work()}, stacks::FrameRange{50, 51}, false, false,
                                      x->forest.features);
    x->frame = x->stacks->dataset.frames.front();
    x->source = "CamVid val, forest Kt = 20000";
    return x;
  }();
  return s;
}

void counters(benchmark::State& state, const Setup& s) {
  double nodes = 0;
  for (const auto& t : s.forest.trees) nodes += static_cast<double>(t.nodes.size());
  state.counters["nodes_per_tree"] = nodes / static_cast<double>(s.forest.trees.size());
  state.counters["trees"] = static_cast<double>(s.forest.trees.size());
  state.counters["width"] = s.frame.width;
  state.counters["height"] = s.frame.height;
  state.SetLabel(s.source);
}

// Args (from state.range(first)): mode (0 per pixel, 1 grid, 2 superpixels), region size (B or SLIC
// size), V, threads.
void label_frame_case(benchmark::State& state, const Setup& s) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(3)));
  const forest::Classifier classifier(s.forest);
  eval::EvalOptions opt;
  if (state.range(0) == 1) opt.grid = static_cast<int>(state.range(1));
  if (state.range(0) == 2) opt.superpixels = static_cast<int>(state.range(1));
  opt.votes = static_cast<int>(state.range(2));
  double regions = 0, classify = 0;
  for (auto _ : state) {
    eval::LabelTimes t;
    cv::Mat labels = eval::label_frame(classifier, s.frame, opt, s.frame_index, &t);
    benchmark::DoNotOptimize(labels.data);
    regions += t.regions;
    classify += t.classify;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["classify_ms"] = 1000 * classify / n;
  state.counters["superpixels_ms"] = 1000 * regions / n;
  counters(state, s);
}

// Args: mode, size, V, threads (label_frame_case),
// width (320: the default setup, synthetic 320x240 or the environment's; 480: synthetic 480x360)
void BM_LabelFrame(benchmark::State& state) {
  label_frame_case(state, state.range(4) == 480 ? setup_480() : setup());
}
BENCHMARK(BM_LabelFrame)
    ->ArgNames({"mode", "size", "V", "threads", "width"})
    ->Args({0, 0, 0, 1, 320})
    ->Args({0, 0, 0, 2, 320})
    ->Args({1, 20, 6, 1, 320})
    ->Args({1, 20, 6, 2, 320})
    ->Args({1, 20, 9, 2, 320})
    ->Args({2, eval::kSmallSuperpixels, 9, 2, 320})
    ->Args({2, eval::kLargeSuperpixels, 9, 2, 320})
    ->Args({0, 0, 0, 2, 480})
    ->Args({1, 20, 6, 2, 480})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The CamVid-size forest on a CamVid frame. Args: mode, size, V, threads (label_frame_case).
void BM_LabelFrameCamVid(benchmark::State& state) {
  const Setup* s = setup_camvid();
  if (!s) return camvid_bench::skip(state);
  label_frame_case(state, *s);
}
BENCHMARK(BM_LabelFrameCamVid)
    ->ArgNames({"mode", "size", "V", "threads"})
    ->Args({0, 0, 0, 2})
    ->Args({0, 0, 0, 1})
    ->Args({1, 20, 6, 2})
    ->Args({1, 20, 6, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The SLIC segmentation alone (what --superpixels adds before classification), OpenCV threads default.
void BM_Superpixels(benchmark::State& state) {
  const Setup& s = setup();
  if (!s.frame.gray) {
    state.SkipWithError("the frame has no greyscale image");
    return;
  }
  const cv::Mat gray(s.frame.height, s.frame.width, CV_8UC1, const_cast<std::uint8_t*>(s.frame.gray));
  for (auto _ : state) {
    cv::Mat ids = eval::superpixels(gray, static_cast<int>(state.range(0)));
    benchmark::DoNotOptimize(ids.data);
  }
  counters(state, s);
}
BENCHMARK(BM_Superpixels)->ArgNames({"size"})->Arg(eval::kSmallSuperpixels)->Arg(eval::kLargeSuperpixels)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
