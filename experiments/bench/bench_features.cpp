// Rasterising the six structure-and-motion features and building their summed-area tables for a
// 320x240 frame with ~500 tracked points (issue target: 300 frames/s or more on one core); the plane
// sweep of extract-features --dense on monocular runs and the dense channels made from its depth, on
// CamVid val frames (480x360) with its SfM poses; loading one frame's stack as training and evaluation
// do (open it, read every table once, release it) from the work folder named by SMSEG_BENCH_STACKS
// (either stacks format; skipped without it).
// Run: build/bin/bench_features --benchmark_out=bench_features.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <random>

#include <opencv2/imgproc.hpp>

#include "camvid_setup.hpp"
#include "smseg/sfm/sfm.hpp"
#include "smseg/frontend/tracks_io.hpp"
#include "smseg/stacks/dense.hpp"
#include "smseg/stacks/front_ends.hpp"
#include "smseg/stacks/plane_sweep.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/stacks/stack.hpp"

using namespace smseg::sequence;
using namespace smseg::frontend;
using namespace smseg::sfm;
using namespace smseg::stacks;

namespace {

PointCloudVideo make_video(int points, int frames) {
  PointCloudVideo v;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(-3, 3), uy(0, 2.5), uz(-12, -2);
  std::vector<Eigen::Vector3d> world(points);
  for (auto& w : world) w = {ux(rng), uy(rng), uz(rng)};
  for (int f = 0; f < frames; ++f) {
    Pose p;
    p.R = {1, 0, 0, 0, -1, 0, 0, 0, -1};
    p.t = {0, 1, -0.02 * f};
    v.poses.push_back(p);
    std::vector<Observation> obs;
    for (int k = 0; k < points; ++k) {
      const Eigen::Vector3d c(world[k].x() - p.t[0], -(world[k].y() - p.t[1]), -(world[k].z() - p.t[2]));
      if (c.z() < 0.5) continue;
      Observation o;
      o.track = k;
      o.cam = c;
      o.x = static_cast<float>(200 * c.x() / c.z() + 159.5);
      o.y = static_cast<float>(200 * c.y() / c.z() + 119.5);
      if (o.x < 0 || o.y < 0 || o.x > 319 || o.y > 239) continue;
      obs.push_back(o);
    }
    v.observations.push_back(std::move(obs));
  }
  return v;
}

void BM_RasteriseAndSat(benchmark::State& state) {
  const PointCloudVideo v = make_video(static_cast<int>(state.range(0)), 4);
  const PointAttributes a = compute_point_attributes(v, {});
  const cv::Size size(320, 240);
  cv::setNumThreads(0);  // one core: OpenCV's own threads off
  std::vector<cv::Mat> rasters, sats(6);  // reused frame to frame, as extract-features does
  for (auto _ : state) {
    rasterise_features(v, a, 0, size, rasters);
    for (int k = 0; k < 6; ++k) summed_area_table(rasters[k], sats[k]);
    benchmark::DoNotOptimize(sats.back().data);
  }
  state.counters["points"] = static_cast<double>(v.observations[0].size());
  state.counters["frames_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RasteriseAndSat)->Arg(600)->Unit(benchmark::kMillisecond);

void BM_SatOnly(benchmark::State& state) {
  cv::Mat r = cv::Mat::zeros(240, 320, CV_64FC1), sat;
  for (auto _ : state) {
    for (int k = 0; k < 6; ++k) {
      summed_area_table(r, sat);
      benchmark::DoNotOptimize(sat.data);
    }
  }
}
BENCHMARK(BM_SatOnly)->Unit(benchmark::kMillisecond);

void BM_DelaunayOnly(benchmark::State& state) {
  const PointCloudVideo v = make_video(600, 1);
  for (auto _ : state) {
    cv::Subdiv2D subdiv(cv::Rect(-1, -1, 322, 242));
    for (const auto& o : v.observations[0]) subdiv.insert(cv::Point2f(o.x, o.y));
    std::vector<cv::Vec6f> tris;
    subdiv.getTriangleList(tris);
    benchmark::DoNotOptimize(tris.data());
  }
}
BENCHMARK(BM_DelaunayOnly)->Unit(benchmark::kMillisecond);

// One frame's plane sweep (val frame 60 against frames 60 - gap and 60 + gap, with the poses and focal
// of the cached val extraction). gap 2 is what sweep_neighbours picks at 15 Hz (0.5 m, 90 planes);
// gap 15 puts the neighbours ~4 m away, as at 1 Hz, where the sweep takes its cap of 256 planes.
// scale_pct: the sweep's resolution in percent (--sweep-scale; 50 sweeps 240x180 images).
void BM_PlaneSweepCamVid(benchmark::State& state) {
  if (camvid_bench::unavailable()) return camvid_bench::skip(state);
  const int f = 60, gap = static_cast<int>(state.range(0));
  PlaneSweepOptions options;
  options.scale = state.range(1) / 100.0;
  const TracksFile tracks = smseg::stacks::read_tracks(camvid_bench::val_work() / "tracks.json");
  const Sequence seq = load_sequence(camvid_bench::kCache / "sequences" / camvid_bench::kValRun);
  const auto pose = [&](int g) { return tracks.result.poses.at(std::size_t(g - tracks.result.first_frame)); };
  const Calibration camera = sfm_camera(seq, sfm_summary_of(tracks.result.summary)->focal);
  const std::vector<SweepView> views{{seq.load_left_gray(f - gap), pose(f - gap)},
                                     {seq.load_left_gray(f + gap), pose(f + gap)}};
  const cv::Mat reference = seq.load_left_gray(f);
  state.counters["planes"] = sweep_plane_count(pose(f), views, *camera.fx * options.scale, options);
  for (auto _ : state) benchmark::DoNotOptimize(plane_sweep_depth(reference, pose(f), views, camera, options));
}
BENCHMARK(BM_PlaneSweepCamVid)->ArgsProduct({{2, 15}, {100, 50}})->ArgNames({"gap", "scale_pct"})->Unit(benchmark::kMillisecond);

// The dense channels of one val frame from its plane-sweep depth (neighbours 15 frames away, as the
// benchmark's 4 m sweep): Arg 0 measures fZC to the camera's own centre, Arg 1 to the path of the next
// 100 frames, as extract-features does (the cost of fZC's path is the difference).
void BM_DenseRastersCamVid(benchmark::State& state) {
  if (camvid_bench::unavailable()) return camvid_bench::skip(state);
  const int f = 60, gap = 15;
  const TracksFile tracks = smseg::stacks::read_tracks(camvid_bench::val_work() / "tracks.json");
  const Sequence seq = load_sequence(camvid_bench::kCache / "sequences" / camvid_bench::kValRun);
  const auto index = [&](int g) { return std::size_t(g - tracks.result.first_frame); };
  const Calibration camera = sfm_camera(seq, sfm_summary_of(tracks.result.summary)->focal);
  const std::vector<SweepView> views{{seq.load_left_gray(f - gap), tracks.result.poses.at(index(f - gap))},
                                     {seq.load_left_gray(f + gap), tracks.result.poses.at(index(f + gap))}};
  const Pose& pose = tracks.result.poses.at(index(f));
  const cv::Mat depth = plane_sweep_depth(seq.load_left_gray(f), pose, views, camera);
  const CameraPath path =
      state.range(0) ? camera_path_near(tracks.result.poses, int(index(f)), 100, false) : CameraPath{};
  state.counters["valid_share"] = double(cv::countNonZero(depth)) / double(depth.total());
  std::vector<cv::Mat> rasters;
  for (auto _ : state) {
    rasters.clear();
    append_dense_rasters(depth, camera, pose, rasters, 0, path);
    benchmark::DoNotOptimize(rasters.data());
  }
}
BENCHMARK(BM_DenseRastersCamVid)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// One frame's stack loaded and read whole, frame after frame of the folder's (the files in the page
// cache after the first round, as in training, which reads every frame many times). Arg 0: every
// feature; 6: the first six only (the six S+M features of an extract-features folder), as a forest
// that reads them opens the frame.
void BM_LoadFrameStack(benchmark::State& state) {
  const char* work = std::getenv("SMSEG_BENCH_STACKS");
  if (!work) return state.SkipWithError("set SMSEG_BENCH_STACKS to a work folder");
  const StackManifest m = load_stack_manifest(work);
  const std::size_t cells = std::size_t(m.size.width + 1) * std::size_t(m.size.height + 1);
  const std::size_t asked = state.range(0) == 0 ? m.features.size() : std::min<std::size_t>(state.range(0), m.features.size());
  std::vector<bool> wanted(m.features.size(), false);
  std::fill(wanted.begin(), wanted.begin() + static_cast<std::ptrdiff_t>(asked), true);
  cv::setNumThreads(0);
  std::size_t next = 0;
  double sum = 0;
  for (auto _ : state) {
    const int frame = m.frames[next++ % m.frames.size()];
    const FrameStack stack = FrameStack::open(m, frame, m.is_labelled(frame), wanted);
    const smseg::forest::FrameData d = stack.view();
    for (const double* sat : d.sats)
      for (std::size_t i = 0; sat && i < cells; ++i) sum += sat[i];
    d.release();
  }
  benchmark::DoNotOptimize(sum);
  state.counters["version"] = m.version;
  state.counters["features"] = static_cast<double>(asked);
  state.counters["frames_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_LoadFrameStack)->Arg(0)->Arg(6)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
