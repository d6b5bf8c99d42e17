// check-sequence: validates a sequence (manifest and every image it names) and summarises it.
#include <iostream>

#include "smseg/common/cli.hpp"
#include "smseg/sequence/sequence.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Validate a sequence: its manifest and every image it names (sizes, label colours or\n"
               "values, instance images), then print a one-paragraph summary. Exit 1 with one line naming the file and\n"
               "the problem if anything is wrong.",
               "check-sequence"};
  std::string dir;
  bool quick = false;
  app.add_option("SEQUENCE", dir, "sequence folder (holding sequence.json) or manifest file")->required();
  app.add_flag("--quick", quick, "check the manifest and that files exist, without decoding images");
  return smseg::run_tool(app, argc, argv, [&] {
    using namespace smseg::sequence;
    const Sequence seq = load_sequence(dir);
    if (!quick) validate_images(seq);
    std::cout << seq.manifest.string() << ": OK: " << (seq.kind == SequenceKind::Stereo ? "stereo" : "mono")
              << ", " << seq.frame_count() << " frames of " << seq.size.width << "x" << seq.size.height << ", "
              << seq.labelled_frames.size() << " labelled, " << seq.classes.size() << " classes";
    if (seq.calibration.fx) std::cout << ", fx " << *seq.calibration.fx;
    int instances = 0;
    for (int f = 0; f < seq.frame_count(); ++f) instances += seq.has_instances(f);
    if (instances > 0) std::cout << ", " << instances << " instance images";
    std::cout << (quick ? " (images not decoded)" : "") << "\n";
    return 0;
  });
}
