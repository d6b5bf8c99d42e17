// Cost of the monocular structure-from-motion front end per frame (docs/design.md 4, thesis 3.2.6) on short
// synthetic corridor videos (make-sequence's default scene, left images only): the whole front end
// (image decoding, keypoints, KLT tracking, focal from the manifest, initialisation, PnP, key frames,
// local and global bundle adjustment with Ceres, ground plane), and one bundle adjustment of a
// sliding window alone. Counters: ms per frame, share of it spent in bundle adjustment.
// Run: bench_sfm --benchmark_out=sfm.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <random>

#include <Eigen/Geometry>

#include "smseg/sfm/sfm.hpp"
#include "smseg/synth/synth.hpp"

namespace fs = std::filesystem;
using namespace smseg;
using namespace smseg::sequence;
using namespace smseg::frontend;
using namespace smseg::sfm;

namespace {

// A corridor video of `frames` frames at w x h, generated once per size.
const Sequence& corridor(int frames, int w, int h) {
  static std::map<std::tuple<int, int, int>, Sequence> cache;
  const auto key = std::make_tuple(frames, w, h);
  auto it = cache.find(key);
  if (it == cache.end()) {
    synth::SynthOptions so;
    so.frames = frames;
    so.width = w;
    so.height = h;
    so.seed = 1;
    const fs::path dir = fs::temp_directory_path() /
                         ("smseg_bench_sfm_" + std::to_string(frames) + "_" + std::to_string(w) + "x" + std::to_string(h));
    it = cache.emplace(key, synth::make_sequence(so, dir)).first;
  }
  return it->second;
}

// args: frames, width (height = 3/4 width).
void BM_MonoFrontEnd(benchmark::State& state) {
  const int frames = static_cast<int>(state.range(0)), w = static_cast<int>(state.range(1));
  const Sequence& seq = corridor(frames, w, w * 3 / 4);
  SfmOptions o;
  o.progress = false;
  SfmReport rep;
  for (auto _ : state) {
    const FrontEndResult r = run_mono_front_end(seq, o, &rep);
    benchmark::DoNotOptimize(r.poses.data());
  }
  state.counters["ms_per_frame"] =
      benchmark::Counter(frames / 1000.0, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["sfm_ms_per_frame"] = 1000 * rep.seconds_sfm;
  state.counters["ba_ms_per_frame"] = 1000 * rep.seconds_ba;
  state.counters["reprojection_rms_px"] = rep.reprojection_rms_px;
  state.counters["keyframes"] = rep.keyframes;
}
BENCHMARK(BM_MonoFrontEnd)->Args({60, 320})->Args({60, 480})->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

// One local bundle adjustment: 8 key frames (2 fixed), 600 points, each seen by 5 cameras, 1 px noise.
void BM_BundleAdjustWindow(benchmark::State& state) {
  std::mt19937_64 g(5);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> noise(0, 1);
  const double f = 400, cx = 240, cy = 180;
  const int nc = 8, np = static_cast<int>(state.range(0));
  std::vector<BaCamera> truth(nc);
  for (int i = 0; i < nc; ++i) {
    truth[i].R = Eigen::AngleAxisd(0.01 * i, Eigen::Vector3d::UnitY()).toRotationMatrix();
    truth[i].t = Eigen::Vector3d(0.02 * i, 0, -0.3 * i);
    truth[i].fixed = i < 2;
  }
  std::vector<Eigen::Vector3d> pts;
  for (int j = 0; j < np; ++j) pts.emplace_back(3 * u(g), 1.5 * u(g), 8 + 4 * u(g));
  std::vector<BaObservation> obs;
  for (int j = 0; j < np; ++j)
    for (int k = 0; k < 5; ++k) {
      const int i = (j + k) % nc;
      const Eigen::Vector3d xc = truth[i].R * pts[j] + truth[i].t;
      obs.push_back({i, j, Eigen::Vector2d(f * xc.x() / xc.z() + cx + noise(g), f * xc.y() / xc.z() + cy + noise(g))});
    }
  for (auto _ : state) {
    state.PauseTiming();
    auto cams = truth;
    for (int i = 2; i < nc; ++i) cams[i].t += 0.02 * Eigen::Vector3d(u(g), u(g), u(g));
    auto p = pts;
    for (auto& x : p) x += 0.05 * Eigen::Vector3d(u(g), u(g), u(g));
    state.ResumeTiming();
    const BaSummary s = bundle_adjust(cams, p, obs, f, cx, cy, BaOptions{});
    benchmark::DoNotOptimize(s.final_rms);
  }
}
BENCHMARK(BM_BundleAdjustWindow)->Arg(300)->Arg(1000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
