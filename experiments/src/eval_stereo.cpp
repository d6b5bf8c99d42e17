// eval-stereo's work (see eval_stereo.hpp).
#include "smseg/experiments/eval_stereo.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "smseg/common/progress.hpp"
#include "smseg/sequence/image_file.hpp"

namespace smseg::experiments {

using frontend::StereoMethod;
using frontend::StereoOptions;

namespace {

cv::Mat read_gray(const fs::path& p) {
  std::error_code ec;
  if (!fs::is_regular_file(p, ec)) throw Error(p.string(), "", "no such image");
  return sequence::read_image_file(p, cv::IMREAD_GRAYSCALE);
}

std::string pct(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", 100 * v);
  return b;
}

/// The scene folders under `images`, sorted.
std::vector<std::string> scene_folders(const fs::path& images) {
  std::error_code ec;
  if (!fs::is_directory(images, ec)) throw Error(images.string(), "", "no such folder (is --data right?)");
  std::vector<std::string> scenes;
  for (const auto& e : fs::directory_iterator(images)) {
    if (e.is_directory()) scenes.push_back(e.path().filename().string());
  }
  std::sort(scenes.begin(), scenes.end());
  if (scenes.empty()) throw Error(images.string(), "", "holds no scene folders");
  return scenes;
}

/// Every matcher on one scene, appended to e.rows.
void evaluate_scene(StereoEvaluation& e, const std::string& scene, Progress& progress) {
  const fs::path images = fs::path(e.data) / "images", gt_dir = fs::path(e.data) / "groundtruth";
  const frontend::MiddleburyCalib calib = frontend::read_middlebury_calib(images / scene / "calib.txt");
  const cv::Mat left = read_gray(images / scene / "im0.png");
  const cv::Mat right = read_gray(images / scene / "im1.png");
  const cv::Mat gt = frontend::read_pfm(gt_dir / scene / "disp0GT.pfm");
  const cv::Mat mask = read_gray(gt_dir / scene / "mask0nocc.png");
  if (gt.size() != left.size() || mask.size() != left.size() || right.size() != left.size())
    throw Error((gt_dir / scene).string(), "", "images, ground truth and mask differ in size");
  for (StereoOptions o : e.matchers) {
    o.num_disparities = (calib.ndisp + 15) / 16 * 16;
    const auto t0 = std::chrono::steady_clock::now();
    const cv::Mat d = frontend::compute_disparity(left, right, o);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    e.rows.push_back({scene, frontend::stereo_method_name(o.method),
                      frontend::score_disparity(d, gt, mask, e.threshold), secs});
    progress.tick();
  }
}

/// Per matcher, the means over the scenes of the valid share, the bad rate and the seconds.
struct MatcherMeans {
  std::vector<double> valid, bad, seconds;
};

MatcherMeans matcher_means(const StereoEvaluation& e) {
  const std::size_t m_count = e.matchers.size();
  std::vector<double> sum_valid(m_count), sum_bad(m_count), sum_secs(m_count);
  for (std::size_t s = 0; s < e.scenes.size(); ++s)
    for (std::size_t m = 0; m < m_count; ++m) {
      const StereoEvalRow& r = e.rows[s * m_count + m];
      sum_valid[m] += r.score.valid_share;
      sum_bad[m] += r.score.bad_rate;
      sum_secs[m] += r.seconds;
    }
  const double n = static_cast<double>(e.scenes.size());
  MatcherMeans means;
  for (std::size_t m = 0; m < m_count; ++m) {
    means.valid.push_back(sum_valid[m] / n);
    means.bad.push_back(sum_bad[m] / n);
    means.seconds.push_back(sum_secs[m] / n);
  }
  return means;
}

Json row_json(const StereoEvalRow& r) {
  return {{"scene", r.scene},
          {"method", r.method},
          {"pixels", r.score.pixels},
          {"valid", r.score.valid},
          {"valid_share", r.score.valid_share},
          {"nonocc_known", r.score.nonocc_known},
          {"evaluated", r.score.evaluated},
          {"nonocc_valid_share", r.score.nonocc_valid_share},
          {"bad", r.score.bad},
          {"bad_rate", r.score.bad_rate},
          {"mean_abs_error", r.score.mean_abs_error},
          {"seconds", r.seconds}};
}

}  // namespace

std::vector<StereoOptions> stereo_matchers(const std::vector<std::string>& methods, const StereoOptions& bm,
                                           StereoOptions sgbm) {
  sgbm.uniqueness_ratio = bm.uniqueness_ratio;
  sgbm.lr_max_diff = bm.lr_max_diff;
  sgbm.speckle_window = bm.speckle_window;
  std::vector<StereoOptions> opts;
  for (const auto& m : methods) {
    const StereoMethod sm = frontend::parse_stereo_method(m, "--methods");
    if (sm == StereoMethod::Given) throw Error("", "--methods", "'given' has nothing to evaluate here");
    opts.push_back(sm == StereoMethod::SGBM ? sgbm : bm);
    opts.back().method = sm;  // sparse: bm's options, matched pixel by pixel
    opts.back().validate();
  }
  return opts;
}

StereoEvaluation evaluate_stereo(const std::string& data, const std::vector<StereoOptions>& matchers,
                                 double threshold) {
  StereoEvaluation e;
  e.data = data;
  e.threshold = threshold;
  e.matchers = matchers;
  e.scenes = scene_folders(fs::path(data) / "images");
  Progress progress("eval-stereo", static_cast<long>(e.scenes.size() * matchers.size()));
  for (const auto& scene : e.scenes) evaluate_scene(e, scene, progress);
  progress.finish();
  return e;
}

std::string stereo_eval_markdown(const StereoEvaluation& e) {
  std::ostringstream md;
  md << "| scene |";
  for (const auto& o : e.matchers)
    md << " " << frontend::stereo_method_name(o.method) << " valid % | " << frontend::stereo_method_name(o.method)
       << " bad-" << e.threshold << " % |";
  md << "\n|---|";
  for (std::size_t i = 0; i < e.matchers.size(); ++i) md << "---:|---:|";
  md << "\n";
  for (std::size_t s = 0; s < e.scenes.size(); ++s) {
    md << "| " << e.scenes[s] << " |";
    for (std::size_t m = 0; m < e.matchers.size(); ++m) {
      const StereoEvalRow& r = e.rows[s * e.matchers.size() + m];
      md << " " << pct(r.score.valid_share) << " | " << pct(r.score.bad_rate) << " |";
    }
    md << "\n";
  }
  md << "| **mean** |";
  const MatcherMeans means = matcher_means(e);
  for (std::size_t m = 0; m < e.matchers.size(); ++m) md << " " << pct(means.valid[m]) << " | " << pct(means.bad[m]) << " |";
  md << "\n";
  return md.str();
}

Json stereo_eval_json(const StereoEvaluation& e) {
  Json j{{"format", "smseg-stereo-eval"}, {"version", 1}, {"data", e.data}, {"bad_threshold", e.threshold}};
  const MatcherMeans means = matcher_means(e);
  Json methods_j = Json::array();
  for (std::size_t m = 0; m < e.matchers.size(); ++m) {
    const auto& o = e.matchers[m];
    methods_j.push_back({{"method", frontend::stereo_method_name(o.method)},
                         {"block_size", o.block_size},
                         {"texture_threshold", o.texture_threshold},
                         {"uniqueness_ratio", o.uniqueness_ratio},
                         {"lr_max_diff", o.lr_max_diff},
                         {"speckle_window", o.speckle_window},
                         {"speckle_range", o.speckle_range},
                         {"mean_valid_share", means.valid[m]},
                         {"mean_bad_rate", means.bad[m]},
                         {"mean_seconds", means.seconds[m]}});
  }
  j["methods"] = methods_j;
  Json rj = Json::array();
  for (const auto& r : e.rows) rj.push_back(row_json(r));
  j["scenes"] = rj;
  return j;
}

}  // namespace smseg::experiments
