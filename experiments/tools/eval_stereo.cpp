// eval-stereo: measures the stereo matchers (block matching with validity checks, semi-global matching)
// on the Middlebury 2014 quarter-resolution training pairs: share of pixels with a valid disparity and
// the bad-2 rate (|d - d_gt| > 2 px over non-occluded pixels with a valid estimate), per scene and mean.
#include <charconv>
#include <iostream>

#include "smseg/common/cli.hpp"
#include "smseg/common/output.hpp"
#include "smseg/common/options.hpp"
#include "smseg/experiments/eval_stereo.hpp"

namespace {

/// Block sizes: the matchers take odd windows only.
const CLI::Validator kOdd(
    [](std::string& text) -> std::string {
      int x = 0;
      const auto r = std::from_chars(text.data(), text.data() + text.size(), x);
      const bool even = r.ec == std::errc() && x % 2 == 0;  // not a number: in_range says so
      return even ? "must be odd, got " + text : std::string();
    },
    "ODD");

}  // namespace

int main(int argc, char** argv) {
  using namespace smseg;
  using namespace smseg::frontend;
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
  app.add_option("--methods", methods, "matchers to evaluate, any of bm sgbm sparse (default: bm sgbm)");
  app.add_option("--threshold", threshold, "bad-pixel threshold in pixels (default 2)")
      ->check(options::in_range(0.0, 1000.0));
  app.add_option("--bm-block", bm.block_size, "BM block size, odd (default " + std::to_string(bm.block_size) + ")")
      ->check(options::in_range(5, 255) & kOdd);
  app.add_option("--bm-texture", bm.texture_threshold,
                 "BM texture threshold (default " + std::to_string(bm.texture_threshold) + ")")
      ->check(options::in_range(0, 1000000));
  app.add_option("--uniqueness", bm.uniqueness_ratio,
                 "uniqueness ratio in percent, both matchers (default " + std::to_string(bm.uniqueness_ratio) + ")")
      ->check(options::in_range(0, 100));
  app.add_option("--lr-max-diff", bm.lr_max_diff,
                 "left-right check tolerance in pixels, < 0 disables, both matchers (default " +
                     std::to_string(bm.lr_max_diff) + ")")
      ->check(options::in_range(-1, 1000));
  app.add_option("--speckle-window", bm.speckle_window,
                 "speckle filter region size in pixels, 0 disables, both matchers (default " +
                     std::to_string(bm.speckle_window) + ")")
      ->check(options::in_range(0, 1000000));
  app.add_option("--sgbm-block", sgbm.block_size, "SGBM block size, odd (default " + std::to_string(sgbm.block_size) + ")")
      ->check(options::in_range(1, 21) & kOdd);
  return run_tool(app, argc, argv, [&] {
    for (const auto& [output, option] : {std::pair{out, "-o"}, std::pair{markdown, "--markdown"}})
      if (!output.empty()) check_output_apart(output, {data}, option);
    const auto matchers = experiments::stereo_matchers(methods, bm, sgbm);
    const experiments::StereoEvaluation e = experiments::evaluate_stereo(data, matchers, threshold);
    const std::string md = experiments::stereo_eval_markdown(e);
    std::cout << md;
    if (!out.empty()) write_json_atomic(out, experiments::stereo_eval_json(e));
    if (!markdown.empty()) write_file_atomic(markdown, md);
    return 0;
  });
}
