// extract-features: a sequence -> tracks, camera path (stereo, or monocular structure from motion) and
// per-frame feature stacks.
#include <iostream>

#include "smseg/cloud/cloud_io.hpp"
#include "smseg/common/cli.hpp"
#include "smseg/common/output.hpp"
#include "smseg/common/option_names.hpp"
#include "smseg/common/options.hpp"
#include "smseg/stacks/extract.hpp"

int main(int argc, char** argv) {
  using namespace smseg;
  using namespace smseg::sequence;
  using namespace smseg::sfm;
  using namespace smseg::stacks;
  using namespace smseg::cloud;
  CLI::App app{
      "Run the front end of a sequence and write its feature stacks (thesis 3.2.2, 3.2.3, 3.2.6).\n"
      "Stereo (default for stereo sequences): disparity (block matching with a left-right check by\n"
      "default), Shi-Tomasi corners followed frame to frame by KLT (or SIFT keypoints matched by\n"
      "symmetric nearest neighbours, the thesis's way, with --tracker descriptors), tracks and their\n"
      "filters, camera motion (Arun SVD in RANSAC). Monocular structure from motion (always for mono\n"
      "sequences, --motion sfm for the left images of a stereo one): KLT or descriptor tracks, focal\n"
      "length from --focal, the manifest or self-calibration, essential-matrix initialisation, PnP, key\n"
      "frames and bundle adjustment (Ceres), metric scale from the camera height over a RANSAC ground\n"
      "plane (docs/sfm.md). Then per frame the features fH fC fOx fOy fD fR (and with --appearance nine\n"
      "image channels), each stored exactly and compactly (the summed-area tables the forest reads are\n"
      "built when a frame is read), the greyscale image and, for labelled frames, the labels:\n"
      "WORK/stacks.json and WORK/stacks/*.values.bin (docs/formats.md). Also WORK/tracks.json\n"
      "(tracks, camera path, front-end summary), WORK/cloud.pcd (one point per track, class colours and\n"
      "labels; opens in pcl_viewer) and WORK/path.png (top-down camera path and cloud). Parallel over\n"
      "frames; frames already written are skipped unless --force: a killed or failed run resumes, keeping\n"
      "every stack on disk made with the same options from the same sequence (the front end runs again).",
      "extract-features"};
  std::string seq_dir, work, frames = "0:", preview;
  ExtractOptions opt;
  int threads = 0;
  bool quiet = false, verbose = false;
  app.add_option("SEQUENCE", seq_dir, "sequence folder (holding sequence.json)")->required();
  app.add_option("-o,--out", work, "work folder to write")->required();
  app.add_option("--frames", frames, "frames whose stacks are written, A:B half-open (the front end sees all)")
      ->capture_default_str();
  extract_options_table().add_to(app, opt);
  app.add_option("--preview", preview, "comma-separated frames to write false-colour feature pictures of (WORK/preview/)");
  add_threads_option(app, threads, "the output does not depend on it");
  auto* quiet_flag = app.add_flag("-q,--quiet", quiet, "nothing on stderr but errors (no progress, no solver warnings)");
  app.add_flag("-v,--verbose", verbose, "also the solver libraries' warnings and one summary per bundle adjustment (SfM)")
      ->excludes(quiet_flag);
  return run_tool(app, argc, argv, threads, [&] {
    const OptionNames option_of = extract_options_table().option_names();
    validate_options(option_of, [&] {
      opt.resolve();
      opt.validate();
    });
    opt.frames = as_usage([&] { return FrameRange::parse(frames, "--frames"); });
    for (const auto& item : split_comma_list(preview))
      opt.preview.push_back(as_usage([&] { return FrameRange::parse(item, "--preview").begin; }));
    opt.progress = !quiet;
    set_solver_verbose(verbose);
    const OutputLock one_writer(work, {seq_dir});
    const Sequence seq = load_sequence(seq_dir);
    const ExtractReport r = extract_features(seq, work, opt);
    write_cloud(fs::path(work) / "cloud.pcd", r.cloud, seq);
    std::cout << report_text(r, work);
    return 0;
  });
}
