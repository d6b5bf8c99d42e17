// add-people: work folders whose stacks also hold people-detector channels (people.hpp).
#include <cstdio>

#include "extending_cli.hpp"
#include "smseg/stacks/extension.hpp"
#include "smseg/stacks/people.hpp"

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "People-detector channels: write, for each work folder, a work folder OUT/<its name> whose stacks hold\n"
      "all of WORK's features and then fHogD and fHogI: at each pixel the highest score of the windows of\n"
      "two pretrained HOG people detectors (OpenCV's Daimler 48x96 and default 64x128, over the image\n"
      "enlarged twice) whose person region covers it, 0 where none does, so that a forest window's mean says\n"
      "how much of it a detector takes for a person (Ladicky et al. 2010's detector potentials). OUT stores\n"
      "only those channels and reads the others, the greyscale and the labels from WORK, which its\n"
      "stacks.json names with a digest (WORK moved or extracted again makes OUT refused: run add-people\n"
      "again). The colour images come from the sequences the folders were extracted from; about 0.4 s of\n"
      "CPU a 480x360 frame. OUT is built beside itself and swapped in whole at the end. See docs/camvid.md,\n"
      "\"People detectors\".",
      "add-people"};
  stacks::ExtendingCli cli;
  cli.add_to(app);
  return run_tool(app, argc, argv, cli.threads, [&] {
    const int written = stacks::write_extending_folders(cli.works, cli.out, cli.frames, {}, [&](const auto& ins, const auto& outs,
                                                                                     const auto& range) {
      return stacks::add_people_channels(ins, outs, range, !cli.quiet);
    });
    std::printf("%d frames of %zu work folders with %zu people-detector channels -> %s\n", written, cli.works.size(),
                stacks::people_feature_names().size(), cli.out.c_str());
    return 0;
  });
}
