// make-sequence: renders the synthetic stereo video (the toolkit's embedded default dataset).
#include <algorithm>
#include <iostream>
#include <map>
#include <regex>

#include "smseg/common/cli.hpp"
#include "smseg/common/output.hpp"
#include "smseg/common/option_names.hpp"
#include "smseg/common/options.hpp"
#include "smseg/synth/synth.hpp"

int main(int argc, char** argv) {
  using namespace smseg::sequence;
  smseg::synth::SynthOptions o;
  CLI::App app{"Render a synthetic stereo video as a small indoor robot would record it: a rectified stereo\n"
               "rig (12 cm baseline, ~1 m above the floor) driving through a corridor with turns or around a\n"
               "cluttered lab, with a walking person, textured surfaces, lighting changes and sensor noise.\n"
               "Writes left/right images, a label image and ground-truth depth for every frame, and the\n"
               "manifest (sequence.json) with calibration and ground-truth camera poses. Classes: floor, wall,\n"
               "ceiling, furniture, obstacle, person. The tabletop scene (for the point-cloud segmenters): a\n"
               "camera circling a table with 3-6 boxes and cylinders on it; classes floor, wall, ceiling,\n"
               "table, object, and an instance image (object ids) per labelled frame in instances/.\n"
               "Same options and seed give byte-identical files.",
               "make-sequence"};
  std::string out, size = "320x240", montage;
  int montage_frames = 4;
  double montage_scale = 1.0;
  bool quiet = false;
  smseg::synth::synth_options_table().add_to(app, o);
  app.add_option("--size", size, "image size WIDTHxHEIGHT")->capture_default_str();
  app.add_option("-o,--output", out, "output folder (created; existing files of the same names are replaced)")
      ->required();
  app.add_option("--montage", montage,
                 "also write a montage PNG: rows of frames, columns left image | labels | depth (default: none)");
  app.add_option("--montage-frames", montage_frames, "number of frames (rows) in the montage (default 4)")
      ->check(smseg::options::in_range(1, 100000));
  app.add_option("--montage-scale", montage_scale, "scale of each montage panel (default 1)")
      ->check(smseg::options::in_range(0.1, 4.0));
  app.add_flag("-q,--quiet", quiet, "no progress on stderr (default: progress shown)");
  return smseg::run_tool(app, argc, argv, [&] {
    std::smatch m;
    if (!std::regex_match(size, m, std::regex(R"((\d{1,5})[xX](\d{1,5}))")))
      throw smseg::UsageError("", "--size", "is \"" + size + "\", expected WIDTHxHEIGHT, e.g. 320x240");
    o.width = std::stoi(m[1]);
    o.height = std::stoi(m[2]);
    o.progress = !quiet;
    smseg::OptionNames option_of = smseg::synth::synth_options_table().option_names();
    option_of["width"] = "--size (width)";
    option_of["height"] = "--size (height)";
    smseg::validate_options(option_of, [&] { o.validate(); });
    const smseg::OutputLock one_writer(out);  // no inputs (--montage is a second output, often inside OUT)
    const Sequence seq = smseg::synth::make_sequence(o, out);
    if (!montage.empty()) {
      std::vector<int> frames;
      const int n = std::min(montage_frames, seq.frame_count());
      for (int i = 0; i < n; ++i)
        frames.push_back(n == 1 ? 0 : static_cast<int>(std::lround(double(i) * (seq.frame_count() - 1) / (n - 1))));
      write_image_atomic(montage, smseg::synth::make_montage(seq, frames, 10.0, montage_scale));
    }
    std::cout << seq.manifest.string() << ": " << seq.frame_count() << " frames of " << seq.size.width << "x"
              << seq.size.height << ", " << seq.labelled_frames.size() << " labelled, scene " << o.scene << ", seed "
              << o.seed << "\n";
    return 0;
  });
}
