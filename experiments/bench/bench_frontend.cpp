// Speed of the stereo front end at 320x240: block matching (with the left-right check), SGBM,
// keypoints (SIFT / ORB / AKAZE / GFTT), symmetric matching, RANSAC motion, and the whole front end
// (descriptor matching, or KLT tracking)
// (image decoding included) over a 32-frame synthetic stereo video. Target (issue): the front end at
// 30 frames/s or more on 2 cores.
// Run: bench_frontend --benchmark_out=frontend.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <filesystem>
#include <random>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "smseg/frontend/motion.hpp"
#include "smseg/frontend/sparse_stereo.hpp"

namespace fs = std::filesystem;
using namespace smseg::sequence;
using namespace smseg::frontend;

namespace {

constexpr int W = 320, H = 240;

// A scene-like texture: blurred noise at two scales plus some flat patches (textureless areas).
cv::Mat texture(int w, int h, std::uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat fine(h, w, CV_32FC1), coarse(h / 8 + 1, w / 8 + 1, CV_32FC1);
  rng.fill(fine, cv::RNG::UNIFORM, 0.0, 1.0);
  rng.fill(coarse, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(fine, fine, cv::Size(0, 0), 1.2);
  cv::resize(coarse, coarse, fine.size(), 0, 0, cv::INTER_CUBIC);
  cv::Mat t = 0.5 * fine + 0.5 * coarse;
  cv::normalize(t, t, 0, 255, cv::NORM_MINMAX);
  for (int i = 0; i < 6; ++i) t(cv::Rect(rng.uniform(0, w - 40), rng.uniform(0, h - 40), 40, 40)).setTo(128);
  return t;
}

cv::Mat shifted(const cv::Mat& tex, double sx) {
  cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, sx, 0, 1, 0);  // dst(x) = tex(x + sx)
  cv::Mat out, out8;
  cv::warpAffine(tex, out, m, cv::Size(W, H), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT);
  out.convertTo(out8, CV_8U);
  return out8;
}

const cv::Mat& tex() {
  static const cv::Mat t = texture(W + 400, H, 3);
  return t;
}

// Frame f: camera slid by 3 px per frame, disparity 10 px.
cv::Mat left_of(int f) { return shifted(tex(), 3.0 * f); }
cv::Mat right_of(int f) { return shifted(tex(), 3.0 * f + 10); }

const Sequence& video() {
  static const Sequence seq = [] {
    Sequence q;
    const fs::path dir = fs::temp_directory_path() / "smseg_bench_frontend";
    fs::create_directories(dir);
    q.manifest = dir / "sequence.json";
    q.root = dir;
    q.name = "bench";
    q.size = cv::Size(W, H);
    q.calibration.fx = 300;
    q.calibration.fy = 300;
    q.calibration.cx = W / 2.0;
    q.calibration.cy = H / 2.0;
    q.calibration.baseline = 0.1;
    q.camera_height = 1.2;
    for (int f = 0; f < 32; ++f) {
      FrameEntry e;
      e.left = "l" + std::to_string(f) + ".png";
      e.right = "r" + std::to_string(f) + ".png";
      cv::imwrite((dir / e.left).string(), left_of(f));
      cv::imwrite((dir / e.right).string(), right_of(f));
      q.frames.push_back(e);
    }
    return q;
  }();
  return seq;
}

KeypointMethod method(int i) { return static_cast<KeypointMethod>(i); }

void BM_BlockMatching(benchmark::State& st) {
  const cv::Mat l = left_of(0), r = right_of(0);
  StereoOptions o;
  o.lr_max_diff = static_cast<int>(st.range(0)) ? 1 : -1;
  for (auto _ : st) benchmark::DoNotOptimize(compute_disparity(l, r, o));
  st.SetLabel(o.lr_max_diff >= 0 ? "with left-right check" : "no left-right check");
}
BENCHMARK(BM_BlockMatching)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->UseRealTime();

// The sparse matcher as the front end uses it: the pair prefiltered, then N corners sampled (with the
// mirrored left-right check), against BM_BlockMatching's dense pass.
void BM_SparseMatching(benchmark::State& st) {
  const cv::Mat l = left_of(0), r = right_of(0);
  StereoOptions o;
  o.method = StereoMethod::Sparse;
  TrackingOptions t;
  t.detector = KeypointMethod::Gftt;
  t.max_keypoints = static_cast<int>(st.range(0));
  std::vector<cv::Point2f> pixels;
  for (const auto& k : detect_keypoints(l, t).keypoints) pixels.push_back(k.pt);
  for (auto _ : st) benchmark::DoNotOptimize(prepare_disparity(l, r, o).sample(pixels));
  st.counters["points"] = static_cast<double>(pixels.size());
}
BENCHMARK(BM_SparseMatching)->Arg(200)->Arg(800)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_SemiGlobalMatching(benchmark::State& st) {
  const cv::Mat l = left_of(0), r = right_of(0);
  StereoOptions o;
  o.method = StereoMethod::SGBM;
  o.block_size = 5;
  for (auto _ : st) benchmark::DoNotOptimize(compute_disparity(l, r, o));
}
BENCHMARK(BM_SemiGlobalMatching)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Keypoints(benchmark::State& st) {
  const cv::Mat l = left_of(0);
  TrackingOptions o;
  o.detector = method(static_cast<int>(st.range(0)));
  std::size_t n = 0;
  for (auto _ : st) n = detect_keypoints(l, o).keypoints.size();
  st.SetLabel(keypoint_method_name(o.detector));
  st.counters["keypoints"] = static_cast<double>(n);
}
BENCHMARK(BM_Keypoints)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_SymmetricMatching(benchmark::State& st) {
  TrackingOptions o;
  o.detector = method(static_cast<int>(st.range(0)));
  const FrameKeypoints a = detect_keypoints(left_of(0), o), b = detect_keypoints(left_of(1), o);
  std::size_t n = 0;
  for (auto _ : st) n = match_symmetric(a.descriptors, b.descriptors, descriptor_norm(o.detector)).size();
  st.SetLabel(keypoint_method_name(o.detector));
  st.counters["matches"] = static_cast<double>(n);
}
BENCHMARK(BM_SymmetricMatching)->DenseRange(0, 2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_RansacMotion(benchmark::State& st) {
  const int n = static_cast<int>(st.range(0));
  std::mt19937_64 g(1);
  std::uniform_real_distribution<double> u(-2, 2), z(1, 6), out(-1, 1);
  std::vector<Eigen::Vector3d> p, q;
  for (int i = 0; i < n; ++i) {
    p.emplace_back(u(g), u(g) * 0.5, z(g));
    q.push_back(p.back() + Eigen::Vector3d(0.01, 0, -0.1) +
                (i % 10 < 3 ? Eigen::Vector3d(out(g), out(g), out(g)) : Eigen::Vector3d::Zero()));
  }
  RansacOptions o;
  for (auto _ : st) benchmark::DoNotOptimize(estimate_motion(p, q, o, 0));
}
BENCHMARK(BM_RansacMotion)->Arg(150)->Arg(500)->Unit(benchmark::kMicrosecond);

void BM_FrontEnd(benchmark::State& st) {
  const Sequence& seq = video();
  FrontEndOptions o;
  o.progress = false;
  o.tracking.detector = method(static_cast<int>(st.range(0)));
  o.tracker = st.range(1) ? FrameTracker::Klt : FrameTracker::Descriptors;
  FrontEndSummary s;
  for (auto _ : st) s = run_stereo_front_end(seq, o).summary;
  st.SetLabel(std::string(keypoint_method_name(o.tracking.detector)) + " + " + frame_tracker_name(o.tracker) +
              ", 32 frames, images decoded from PNG");
  st.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(seq.frame_count()), benchmark::Counter::kIsIterationInvariantRate);
  st.counters["valid_points_per_frame"] = s.valid_points_per_frame_mean;
  st.counters["s_disparity"] = s.seconds.disparity;
  st.counters["s_keypoints"] = s.seconds.keypoints;
  st.counters["s_matching"] = s.seconds.matching;
  st.counters["s_motion"] = s.seconds.motion;
}
// (detector, tracker): sift/orb/akaze + descriptors (symmetric matching), sift/gftt + klt.
BENCHMARK(BM_FrontEnd)
    ->Args({0, 0})
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({0, 1})
    ->Args({3, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
