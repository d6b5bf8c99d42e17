// make-sequence: renders the synthetic stereo video (the toolkit's embedded default dataset).
#include <algorithm>
#include <iostream>
#include <map>
#include <regex>

#include "smseg/common/cli.hpp"
#include "smseg/common/option_names.hpp"
#include "smseg/synth/synth.hpp"

int main(int argc, char** argv) {
  using namespace smseg::features;
  synth::SynthOptions o;
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
  app.add_option("--scene", o.scene,
                 "scene: corridor, lab, or tabletop (a table with 3-6 objects in a room, the camera circling "
                 "it; also writes instance images) (default corridor)")
      ->check(CLI::IsMember({"corridor", "lab", "tabletop"}));
  app.add_option("--seed", o.seed, "random seed for layout, textures, people and noise (default 1)")
      ->check(smseg::kDecimalDigits);
  app.add_option("--frames", o.frames, "number of frames (default 300)");
  app.add_option("--size", size, "image size WIDTHxHEIGHT (default 320x240)");
  app.add_option("--label-every", o.label_every,
                 "mark every Nth frame as labelled in the manifest; label images are written for every frame "
                 "(default 10)");
  app.add_option("--fps", o.fps, "frame rate in Hz (default 12, as in the thesis)");
  app.add_option("--baseline", o.baseline, "stereo baseline in metres (default 0.12)");
  app.add_option("--camera-height", o.camera_height,
                 "camera height above the floor in metres (default 1.0; tabletop 1.15, the table top + 0.4)");
  app.add_option("--hfov", o.hfov_deg, "horizontal field of view in degrees (default 66)");
  app.add_option("--speed", o.speed, "mean robot speed in m/s (default 0.45)");
  app.add_option("--noise", o.noise_sigma, "sensor read noise, grey levels of 255 (default 2)");
  app.add_option("-o,--output", out, "output folder (created; existing files of the same names are replaced)")
      ->required();
  app.add_option("--montage", montage,
                 "also write a montage PNG: rows of frames, columns left image | labels | depth (default: none)");
  app.add_option("--montage-frames", montage_frames, "number of frames (rows) in the montage (default 4)");
  app.add_option("--montage-scale", montage_scale, "scale of each montage panel (default 1)");
  app.add_flag("-q,--quiet", quiet, "no progress on stderr (default: progress shown)");
  return smseg::run_tool(app, argc, argv, [&] {
    std::smatch m;
    if (!std::regex_match(size, m, std::regex(R"((\d{1,5})[xX](\d{1,5}))")))
      throw smseg::UsageError("", "--size", "is \"" + size + "\", expected WIDTHxHEIGHT, e.g. 320x240");
    o.width = std::stoi(m[1]);
    o.height = std::stoi(m[2]);
    o.progress = !quiet;
    if (montage_frames < 1) throw smseg::UsageError("", "--montage-frames", "must be at least 1");
    static const smseg::OptionNames kOptionOf = {
        {"scene", "--scene"},         {"frames", "--frames"},   {"width", "--size (width)"},
        {"height", "--size (height)"}, {"label_every", "--label-every"}, {"fps", "--fps"},
        {"baseline", "--baseline"},   {"camera_height", "--camera-height"}, {"hfov_deg", "--hfov"},
        {"speed", "--speed"},         {"noise_sigma", "--noise"}};
    smseg::validate_options(kOptionOf, [&] { o.validate(); });
    const Sequence seq = synth::make_sequence(o, out);
    if (!montage.empty()) {
      std::vector<int> frames;
      const int n = std::min(montage_frames, seq.frame_count());
      for (int i = 0; i < n; ++i)
        frames.push_back(n == 1 ? 0 : static_cast<int>(std::lround(double(i) * (seq.frame_count() - 1) / (n - 1))));
      write_image_atomic(montage, synth::make_montage(seq, frames, 10.0, montage_scale));
    }
    std::cout << seq.manifest.string() << ": " << seq.frame_count() << " frames of " << seq.size.width << "x"
              << seq.size.height << ", " << seq.labelled_frames.size() << " labelled, scene " << o.scene << ", seed "
              << o.seed << "\n";
    return 0;
  });
}
