// add-textons: work folders whose stacks also hold texton channels (textons.hpp).
#include <cstdio>
#include <iostream>

#include "extending_cli.hpp"
#include "smseg/stacks/extension.hpp"
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
  std::string dictionary_file;
  stacks::ExtendingCli cli;
  app.add_option("DICTIONARY", dictionary_file, "texton dictionary (learn-textons)")->required();
  cli.add_to(app);
  return run_tool(app, argc, argv, cli.threads, [&] {
    const stacks::TextonDictionary dictionary = stacks::load_texton_dictionary(dictionary_file);
    const int written = stacks::write_extending_folders(
        cli.works, cli.out, cli.frames, {dictionary_file}, [&](const auto& ins, const auto& outs, const auto& range) {
          return stacks::add_texton_channels(dictionary, dictionary_file, ins, outs, range, !cli.quiet);
        });
    std::printf("%d frames of %zu work folders with %d texton channels -> %s\n", written, cli.works.size(),
                dictionary.count(), cli.out.c_str());
    return 0;
  });
}
