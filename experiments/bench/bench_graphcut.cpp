// Speed of graph-cut smoothing (eval/smooth.hpp): eval::smooth_labels on one 320x240 frame's per-pixel
// class distributions, 4- and 8-connected, for a few lambdas, within the default label window of 5 pixels
// in the default 2 bands (8-connected, lambda 1: also 1 and 4 bands, and without a window); and the plain
// max-flow of one expansion
// move's size. Target (graph-cut issue): smoothing a 320x240 frame under 50 ms on 2 cores.
//
// By default the distributions come from a forest (M = 7, K = 400) trained in the benchmark on
// libforest's synthetic frames (4 classes, as bench_eval). To time a real forest and stack:
//   SMSEG_BENCH_FOREST=work/forest.json SMSEG_BENCH_WORK=work SMSEG_BENCH_FRAME=110 bench_graphcut
// BM_SmoothFrameCamVid times the smoothing, label windows 0, 2, 5, 10, on CamVid val frame 60 with the CamVid-size forest
// (camvid_setup.hpp; skipped without CamVid).
// Run: bench_graphcut --benchmark_out=graphcut.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <optional>

#include "camvid_setup.hpp"
#include "synthetic_setup.hpp"
#include "smseg/eval/evaluate.hpp"
#include "smseg/eval/smooth.hpp"
#include "smseg/graphcut/graphcut.hpp"
#include "smseg/forest/synthetic.hpp"
#include "smseg/forest/train.hpp"

using namespace smseg;

namespace {

struct Setup {
  forest::Forest forest;
  forest::SyntheticData synthetic;
  std::optional<stacks::StackSet> stacks;
  forest::FrameData frame;
  std::vector<float> dists;
  cv::Mat gray;
  std::string source;
};

// The forest's per-pixel class distributions of the frame, and its greyscale image.
void classify(Setup& x) {
  const forest::Classifier c(x.forest);
  const std::size_t n = std::size_t(x.frame.width) * std::size_t(x.frame.height);
  std::vector<std::uint8_t> labels(n);
  x.dists.resize(n * std::size_t(c.num_classes()));
  c.classify_frame(x.frame, labels, x.dists);
  x.gray = cv::Mat(x.frame.height, x.frame.width, CV_8UC1, const_cast<std::uint8_t*>(x.frame.gray)).clone();
}

// Frame f of a work folder's stacks, classified by the forest.
Setup* stack_setup(forest::Forest forest, const std::string& work, int f) {
  auto* x = new Setup;
  x->forest = std::move(forest);
  x->stacks = stacks::open_stacks({work}, stacks::FrameRange{f, f + 1}, false, true, x->forest.features);
  eval::check_forest_fits(x->forest, *x->stacks);
  x->frame = x->stacks->dataset.frames.front();
  x->source = work;
  classify(*x);
  return x;
}

const Setup& setup() {
  static const Setup* s = [] {
    const char* forest_file = std::getenv("SMSEG_BENCH_FOREST");
    const char* work = std::getenv("SMSEG_BENCH_WORK");
    if (forest_file && work) {
      const char* frame = std::getenv("SMSEG_BENCH_FRAME");
      return stack_setup(forest::load_forest(forest_file), work, frame ? std::atoi(frame) : 0);
    }
    auto* x = new Setup;
    synthetic_bench::ForestAndFrame made = synthetic_bench::forest_and_frame(320, 240);
    x->forest = std::move(made.forest);
    x->synthetic = std::move(made.frame);
    x->frame = x->synthetic.data.frames.front();
    x->source = "synthetic";
    classify(*x);
    return x;
  }();
  return *s;
}

// The CamVid-size forest and val frame 60 of its run (camvid_setup.hpp); null when CamVid is absent.
const Setup* setup_camvid() {
  static const Setup* s = []() -> const Setup* {
    if (camvid_bench::unavailable()) return nullptr;
    Setup* x = stack_setup(camvid_bench::val_forest(), camvid_bench::val_work().string(), 60);
    x->source = "CamVid val frame 60, forest Kt = 20000";
    return x;
  }();
  return s;
}

void smooth_case(benchmark::State& state, const Setup& s, const eval::SmoothOptions& opt) {
  eval::SmoothReport rep;
  for (auto _ : state) {
    cv::Mat out = eval::smooth_labels(s.dists, static_cast<int>(s.forest.classes.size()), s.gray, opt, &rep);
    benchmark::DoNotOptimize(out.data);
  }
  state.counters["cycles"] = rep.cycles;
  state.counters["moves"] = rep.moves;
  state.counters["graph_nodes"] = double(rep.graph_nodes);
  state.counters["allowed_labels"] = double(rep.allowed_labels);
  state.counters["energy_after"] = rep.energy_after;
  state.counters["energy_drop"] = rep.energy_before - rep.energy_after;
  state.counters["classes"] = double(s.forest.classes.size());
  state.counters["width"] = s.frame.width;
  state.counters["height"] = s.frame.height;
  state.SetLabel(s.source);
}

// Args: connectivity, lambda x 10, label window (0: plain alpha-expansion)
void BM_SmoothFrame(benchmark::State& state) {
  const Setup& s = setup();
  eval::SmoothOptions opt;
  opt.method = eval::SmoothMethod::GraphCut;
  opt.connectivity = static_cast<int>(state.range(0));
  opt.lambda = double(state.range(1)) / 10.0;
  opt.label_window = static_cast<int>(state.range(2));
  opt.bands = static_cast<int>(state.range(3));
  smooth_case(state, s, opt);
}
BENCHMARK(BM_SmoothFrame)
    ->ArgNames({"conn", "lambda10", "window", "bands"})
    ->Args({4, 5, 5, 2})
    ->Args({4, 10, 5, 2})
    ->Args({4, 20, 5, 2})
    ->Args({8, 5, 5, 2})
    ->Args({8, 10, 0, 1})
    ->Args({8, 10, 5, 1})
    ->Args({8, 10, 5, 2})
    ->Args({8, 10, 5, 4})
    ->Args({8, 20, 5, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// eval-forest's smoothing (--smooth graphcut, every other option at its default but the label window:
// 0 = plain alpha-expansion, 5 = the default) on a CamVid frame (480x360, 11 classes). Target
// (real-scale issue): <= 60 ms.
void BM_SmoothFrameCamVid(benchmark::State& state) {
  const Setup* s = setup_camvid();
  if (!s) return camvid_bench::skip(state);
  eval::SmoothOptions opt;
  opt.method = eval::SmoothMethod::GraphCut;
  opt.label_window = static_cast<int>(state.range(0));
  smooth_case(state, *s, opt);
}
BENCHMARK(BM_SmoothFrameCamVid)->ArgName("window")->Arg(0)->Arg(2)->Arg(5)->Arg(10)->Unit(benchmark::kMillisecond)->UseRealTime();

// One binary max-flow on a 320x240 4-connected grid with random terminal capacities (the size of one
// expansion move).
void BM_GridMaxFlow(benchmark::State& state) {
  const int W = 320, H = 240;
  graphcut::FlowGraph g;
  std::uint64_t k = 1;
  auto next = [&k] {
    k = k * 6364136223846793005ull + 1442695040888963407ull;
    return double(k >> 40) / double(1ull << 24);
  };
  for (int i = 0; i < W * H; ++i) {
    g.source.push_back(3 * next());
    g.sink.push_back(3 * next());
  }
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (x + 1 < W) g.edges.push_back({y * W + x, y * W + x + 1, 1.0, 1.0});
      if (y + 1 < H) g.edges.push_back({y * W + x, (y + 1) * W + x, 1.0, 1.0});
    }
  for (auto _ : state) benchmark::DoNotOptimize(graphcut::max_flow(g));
}
BENCHMARK(BM_GridMaxFlow)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
