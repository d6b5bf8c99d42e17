// learn-textons: a texton dictionary (textons.hpp) learned by k-means on the training frames' filter-bank
// responses, for add-textons.
#include <cstdio>
#include <iostream>

#include "smseg/common/cli.hpp"
#include "smseg/common/options.hpp"
#include "smseg/common/output.hpp"
#include "smseg/stacks/textons.hpp"
#include "learned_from.hpp"

namespace {

/// What the dictionary was learned from: each work folder with its stacks.json's digest, and the options.
smseg::Json provenance(const std::vector<std::string>& works, const std::string& frames, int samples,
                       const smseg::stacks::TextonLearning& o) {
  return {{"work_folders", smseg::stacks::learned_from(works)}, {"frames", frames}, {"samples_per_frame", samples},
          {"iterations", o.iterations}, {"seed", o.seed}};
}

}  // namespace

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Learn textons: the 17 filters of Winn et al. (Gaussians on Lab, Laplacians of Gaussians and\n"
      "derivatives on L) at --samples random pixels of every frame of the work folders (their colour\n"
      "images, read from the sequences they were extracted from), made z-scores and clustered by\n"
      "k-means++ and Lloyd's iterations into --textons centres. Learn them on the training folders only;\n"
      "add-textons then gives every folder, training and test, the texton channels fTx0.. (a forest\n"
      "window's mean of fTxK is the share of texton K in it: TextonBoost's texture-layout features).\n"
      "The same folders, options and seed give the same file whatever --threads. See docs/camvid.md,\n"
      "\"Textons\".",
      "learn-textons"};
  std::vector<std::string> works;
  std::string out, frames = "0:";
  stacks::TextonLearning opt;
  int samples = 2000, threads = 0;
  bool quiet = false;
  app.add_option("WORK", works, "training work folders (from extract-features)")->required();
  app.add_option("--textons", opt.textons, "number of textons K")->capture_default_str()
      ->check(options::in_range(2, stacks::kMaxTextons));
  app.add_option("--samples", samples, "pixels sampled per frame")->capture_default_str()
      ->check(options::in_range(1, 1000000));
  app.add_option("--iterations", opt.iterations, "k-means iterations at most")->capture_default_str()
      ->check(options::in_range(1, 10000));
  app.add_option("--seed", opt.seed, "seed of the pixel draws and of k-means++")->capture_default_str()
      ->check(options::any_seed())->check(CLI::Validator(kDecimalDigits).description(""));
  app.add_option("--frames", frames, "frames of each folder sampled, A:B half-open")->capture_default_str();
  add_threads_option(app, threads, "the output does not depend on it");
  app.add_flag("-q,--quiet", quiet, "no progress on stderr");
  app.add_option("-o,--out", out, "the dictionary to write (JSON)")->required();
  return run_tool(app, argc, argv, threads, [&] {
    const stacks::FrameRange range = stacks::FrameRange::parse(frames, "--frames");
    const OutputLock one_writer(out, paths_of(works));
    const std::vector<fs::path> folders(works.begin(), works.end());
    const cv::Mat sample = stacks::texton_samples(folders, range, samples, opt.seed, !quiet);
    stacks::TextonDictionary d = stacks::learn_textons(sample, opt);
    d.provenance = provenance(works, frames, samples, opt);
    stacks::save_texton_dictionary(out, d);
    std::printf("%d textons from %d samples of %zu work folders -> %s\n", d.count(), sample.rows, works.size(),
                out.c_str());
    return 0;
  });
}
