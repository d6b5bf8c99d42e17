// segment-cloud: graph-cut segmentation of a point cloud (the systems of ../shared/papers 000 and 003),
// and synthetic tabletop clouds to try them on.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>

#include <tbb/global_control.h>

#include "smseg/cli.hpp"
#include "smseg/features/cloud_segment.hpp"

namespace {

std::string fmt(double v, const char* f = "%.4f") {
  if (std::isnan(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

smseg::Json nan_null(double v) { return std::isnan(v) ? smseg::Json(nullptr) : smseg::Json(v); }

}  // namespace

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Segment a point cloud (PCD or PLY) by graph cuts and write it labelled (pcl::PointXYZRGBL) with a\n"
      "summary OUT.json next to it (parameters, time, and F1 per label when the input carries ground-truth\n"
      "labels).\n"
      "  --method centroid-mincut (Aung & Thein, paper 003): object = min cut seeded by the points within\n"
      "    --radius of the cloud's centroid over a k-NN graph with smoothness exp(-d / sigma); label 1 object,\n"
      "    0 background. --solver maxflow (the paper's energy, libmaxflow) or pcl (pcl::MinCutSegmentation).\n"
      "  --method mrf (paper 000): multi-class MRF; seeds from the supporting plane (--seeds plane: RANSAC plane\n"
      "    = label 0, clusters above it by colour and distance = labels 1..) or a seed file (--seeds FILE.json);\n"
      "    a colour GMM per label, contrast-sensitive Potts on the 4-NN graph, alpha-expansion, GMMs re-fitted\n"
      "    until the energy settles. With ground truth: F1 per object and the confusion matrix.\n"
      "With --make-tabletop N, writes a synthetic tabletop cloud of N points instead (label 0 table,\n"
      "1..--objects objects) to -o.",
      "segment-cloud"};
  std::string input, out, method = "centroid-mincut", solver = "maxflow", up = "y";
  features::CentroidMinCutParams mc;
  features::TabletopCloudOptions tab;
  features::MrfParams mrf;
  features::PlaneSeedParams plane;
  std::string seeds = "plane";
  double mrf_lambda = mrf.lambda;
  int make_tabletop = 0, threads = 0, truth_object = 1;
  app.add_option("CLOUD", input, "input cloud (.pcd or .ply; fields x y z, optional rgb and label)");
  app.add_option("-o,--out", out, "output cloud (.pcd or .ply); the summary goes to the same name + .json")->required();
  app.add_option("--method", method, "centroid-mincut or mrf")->capture_default_str();
  app.add_option("--seeds", seeds, "mrf: plane, or a seed file {\"format\": \"smseg-seeds\", \"version\": 1, \"radius\": r, "
                 "\"seeds\": [{\"label\": 0, \"position\": [x, y, z]}, ...]}")->capture_default_str();
  app.add_option("--components", mrf.components, "mrf: Gaussians per colour model")->capture_default_str();
  app.add_option("--mrf-lambda", mrf_lambda, "mrf: weight of the pairwise term")->capture_default_str();
  app.add_option("--iterations", mrf.max_iterations, "mrf: at most this many GMM re-estimation rounds")->capture_default_str();
  app.add_option("--plane-distance", plane.plane_distance, "mrf plane seeds: RANSAC inlier distance")->capture_default_str();
  app.add_option("--colour-tolerance", plane.colour_tolerance, "mrf plane seeds: RGB distance within one cluster")
      ->capture_default_str();
  app.add_option("--min-cluster", plane.min_cluster, "mrf plane seeds: smallest cluster that seeds an object")
      ->capture_default_str();
  app.add_option("--radius", mc.radius, "centroid-mincut: R, points within R of the centroid seed the object (required)");
  app.add_option("--neighbours", mc.neighbours, "centroid-mincut: k of the k-nearest-neighbour graph (mrf uses 000's 4)")
      ->capture_default_str();
  app.add_option("--sigma", mc.sigma, "smoothness scale (0: mean distance of the points to their k nearest neighbours)")
      ->capture_default_str();
  app.add_option("--lambda", mc.lambda, "centroid-mincut (maxflow): weight of the smoothness term")->capture_default_str();
  app.add_option("--solver", solver, "centroid-mincut: maxflow or pcl")->capture_default_str();
  app.add_option("--source-weight", mc.source_weight, "centroid-mincut (pcl): PCL's foreground weight")
      ->capture_default_str();
  app.add_option("--up", up, "centroid-mincut (pcl): the cloud's up axis, x, y or z")->capture_default_str();
  app.add_option("--truth-object", truth_object,
                 "centroid-mincut: the ground-truth label of the object, for F1 (when the cloud has labels)")
      ->capture_default_str();
  app.add_option("--make-tabletop", make_tabletop, "write a synthetic tabletop cloud of this many points instead");
  app.add_option("--objects", tab.objects, "--make-tabletop: objects on the table (1..8)")->capture_default_str();
  app.add_option("--seed", tab.seed, "--make-tabletop: seed")->capture_default_str();
  app.add_option("--threads", threads, "worker threads (0: all cores)")->capture_default_str();
  return run_tool(app, argc, argv, [&] {
    if (threads < 0) throw Error("", "--threads", "must be 0 (all cores) or a number of threads");
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0)
      limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
    if (make_tabletop > 0) {
      tab.points = make_tabletop;
      const features::ColouredCloud c = features::make_tabletop_cloud(tab);
      features::write_labelled_cloud(out, c, c.labels);
      std::cout << "tabletop cloud: " << c.size() << " points, " << tab.objects << " objects -> " << out << "\n";
      return 0;
    }
    if (input.empty()) throw Error("", "CLOUD", "an input cloud is required (or --make-tabletop N)");
    if (method == "mrf") {
      mrf.lambda = mrf_lambda;
      mrf.neighbours = 4;
      mrf.validate();
      plane.validate();
      const features::ColouredCloud cloud = features::read_coloured_cloud(input);
      const auto t0 = std::chrono::steady_clock::now();
      features::MrfSeeds sd;
      features::MrfReport rep;
      std::vector<int> labels;
      try {
        sd = seeds == "plane" ? features::plane_seeds(cloud, plane) : features::file_seeds(cloud, seeds);
        labels = features::mrf_segment(cloud, sd, mrf, &rep);
      } catch (const Error& e) {
        throw Error(e.file().empty() ? input : e.file(), e.field(), e.reason());
      }
      const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      features::write_labelled_cloud(out, cloud, labels);
      Json seeds_json = Json::array();
      for (std::size_t l = 0; l < sd.regions.size(); ++l)
        seeds_json.push_back({{"label", l},
                              {"points", sd.regions[l].size()},
                              {"position", {sd.positions[l].x(), sd.positions[l].y(), sd.positions[l].z()}}});
      Json summary = {{"format", "smseg-segment-cloud"},
                      {"version", 1},
                      {"input", input},
                      {"method", method},
                      {"params",
                       {{"seeds", seeds},
                        {"neighbours", mrf.neighbours},
                        {"components", mrf.components},
                        {"lambda", mrf.lambda},
                        {"iterations", mrf.max_iterations},
                        {"tolerance", mrf.tolerance},
                        {"plane_distance", plane.plane_distance},
                        {"colour_tolerance", plane.colour_tolerance},
                        {"min_cluster", plane.min_cluster}}},
                      {"points", cloud.size()},
                      {"labels", rep.labels},
                      {"seeds", seeds_json},
                      {"iterations", rep.iterations},
                      {"energies", rep.energies},
                      {"beta", rep.beta},
                      {"seconds_mrf", rep.seconds},
                      {"seconds_total", total}};
      std::string line = input + ": " + std::to_string(cloud.size()) + " points, " + std::to_string(rep.labels) +
                         " labels (" + sd.method + " seeds), " + std::to_string(rep.iterations) + " rounds, " +
                         fmt(total * 1000, "%.1f") + " ms";
      if (cloud.has_labels()) {
        // Each predicted label stands for the ground-truth label most of its seed carries.
        const std::vector<int> map = features::seed_truth(cloud, sd);
        std::vector<int> mapped(labels.size());
        for (std::size_t i = 0; i < labels.size(); ++i) mapped[i] = map[std::size_t(labels[i])];
        int truth_max = 0;
        for (int t : cloud.labels) truth_max = std::max(truth_max, t);
        Json f1 = Json::array();
        line += ", F1";
        for (int t = 0; t <= truth_max; ++t) {
          const double v = features::f1_score(cloud.labels, mapped, t);
          f1.push_back({{"truth_label", t}, {"f1", nan_null(v)}});
          line += " " + std::to_string(t) + ":" + fmt(v, "%.3f");
        }
        Json confusion = Json::array();  // rows: truth labels 0..max; columns: predicted labels 0..L-1
        for (int t = 0; t <= truth_max; ++t) {
          std::vector<long> row(std::size_t(rep.labels), 0);
          for (std::size_t i = 0; i < labels.size(); ++i)
            if (cloud.labels[i] == t) ++row[std::size_t(labels[i])];
          confusion.push_back(row);
        }
        summary["seed_truth"] = map;
        summary["f1"] = f1;
        summary["confusion"] = confusion;
      }
      write_json_atomic(out + ".json", summary);
      std::cout << line << " -> " << out << "\n";
      return 0;
    }
    if (method != "centroid-mincut") throw Error("", "--method", "\"" + method + "\" is not a method (centroid-mincut or mrf)");
    if (solver == "maxflow") mc.solver = features::MinCutSolver::MaxFlow;
    else if (solver == "pcl") mc.solver = features::MinCutSolver::Pcl;
    else throw Error("", "--solver", "\"" + solver + "\" is not a solver (maxflow or pcl)");
    if (up == "x" || up == "y" || up == "z") mc.up = up[0] - 'x';
    else throw Error("", "--up", "must be x, y or z");
    mc.validate();
    const features::ColouredCloud cloud = features::read_coloured_cloud(input);
    features::CentroidMinCutReport rep;
    std::vector<int> labels;
    try {
      labels = features::centroid_mincut(cloud, mc, &rep);
    } catch (const Error& e) {
      throw Error(input, e.field(), e.reason());
    }
    features::write_labelled_cloud(out, cloud, labels);
    Json summary = {{"format", "smseg-segment-cloud"},
                    {"version", 1},
                    {"input", input},
                    {"method", method},
                    {"params",
                     {{"radius", mc.radius},
                      {"neighbours", mc.neighbours},
                      {"sigma", mc.sigma},
                      {"sigma_used", rep.sigma},
                      {"lambda", mc.lambda},
                      {"solver", solver},
                      {"source_weight", mc.source_weight},
                      {"up", up}}},
                    {"points", cloud.size()},
                    {"centroid", {rep.centroid.x(), rep.centroid.y(), rep.centroid.z()}},
                    {"seeds", rep.seeds},
                    {"object_points", std::count(labels.begin(), labels.end(), 1)},
                    {"max_flow", rep.flow},
                    {"seconds", rep.seconds}};
    std::string line = input + ": " + std::to_string(cloud.size()) + " points, " + std::to_string(rep.seeds) +
                       " seeds within R, " + std::to_string(std::count(labels.begin(), labels.end(), 1)) +
                       " object points, sigma " + fmt(rep.sigma, "%.5f") + ", " + fmt(rep.seconds * 1000, "%.1f") +
                       " ms";
    if (cloud.has_labels()) {
      std::vector<int> truth(cloud.size());
      for (std::size_t i = 0; i < truth.size(); ++i)
        truth[i] = cloud.labels[i] < 0 ? -1 : (cloud.labels[i] == truth_object ? 1 : 0);
      const double f1 = features::f1_score(truth, labels, 1);
      summary["truth_object"] = truth_object;
      summary["f1_object"] = nan_null(f1);
      summary["f1_background"] = nan_null(features::f1_score(truth, labels, 0));
      line += ", F1 (object) " + fmt(f1);
    }
    write_json_atomic(out + ".json", summary);
    std::cout << line << " -> " << out << "\n";
    return 0;
  });
}
