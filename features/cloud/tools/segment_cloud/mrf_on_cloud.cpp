// segment-cloud --method mrf with plane or file seeds, on a cloud file (paper 000).
#include <chrono>
#include <iostream>

#include "runs.hpp"

namespace segment_cloud {

namespace {

/// F1 per ground-truth label of the cloud, each predicted label standing for the ground-truth label most
/// of its seed carries, and the confusion matrix, into the summary and the line.
void score_against_labels(const smseg::cloud::ColouredCloud& cloud, const smseg::cloud::MrfSeeds& sd,
                          const std::vector<int>& labels, int label_count, smseg::Json& summary, std::string& line) {
  using namespace smseg;
  // Each predicted label stands for the ground-truth label most of its seed carries.
  const std::vector<int> map = cloud::seed_truth(cloud, sd);
  std::vector<int> mapped(labels.size());
  for (std::size_t i = 0; i < labels.size(); ++i) mapped[i] = map[std::size_t(labels[i])];
  int truth_max = 0;
  for (int t : cloud.labels) truth_max = std::max(truth_max, t);
  Json f1 = Json::array();
  line += ", F1";
  for (int t = 0; t <= truth_max; ++t) {
    const double v = cloud::f1_score(cloud.labels, mapped, t);
    f1.push_back({{"truth_label", t}, {"f1", nan_null(v)}});
    line += " " + std::to_string(t) + ":" + fmt(v, "%.3f");
  }
  Json confusion = Json::array();  // rows: truth labels 0..max; columns: predicted labels 0..L-1
  for (int t = 0; t <= truth_max; ++t) {
    std::vector<long> row(std::size_t(label_count), 0);
    for (std::size_t i = 0; i < labels.size(); ++i)
      if (cloud.labels[i] == t) ++row[std::size_t(labels[i])];
    confusion.push_back(row);
  }
  summary["seed_truth"] = map;
  summary["f1"] = f1;
  summary["confusion"] = confusion;
}

/// The run's parameters: the seeds, the MRF's and the plane seeding's (also with a seed file).
smseg::Json params_json(const MrfCloudRun& run) {
  smseg::Json params = smseg::cloud::mrf_params_table().to_json(run.mrf);
  params.update(smseg::cloud::plane_seed_params_table().to_json(run.plane));
  params["seeds"] = run.seeds;
  return params;
}

}  // namespace

/// segment-cloud --method mrf with --seeds plane or a seed file, on a cloud file.
int run_mrf_on_cloud(const MrfCloudRun& run) {
  using namespace smseg;
  const std::string& input = run.input;
  const std::string& out = run.out;
  const std::string& seeds = run.seeds;
  const std::string method = "mrf";
  const cloud::MrfParams& mrf = run.mrf;
  const cloud::PlaneSeedParams& plane = run.plane;
  as_usage([&] {  // the options alone, before anything is read: bad usage (exit status 2)
    mrf.validate();
    plane.validate();
  });
  const cloud::ColouredCloud cloud = cloud::read_coloured_cloud(input);
  const auto t0 = std::chrono::steady_clock::now();
  cloud::MrfSeeds sd;
  cloud::MrfReport rep;
  std::vector<int> labels;
  try {
    sd = seeds == "plane" ? cloud::plane_seeds(cloud, plane) : cloud::file_seeds(cloud, seeds);
    labels = cloud::mrf_segment(cloud, sd, mrf, &rep);
  } catch (const Error& e) {
    throw Error(e.file().empty() ? input : e.file(), e.field(), e.reason());
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  begin_output_set(out);
  cloud::write_labelled_cloud(out, cloud, labels);
  Json seeds_json = Json::array();
  for (std::size_t l = 0; l < sd.regions.size(); ++l)
    seeds_json.push_back({{"label", l},
                          {"points", sd.regions[l].size()},
                          {"position", {sd.positions[l].x(), sd.positions[l].y(), sd.positions[l].z()}}});
  Json summary = {{"format", "smseg-segment-cloud"},
                  {"version", 1},
                  {"input", input},
                  {"method", method},
                  {"params", params_json(run)},
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
  if (cloud.has_labels()) score_against_labels(cloud, sd, labels, rep.labels, summary, line);
  write_json_atomic(out + ".json", summary);
  std::cout << line << " -> " << out << "\n";
  return 0;
}

}  // namespace segment_cloud
