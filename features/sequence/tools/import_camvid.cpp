// import-camvid: CamVid-style folder -> one mono sequence manifest per contiguous run.
#include <cstdio>
#include <iostream>
#include <sstream>

#include "smseg/common/cli.hpp"
#include "smseg/common/output.hpp"
#include "smseg/common/options.hpp"
#include "smseg/sequence/camvid.hpp"

int main(int argc, char** argv) {
  using namespace smseg::sequence;
  CLI::App app{"Import a CamVid-style folder (frames.csv, classes.csv, image and label folders) as mono\n"
               "sequences: one sequence.json per contiguous run of a CamVid sequence within one split\n"
               "(the 15 Hz run 0016E5_07959..08159 is one, each 1 Hz run another). Images are referred to\n"
               "where they are, not copied. Void is the ignore label. OUT/index.json lists the runs.",
               "import-camvid"};
  std::string dir, out, splits = "train,val";
  CamvidImportOptions opt;
  double focal = 0;
  app.add_option("DIR", dir, "CamVid folder, e.g. ../shared/data/camvid")->required();
  app.add_option("-o,--out", out, "output folder for the sequence manifests")->required();
  app.add_option("--split", splits, "comma-separated split names from frames.csv")->capture_default_str();
  app.add_option("--camera-height", opt.camera_height, "camera height above the road in metres (assumed)")
      ->capture_default_str()->check(smseg::options::in_range(0.001, 10000.0));
  app.add_option("--focal", focal, "focal length in pixels, if known (default: unknown, estimated later)")
      ->check(smseg::options::in_range(1.0, 1e6));
  app.add_option("--max-gap", opt.max_gap, "a gap of more video frames than this starts a new run")
      ->capture_default_str()->check(smseg::options::in_range(1, 1000000));
  return smseg::run_tool(app, argc, argv, [&] {
    opt.splits.clear();
    std::stringstream ss(splits);
    for (std::string s; std::getline(ss, s, ',');)
      if (!s.empty()) opt.splits.push_back(s);
    if (app.count("--focal")) opt.focal = focal;
    const smseg::OutputLock one_writer(out, {dir});
    const auto runs = import_camvid(dir, out, opt);
    int total = 0;
    for (const auto& r : runs) {
      char rate[32] = "single frame";
      if (r.frame_gap > 0) std::snprintf(rate, sizeof rate, "%.3g Hz", opt.video_fps / r.frame_gap);
      std::cout << r.split << "\t" << r.name << "\t" << r.frames << " frames\t" << rate << "\n";
      total += r.frames;
    }
    std::cout << runs.size() << " sequences, " << total << " frames -> " << out << "/index.json\n";
    return 0;
  });
}
