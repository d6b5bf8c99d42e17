// segment-cloud's command line (the run's inputs and outputs here, every method's options from their
// tables) and the choice of the method it asks for.
#include <iostream>
#include <string>
#include <vector>

#include "runs.hpp"
#include "smseg/common/options.hpp"

namespace segment_cloud {

using namespace smseg;

namespace {

void add_io_options(CLI::App& app, SegmentCloudOptions& o) {
  app.add_option("CLOUD", o.input, "input cloud (.pcd or .ply; fields x y z, optional rgb and label; grabcut-sfm: "
                 "default WORK/cloud.pcd)");
  app.add_option("-o,--out", o.out, "output cloud (.pcd or .ply; grabcut-sfm: the mask, .png); the summary goes to the same name + .json, "
                 "written last (the old one is removed first: a summary is only beside the files of its own run)")->required();
  app.add_option("--method", o.method, "centroid-mincut, mrf or grabcut-sfm")->capture_default_str()
      ->check(CLI::IsMember(std::vector<std::string>{"centroid-mincut", "mrf", "grabcut-sfm"}));
  app.add_option("--seeds", o.seeds, "mrf: plane, saliency, or a seed file {\"format\": \"smseg-seeds\", \"version\": 1, \"radius\": r, "
                 "\"seeds\": [{\"label\": 0, \"position\": [x, y, z]}, ...]}")->capture_default_str();
  app.add_option("--make-tabletop", o.make_tabletop, "write a synthetic tabletop cloud of this many points (1..10000000) instead")
      ->check(options::in_range(1, 10000000));
  app.add_option("--objects", o.tab.objects, "--make-tabletop: objects on the table (1..8)")->capture_default_str()
      ->check(options::in_range(1, 8));
  app.add_option("--seed", o.tab.seed, "seed of --make-tabletop and of grabcut-sfm's random draws")->capture_default_str()
      ->check(options::any_seed())->check(CLI::Validator(kDecimalDigits).description(""));
  add_threads_option(app, o.threads);
}

void add_inputs(CLI::App& app, SegmentCloudOptions& o) {
  app.add_option("--sequence", o.sal.sequence,
                 "grabcut-sfm and mrf saliency seeds: the sequence (folder or sequence.json)");
  app.add_option("--work", o.sal.work,
                 "grabcut-sfm and mrf saliency seeds: the extract-features work folder (tracks.json, cloud.pcd)");
  app.add_option("--frame", o.sal.frame,
                 "grabcut-sfm: the frame to segment; mrf saliency seeds: the frame whose image seeds and views the "
                 "cloud (sequence index)")
      ->check(options::in_range(0, 10000000));
}

}  // namespace

void add_options(CLI::App& app, SegmentCloudOptions& o) {
  add_io_options(app, o);
  add_inputs(app, o);
  saliency_run_table().add_to(app, o.sal);
  cloud::mrf_params_table().add_to(app, o.mrf);
  cloud::plane_seed_params_table().add_to(app, o.plane);
  centroid_run_table().add_to(app, o.centroid);
  grabcut_sfm_cli_table().add_to(app, o.gc);
  cloud::table_params_table().add_to(app, o.gc.params.table);
}

int run_method(const CLI::App& app, SegmentCloudOptions& o) {
  const OutputLock one_writer(o.out, {o.input, o.sal.sequence, o.sal.work, o.gc.truth_mask});
  if (o.make_tabletop > 0) {
    o.tab.points = o.make_tabletop;
    const cloud::ColouredCloud c = cloud::make_tabletop_cloud(o.tab);
    begin_output_set(o.out);  // one file, no summary; this cleans up after killed runs
    cloud::write_labelled_cloud(o.out, c, c.labels);
    std::cout << "tabletop cloud: " << c.size() << " points, " << o.tab.objects << " objects -> " << o.out << "\n";
    return 0;
  }
  if (o.method == "mrf" && o.seeds == "saliency") {
    as_usage([&] { o.mrf.validate(); });
    o.sal.input = o.input;
    o.sal.out = o.out;
    return run_saliency_mrf(o.sal, o.mrf);
  }
  if (o.method == "grabcut-sfm") {
    if (app.count("--plane-distance")) o.gc.params.plane_distance = o.plane.plane_distance;
    o.gc.params.seed = o.tab.seed;
    o.gc.box_to_plane_given = app.count("--box-to-plane") > 0;
    o.gc.mask_depth_share_given = app.count("--mask-depth-share") > 0;
    o.gc.sequence = o.sal.sequence;
    o.gc.work = o.sal.work;
    o.gc.frame = o.sal.frame;
    o.gc.cloud = o.input;
    o.gc.out = o.out;
    return run_grabcut_sfm(o.gc);
  }
  if (o.input.empty()) throw Error("", "CLOUD", "an input cloud is required (or --make-tabletop N)");
  if (o.method == "mrf") {
    return run_mrf_on_cloud({o.input, o.out, o.seeds, o.mrf, o.plane});
  }
  if (o.method != "centroid-mincut") throw Error("", "--method", "\"" + o.method + "\" is not a method (centroid-mincut, mrf or grabcut-sfm)");
  o.centroid.input = o.input;
  o.centroid.out = o.out;
  return run_centroid_mincut(o.centroid);
}

}  // namespace segment_cloud
