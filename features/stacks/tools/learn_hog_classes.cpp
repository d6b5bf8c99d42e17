// learn-hog-classes: a softmax regression of the HOG window around each grid point of the training
// frames (hog_classes.hpp), for add-hog-classes.
#include <algorithm>
#include <cstdio>
#include <utility>

#include "smseg/common/cli.hpp"
#include "smseg/common/options.hpp"
#include "smseg/common/output.hpp"
#include "smseg/stacks/hog_classes.hpp"
#include "learned_from.hpp"

namespace {

/// What the model was learned from: each work folder with its stacks.json's digest, and the options.
smseg::Json provenance(const std::vector<std::string>& works, const std::string& frames, const smseg::stacks::HogLearning& o,
                       const smseg::stacks::HogSamples& samples) {
  smseg::Json per_class = smseg::Json::object();
  for (std::size_t c = 0; c < samples.classes.size(); ++c)
    per_class[samples.classes[c]] = std::count(samples.labels.begin(), samples.labels.end(), int(c));
  return {{"work_folders", smseg::stacks::learned_from(works)}, {"frames", frames},     {"samples_per_class", per_class},
          {"negatives", o.negatives}, {"epochs", o.epochs}, {"l2", o.l2},
          {"learning_rate", o.learning_rate}, {"seed", o.seed}};
}

/// "WxH" as a window, both multiples of 16 from 16 to 256; false for anything else.
bool parse_window(const std::string& text, cv::Size& window) {
  int w = 0, h = 0;
  char x = 0, rest = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &w, &x, &h, &rest) != 3 || x != 'x' || w < 16 || h < 16 || w > 256 ||
      h > 256 || w % 16 || h % 16)
    return false;
  window = cv::Size(w, h);
  return true;
}

CLI::Validator window_size() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        cv::Size unused;
        return parse_window(s, unused) ? std::string() : "is " + s + ", expected WxH, both multiples of 16 from 16 to 256";
      },
      "WxH");
}

}  // namespace

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Learn HOG classes: describe the window (--window) centred on every point of an 8-pixel grid of the\n"
      "labelled training frames by its HOG (Dalal & Triggs: 16x16 blocks, 8x8 cells, 9 bins; the colour\n"
      "images read from the sequences the folders were extracted from) and train a softmax regression over\n"
      "every class on them: all grid points of --channels' classes, one in --negatives of the others, each\n"
      "class weighted by 1 / sqrt(its count), mini-batch Adam with an L2 penalty. Learn it on the training\n"
      "folders only; add-hog-classes then gives every folder, training and test, the channels fHg<class> of\n"
      "--channels' classes (255 times their probabilities), a shape detector for the classes the forest's\n"
      "window means miss. The same folders, options and seed give the same file whatever --threads. See\n"
      "docs/camvid.md, \"HOG classes\".",
      "learn-hog-classes"};
  std::vector<std::string> works, channels;
  std::string out, frames = "0:", window = "32x96";
  stacks::HogLearning opt;
  int threads = 0;
  bool quiet = false;
  app.add_option("WORK", works, "training work folders (from extract-features)")->required();
  app.add_option("--window", window, "HOG window, WxH pixels")->capture_default_str()->check(window_size());
  app.add_option("--channels", opt.channels, "classes add-hog-classes writes a channel of (all their grid points kept)")
      ->delimiter(',')->capture_default_str();
  app.add_option("--negatives", opt.negatives, "one grid point in N of the other classes kept")->capture_default_str()
      ->check(options::in_range(1, 1000));
  app.add_option("--epochs", opt.epochs, "passes over the samples")->capture_default_str()->check(options::in_range(1, 1000));
  app.add_option("--l2", opt.l2, "L2 penalty on the weights")->capture_default_str()->check(options::in_range(0.0, 1.0));
  app.add_option("--learning-rate", opt.learning_rate, "Adam's step size")->capture_default_str()
      ->check(options::in_range(1e-6, 1.0));
  app.add_option("--seed", opt.seed, "seed of the negatives kept and of the batches' order")->capture_default_str()
      ->check(options::any_seed())->check(CLI::Validator(kDecimalDigits).description(""));
  app.add_option("--frames", frames, "frames of each folder sampled, A:B half-open")->capture_default_str();
  add_threads_option(app, threads, "the output does not depend on it");
  app.add_flag("-q,--quiet", quiet, "no progress on stderr");
  app.add_option("-o,--out", out, "the model to write (JSON)")->required();
  return run_tool(app, argc, argv, threads, [&] {
    parse_window(window, opt.window);  // checked by window_size()
    const stacks::FrameRange range = stacks::FrameRange::parse(frames, "--frames");
    const OutputLock one_writer(out, paths_of(works));
    stacks::HogSamples samples =
        stacks::hog_samples(std::vector<fs::path>(works.begin(), works.end()), range, opt, !quiet);
    const int points = samples.descriptors.rows;
    const Json record = provenance(works, frames, opt, samples);
    stacks::HogClassifier model = stacks::learn_hog_classifier(std::move(samples), opt);
    model.provenance = record;
    stacks::save_hog_classifier(out, model);
    std::printf("HOG classes of %zu classes from %d grid points of %zu work folders -> %s\n", model.classes.size(),
                points, works.size(), out.c_str());
    return 0;
  });
}
