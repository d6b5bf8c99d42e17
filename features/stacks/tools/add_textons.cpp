// add-textons: work folders whose stacks also hold texton channels (textons.hpp).
#include <cstdio>
#include <iostream>

#include "smseg/common/cli.hpp"
#include "smseg/common/options.hpp"
#include "smseg/common/output.hpp"
#include "smseg/stacks/textons.hpp"

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Texton channels: write, for each work folder, a work folder OUT/<its name> whose stacks hold all of\n"
      "WORK's features and then fTx0..fTx<K-1>, 1 where the pixel's texton (its nearest centre of\n"
      "DICTIONARY, from learn-textons) is K and 0 elsewhere, so that a forest window's mean of fTxK is the\n"
      "share of texton K in the window. OUT stores only those channels (about 70 kB a 480x360 frame for\n"
      "32 textons): it reads the others, the greyscale and the labels from WORK, which its stacks.json\n"
      "names with a digest (WORK moved or extracted again makes OUT refused: run add-textons again).\n"
      "The colour images come from the sequences the folders were extracted from. OUT is built beside\n"
      "itself and swapped in whole at the end. See docs/camvid.md, \"Textons\".",
      "add-textons"};
  std::string dictionary_file, out, frames = "0:";
  std::vector<std::string> works;
  int threads = 0;
  bool quiet = false;
  app.add_option("DICTIONARY", dictionary_file, "texton dictionary (learn-textons)")->required();
  app.add_option("WORK", works, "work folders (from extract-features, or folders that extend them)")->required();
  app.add_option("--frames", frames, "frames written, A:B half-open")->capture_default_str();
  add_threads_option(app, threads, "the output does not depend on it");
  app.add_flag("-q,--quiet", quiet, "no progress on stderr");
  app.add_option("-o,--out", out, "output folder: OUT/<name of each WORK>/")->required();
  return run_tool(app, argc, argv, threads, [&] {
    const stacks::FrameRange range = stacks::FrameRange::parse(frames, "--frames");
    const OutputLock one_writer(out, paths_of(works, {dictionary_file}));
    const stacks::TextonDictionary dictionary = stacks::load_texton_dictionary(dictionary_file);
    FolderReplacement replacement(out);
    const std::vector<fs::path> outs = folders_by_name(works, replacement.staging());
    const int written = stacks::add_texton_channels(dictionary, dictionary_file,
                                                    std::vector<fs::path>(works.begin(), works.end()), outs, range, !quiet);
    replacement.commit();
    std::printf("%d frames of %zu work folders with %d texton channels -> %s\n", written, works.size(),
                dictionary.count(), out.c_str());
    return 0;
  });
}
