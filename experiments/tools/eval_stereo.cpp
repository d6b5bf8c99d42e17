// eval-stereo: measures the stereo matchers (block matching with validity checks, semi-global matching)
// on the Middlebury 2014 quarter-resolution training pairs: share of pixels with a valid disparity and
// the bad-2 rate (|d - d_gt| > 2 px over non-occluded pixels with a valid estimate), per scene and mean.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "smseg/common/cli.hpp"
#include "smseg/frontend/stereo.hpp"
#include "smseg/sequence/image_file.hpp"
#include "smseg/common/progress.hpp"

namespace {

using namespace smseg;
using namespace smseg::features;

struct Row {
  std::string scene;
  std::string method;
  DisparityScore score;
  double seconds = 0;
};

cv::Mat read_gray(const fs::path& p) {
  std::error_code ec;
  if (!fs::is_regular_file(p, ec)) throw Error(p.string(), "", "no such image");
  return read_image_file(p, cv::IMREAD_GRAYSCALE);
}

std::string pct(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", 100 * v);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Evaluate the stereo matchers on Middlebury 2014 (quarter resolution) pairs: per scene and\n"
               "method, the share of pixels with a valid disparity and the bad-2 rate over non-occluded\n"
               "pixels that have a valid estimate. Writes JSON (-o) and optionally a Markdown table.",
               "eval-stereo"};
  std::string data = "../shared/data/middlebury-q";
  std::string out, markdown;
  std::vector<std::string> methods{"bm", "sgbm"};
  double threshold = 2.0;
  StereoOptions bm, sgbm;
  sgbm.method = StereoMethod::SGBM;
  sgbm.block_size = 5;
  app.add_option("--data", data, "Middlebury folder holding images/<Scene> and groundtruth/<Scene> (default " +
                                     data + ")");
  app.add_option("-o,--output", out, "results JSON file (default: none, table on stdout only)");
  app.add_option("--markdown", markdown, "also write the Markdown table to this file (default: none)");
  app.add_option("--methods", methods, "matchers to evaluate, any of bm sgbm (default: bm sgbm)");
  app.add_option("--threshold", threshold, "bad-pixel threshold in pixels (default 2)");
  app.add_option("--bm-block", bm.block_size, "BM block size (default " + std::to_string(bm.block_size) + ")");
  app.add_option("--bm-texture", bm.texture_threshold,
                 "BM texture threshold (default " + std::to_string(bm.texture_threshold) + ")");
  app.add_option("--uniqueness", bm.uniqueness_ratio,
                 "uniqueness ratio in percent, both matchers (default " + std::to_string(bm.uniqueness_ratio) + ")");
  app.add_option("--lr-max-diff", bm.lr_max_diff,
                 "left-right check tolerance in pixels, < 0 disables, both matchers (default " +
                     std::to_string(bm.lr_max_diff) + ")");
  app.add_option("--speckle-window", bm.speckle_window,
                 "speckle filter region size in pixels, 0 disables, both matchers (default " +
                     std::to_string(bm.speckle_window) + ")");
  app.add_option("--sgbm-block", sgbm.block_size, "SGBM block size (default " + std::to_string(sgbm.block_size) + ")");
  return run_tool(app, argc, argv, [&] {
    sgbm.uniqueness_ratio = bm.uniqueness_ratio;
    sgbm.lr_max_diff = bm.lr_max_diff;
    sgbm.speckle_window = bm.speckle_window;
    std::vector<StereoOptions> opts;
    for (const auto& m : methods) {
      const StereoMethod sm = parse_stereo_method(m, "--methods");
      if (sm == StereoMethod::Given) throw Error("", "--methods", "'given' has nothing to evaluate here");
      opts.push_back(sm == StereoMethod::BM ? bm : sgbm);
      opts.back().validate();
    }
    const fs::path images = fs::path(data) / "images", gt_dir = fs::path(data) / "groundtruth";
    std::error_code ec;
    if (!fs::is_directory(images, ec)) throw Error(images.string(), "", "no such folder (is --data right?)");
    std::vector<std::string> scenes;
    for (const auto& e : fs::directory_iterator(images)) {
      if (e.is_directory()) scenes.push_back(e.path().filename().string());
    }
    std::sort(scenes.begin(), scenes.end());
    if (scenes.empty()) throw Error(images.string(), "", "holds no scene folders");

    std::vector<Row> rows;
    Progress progress("eval-stereo", static_cast<long>(scenes.size() * opts.size()));
    for (const auto& scene : scenes) {
      const MiddleburyCalib calib = read_middlebury_calib(images / scene / "calib.txt");
      const cv::Mat left = read_gray(images / scene / "im0.png");
      const cv::Mat right = read_gray(images / scene / "im1.png");
      const cv::Mat gt = read_pfm(gt_dir / scene / "disp0GT.pfm");
      const cv::Mat mask = read_gray(gt_dir / scene / "mask0nocc.png");
      if (gt.size() != left.size() || mask.size() != left.size() || right.size() != left.size())
        throw Error((gt_dir / scene).string(), "", "images, ground truth and mask differ in size");
      for (StereoOptions o : opts) {
        o.num_disparities = (calib.ndisp + 15) / 16 * 16;
        const auto t0 = std::chrono::steady_clock::now();
        const cv::Mat d = compute_disparity(left, right, o);
        const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        rows.push_back({scene, stereo_method_name(o.method), score_disparity(d, gt, mask, threshold), secs});
        progress.tick();
      }
    }
    progress.finish();

    // Table: one row per scene, per method valid% and bad-2%, then the mean.
    std::ostringstream md;
    md << "| scene |";
    for (const auto& o : opts) md << " " << stereo_method_name(o.method) << " valid % | " << stereo_method_name(o.method)
                                  << " bad-" << threshold << " % |";
    md << "\n|---|";
    for (std::size_t i = 0; i < opts.size(); ++i) md << "---:|---:|";
    md << "\n";
    std::vector<double> sum_valid(opts.size()), sum_bad(opts.size()), sum_secs(opts.size());
    for (std::size_t s = 0; s < scenes.size(); ++s) {
      md << "| " << scenes[s] << " |";
      for (std::size_t m = 0; m < opts.size(); ++m) {
        const Row& r = rows[s * opts.size() + m];
        md << " " << pct(r.score.valid_share) << " | " << pct(r.score.bad_rate) << " |";
        sum_valid[m] += r.score.valid_share;
        sum_bad[m] += r.score.bad_rate;
        sum_secs[m] += r.seconds;
      }
      md << "\n";
    }
    md << "| **mean** |";
    const double n = static_cast<double>(scenes.size());
    for (std::size_t m = 0; m < opts.size(); ++m) md << " " << pct(sum_valid[m] / n) << " | " << pct(sum_bad[m] / n) << " |";
    md << "\n";
    std::cout << md.str();

    Json j{{"format", "smseg-stereo-eval"}, {"version", 1}, {"data", data}, {"bad_threshold", threshold}};
    Json methods_j = Json::array();
    for (std::size_t m = 0; m < opts.size(); ++m) {
      const auto& o = opts[m];
      methods_j.push_back({{"method", stereo_method_name(o.method)},
                           {"block_size", o.block_size},
                           {"texture_threshold", o.texture_threshold},
                           {"uniqueness_ratio", o.uniqueness_ratio},
                           {"lr_max_diff", o.lr_max_diff},
                           {"speckle_window", o.speckle_window},
                           {"speckle_range", o.speckle_range},
                           {"mean_valid_share", sum_valid[m] / n},
                           {"mean_bad_rate", sum_bad[m] / n},
                           {"mean_seconds", sum_secs[m] / n}});
    }
    j["methods"] = methods_j;
    Json rj = Json::array();
    for (const auto& r : rows) {
      rj.push_back({{"scene", r.scene},
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
                    {"seconds", r.seconds}});
    }
    j["scenes"] = rj;
    if (!out.empty()) write_json_atomic(out, j);
    if (!markdown.empty()) write_file_atomic(markdown, md.str());
    return 0;
  });
}
