// segment-cloud --method centroid-mincut on a cloud file (Aung & Thein, paper 003).
#include <algorithm>
#include <iostream>

#include "runs.hpp"

namespace segment_cloud {

const smseg::options::Table<CentroidRun>& centroid_run_table() {
  using smseg::cloud::option_fields::one_of;
  static const smseg::options::Table<CentroidRun> table = [] {
    smseg::options::Table<CentroidRun> t("centroid-mincut", smseg::cloud::kSegmentCloudSurfaces);
    t.include(smseg::cloud::centroid_mincut_params_table(), [](auto& r) -> auto& { return r.mc; });
    one_of(t, "solver", "--solver", "centroid-mincut: maxflow or pcl", [](auto& r) -> auto& { return r.solver; },
           {"maxflow", "pcl"});
    one_of(t, "up", "--up", "centroid-mincut (pcl): the cloud's up axis, x, y or z", [](auto& r) -> auto& { return r.up; },
           {"x", "y", "z"});
    t.number("truth_object", "--truth-object",
             "centroid-mincut: the ground-truth label of the object, for F1 (when the cloud has labels)",
             [](auto& r) -> auto& { return r.truth_object; }, 0, 1000000)
        .only(smseg::options::kCommandLine);  // the summary gives it beside the F1, not in the params
    return t;
  }();
  return table;
}

/// segment-cloud --method centroid-mincut on a cloud file.
int run_centroid_mincut(const CentroidRun& run) {
  using namespace smseg;
  const std::string& input = run.input;
  const std::string& out = run.out;
  const std::string& solver = run.solver;
  const std::string& up = run.up;
  const std::string method = "centroid-mincut";
  const int truth_object = run.truth_object;
  cloud::CentroidMinCutParams mc = run.mc;
  as_usage([&] {  // the options alone, before anything is read: bad usage (exit status 2)
    if (solver == "maxflow") mc.solver = cloud::MinCutSolver::MaxFlow;
    else if (solver == "pcl") mc.solver = cloud::MinCutSolver::Pcl;
    else throw Error("", "--solver", "\"" + solver + "\" is not a solver (maxflow or pcl)");
    if (up == "x" || up == "y" || up == "z") mc.up = up[0] - 'x';
    else throw Error("", "--up", "must be x, y or z");
    mc.validate();
  });
  const cloud::ColouredCloud cloud = cloud::read_coloured_cloud(input);
  cloud::CentroidMinCutReport rep;
  std::vector<int> labels;
  try {
    labels = cloud::centroid_mincut(cloud, mc, &rep);
  } catch (const Error& e) {
    throw Error(input, e.field(), e.reason());
  }
  begin_output_set(out);
  cloud::write_labelled_cloud(out, cloud, labels);
  Json summary = {{"format", "smseg-segment-cloud"},
                  {"version", 1},
                  {"input", input},
                  {"method", method},
                  {"params", centroid_run_table().to_json(run)},
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
    const double f1 = cloud::f1_score(truth, labels, 1);
    summary["truth_object"] = truth_object;
    summary["f1_object"] = nan_null(f1);
    summary["f1_background"] = nan_null(cloud::f1_score(truth, labels, 0));
    line += ", F1 (object) " + fmt(f1);
  }
  summary["params"]["sigma_used"] = rep.sigma;
  write_json_atomic(out + ".json", summary);
  std::cout << line << " -> " << out << "\n";
  return 0;
}

}  // namespace segment_cloud
