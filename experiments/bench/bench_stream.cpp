// Speed of on-line labelling (eval/stream.hpp, the label-stream tool without its file I/O): frames of a
// synthetic stereo corridor, decoded beforehand, go through eval::run_stream (stereo front end, causal
// features, forest; the same pipeline label-stream runs). Reported per case: frames per second
// (items_per_second) and the median latency from a pair's arrival to its labels (latency_ms).
//   BM_LabelStream: 320x240 corridor, a forest (K = 400, M = 7) trained on its causal stacks; target
//     (issue "real scale", part 5): grid B = 20, V = 6, 2 threads >= 30 frames per second.
//   BM_LabelStreamCamVidForest: the CamVid-size forest (camvid_setup.hpp, Kt = 20 000) per pixel on a
//     480x360 corridor (CamVid has no right images; the forest only needs frames of its size).
// Sequences, work folders and forests are cached in SMSEG_BENCH_CACHE (the build tree).
// Run: bench_stream --benchmark_out=stream.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <vector>

#include <oneapi/tbb/global_control.h>

#include "camvid_setup.hpp"
#include "smseg/eval/stream.hpp"
#include "smseg/forest/train.hpp"
#include "smseg/stacks/extract.hpp"
#include "smseg/synth/synth.hpp"

using namespace smseg;
namespace fs = std::filesystem;

namespace {

constexpr int kFrames = 60;

struct Corridor {
  sequence::Sequence seq;
  std::vector<cv::Mat> left, right;  // decoded once: the benchmark times the labelling, not PNG decoding
};

// A corridor of kFrames frames of this size (cached), decoded.
const Corridor& corridor(int width, int height) {
  static std::map<int, Corridor> made;
  auto it = made.find(width);
  if (it != made.end()) return it->second;
  const fs::path dir = fs::path(SMSEG_BENCH_CACHE) / ("stream-corridor-" + std::to_string(width));
  if (!fs::exists(dir / "seq" / "sequence.json")) {
    synth::SynthOptions so;
    so.frames = kFrames;
    so.width = width;
    so.height = height;
    so.label_every = 5;
    synth::make_sequence(so, dir / "seq");
  }
  Corridor c{sequence::load_sequence(dir / "seq"), {}, {}};
  for (int f = 0; f < c.seq.frame_count(); ++f) {
    c.left.push_back(c.seq.load_left_gray(f));
    c.right.push_back(c.seq.load_right_gray(f));
  }
  return made.emplace(width, std::move(c)).first->second;
}

// The forest of the 320x240 corridor: trained on its causal stacks (cached as forest.json).
forest::Forest corridor_forest() {
  const fs::path dir = fs::path(SMSEG_BENCH_CACHE) / "stream-corridor-320";
  const Corridor& c = corridor(320, 240);
  if (fs::exists(dir / "forest.json")) return forest::load_forest(dir / "forest.json");
  stacks::ExtractOptions eo;
  eo.features.causal = true;
  eo.progress = false;
  stacks::extract_features(c.seq, dir / "work", eo);
  forest::TrainParams p;
  p.K = 400;
  p.M = 7;
  const forest::Forest f =
      forest::train_forest(stacks::open_stacks({dir / "work"}, {}, true, true, {}).dataset, p);
  forest::save_forest(f, dir / "forest.json");
  return f;
}

// Args: tracker (0 descriptors + SIFT, 1 klt + gftt), grid B (0: per pixel), threads.
void stream_case(benchmark::State& state, const forest::Forest& forest, const Corridor& c) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(2)));
  eval::StreamOptions opt;
  opt.front_end.progress = false;
  if (state.range(0) == 1) {
    opt.front_end.tracker = frontend::FrameTracker::Klt;
    opt.front_end.tracking.detector = frontend::KeypointMethod::Gftt;
  }
  opt.eval.grid = static_cast<int>(state.range(1));
  opt.eval.votes = 6;
  std::vector<double> latency;
  for (auto _ : state) {
    eval::StreamLabeller labeller(forest, "forest", c.seq.calibration, c.seq.camera_height, c.seq.size, opt, "bench");
    int next = 0;
    eval::run_stream(
        labeller,
        [&](eval::StreamInput& in) {
          if (next >= static_cast<int>(c.left.size())) return false;
          in.index = next;
          in.left = c.left[next];
          in.right = c.right[next];
          ++next;
          return true;
        },
        [&](const eval::StreamInput& in, const cv::Mat& labels, const eval::StreamStageTimes&) {
          benchmark::DoNotOptimize(labels.data);
          latency.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - in.arrived).count());
        });
  }
  std::sort(latency.begin(), latency.end());
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(c.left.size()));
  state.counters["latency_ms"] = latency.empty() ? 0 : latency[latency.size() / 2];
  state.counters["width"] = c.seq.size.width;
  state.counters["height"] = c.seq.size.height;
}

void BM_LabelStream(benchmark::State& state) {
  static const forest::Forest forest = corridor_forest();
  stream_case(state, forest, corridor(320, 240));
}
BENCHMARK(BM_LabelStream)
    ->ArgNames({"klt", "grid", "threads"})
    ->Args({0, 20, 2})
    ->Args({1, 20, 2})
    ->Args({1, 20, 1})
    ->Args({0, 0, 2})
    ->Args({1, 0, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(2);

void BM_LabelStreamCamVidForest(benchmark::State& state) {
  if (camvid_bench::unavailable()) return camvid_bench::skip(state);
  static const forest::Forest forest = camvid_bench::val_forest();
  stream_case(state, forest, corridor(480, 360));
}
BENCHMARK(BM_LabelStreamCamVidForest)
    ->ArgNames({"klt", "grid", "threads"})
    ->Args({1, 0, 2})
    ->Args({1, 20, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(2);

}  // namespace

BENCHMARK_MAIN();
