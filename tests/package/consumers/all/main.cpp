// One call into each library of the package; the cloud module's through PCL (its min-cut segmenter, and
// a PCD file written by PCL's io and read back by our reader). Usage: all-consumer SCRATCH_FOLDER
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "smseg/cloud/cloud_segment.hpp"
#include "smseg/common/error.hpp"
#include "smseg/common/io.hpp"
#include "smseg/eval/metrics.hpp"
#include "smseg/experiments/config.hpp"
#include "smseg/forest/tabular.hpp"
#include "smseg/frontend/gravity.hpp"
#include "smseg/graphcut/graphcut.hpp"
#include "smseg/sequence/npy.hpp"
#include "smseg/sfm/sfm.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/synth/synth.hpp"

int main(int argc, char** argv) try {
  using namespace smseg;
  if (argc != 2) {
    std::cerr << "usage: all-consumer SCRATCH_FOLDER\n";
    return 2;
  }
  const fs::path scratch = argv[1];
  int failures = 0;
  const auto check = [&](const char* module, bool ok, const std::string& what) {
    std::cout << module << ": " << what << (ok ? "" : "  <- wrong") << "\n";
    failures += !ok;
  };

  write_file_atomic(scratch / "note.txt", "smseg");
  check("common", read_file(scratch / "note.txt") == "smseg", "a file written atomically and read back");

  std::vector<float> values;
  std::vector<std::uint8_t> labels;
  for (int i = 0; i < 100; ++i) values.push_back(float(i)), labels.push_back(i < 50 ? 0 : 1);
  const auto trees = forest::grow_tabular_forest(values, 1, labels, 2, 3, 2, 1, forest::Score::InformationGain);
  std::vector<double> acc;
  const float row = 80;
  check("forest", forest::tabular_posterior(trees, &row, 2, acc) == 1, "a 3-tree forest on a threshold");

  check("sequence", sequence::make_npy_header("<f4", {2, 3}).starts_with("\x93NUMPY"), "an .npy header");

  synth::SynthOptions synth_options;
  synth_options.frames = 1;
  check("synth", !synth::build_scene(synth_options).quads.empty(), "the corridor's geometry");

  check("frontend", std::string(frontend::gravity_method_name(frontend::GravityMethod::Estimate)) == "estimate",
        "a gravity method's name");
  check("sfm", std::string(sfm::sfm_tracker_name(sfm::SfmTracker::Klt)) == "klt", "a tracker's name");
  check("stacks", stacks::structure_feature_names().size() == 6, "the structure features' names");

  graphcut::FlowGraph graph;
  graph.source = {3, 0};
  graph.sink = {0, 2};
  graph.edges = {{0, 1, 5, 0}};
  check("graphcut", graphcut::max_flow(graph) == 2, "a two-node max flow");

  cloud::TabletopCloudOptions cloud_options;
  cloud_options.points = 3000;
  const cloud::ColouredCloud cloud = cloud::make_tabletop_cloud(cloud_options);
  cloud::CentroidMinCutParams mincut;
  mincut.radius = 0.3;
  mincut.solver = cloud::MinCutSolver::Pcl;
  const std::vector<int> segmented = cloud::centroid_mincut(cloud, mincut);
  cloud::write_labelled_cloud(scratch / "cloud.pcd", cloud, segmented);
  const cloud::ColouredCloud back = cloud::read_coloured_cloud(scratch / "cloud.pcd");
  check("cloud", back.size() == cloud.size() && back.labels == segmented,
        "PCL's min cut of a tabletop, written by PCL as PCD and read back");

  eval::Confusion confusion(2);
  confusion.add(0, 0, 3);
  confusion.add(1, 0, 1);
  check("eval", confusion.total() == 4, "a confusion matrix");

  check("experiments", experiments::json_hash(Json{{"a", 1}}).size() == 16, "a configuration's hash");

  std::cout << (failures ? "some libraries answered wrong\n" : "every library answered\n");
  return failures ? 1 : 0;
} catch (const smseg::Error& e) {
  std::cerr << "all-consumer: error: " << e.what() << "\n";
  return 1;
}
