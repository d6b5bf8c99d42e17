// add-hog-classes: work folders whose stacks also hold HOG class channels (hog_classes.hpp).
#include <cstdio>

#include "extending_cli.hpp"
#include "smseg/stacks/extension.hpp"
#include "smseg/stacks/hog_classes.hpp"

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "HOG class channels: write, for each work folder, a work folder OUT/<its name> whose stacks hold all\n"
      "of WORK's features and then fHg<class> for each class the MODEL (from learn-hog-classes) names in\n"
      "its channels: 255 times the class's probability under MODEL's softmax regression of the HOG window\n"
      "around the pixel (bilinear between the 8-pixel grid's windows, rounded: a byte a pixel on disk), so\n"
      "that a forest window's mean says how much of it has that class's shape. OUT stores only those\n"
      "channels and reads the others, the greyscale and the labels from WORK, which its stacks.json names\n"
      "with a digest (WORK moved or extracted again makes OUT refused: run add-hog-classes again). The\n"
      "colour images come from the sequences the folders were extracted from. OUT is built beside itself\n"
      "and swapped in whole at the end. See docs/camvid.md, \"HOG classes\".",
      "add-hog-classes"};
  std::string model_file;
  stacks::ExtendingCli cli;
  app.add_option("MODEL", model_file, "HOG class model (learn-hog-classes)")->required();
  cli.add_to(app);
  return run_tool(app, argc, argv, cli.threads, [&] {
    const stacks::HogClassifier model = stacks::load_hog_classifier(model_file);
    const int written = stacks::write_extending_folders(
        cli.works, cli.out, cli.frames, {model_file}, [&](const auto& ins, const auto& outs, const auto& range) {
          return stacks::add_hog_class_channels(model, model_file, ins, outs, range, !cli.quiet);
        });
    std::printf("%d frames of %zu work folders with %zu HOG class channels -> %s\n", written, cli.works.size(),
                model.channels.size(), cli.out.c_str());
    return 0;
  });
}
