// Speed of the point-cloud segmenters (features/cloud_segment.hpp) on synthetic tabletop clouds, at the
// sizes of paper 003's time table (36056, 68042, 177828 points) and 100k. Targets (graph-cut issue):
// centroid min-cut on 100k points under 2 s; the MRF on 50k points with 5 labels under 5 s (2 cores).
// Run: bench_cloud --benchmark_out=cloud.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <map>

#include "smseg/cloud/cloud_segment.hpp"

using namespace smseg;

namespace {

const cloud::ColouredCloud& tabletop(int points, int objects) {
  static std::map<std::pair<int, int>, cloud::ColouredCloud> cache;
  auto it = cache.find({points, objects});
  if (it == cache.end()) {
    cloud::TabletopCloudOptions o;
    o.points = points;
    o.objects = objects;
    it = cache.emplace(std::make_pair(points, objects), cloud::make_tabletop_cloud(o)).first;
  }
  return it->second;
}

// Args: points, solver (0 maxflow, 1 pcl)
void BM_CentroidMinCut(benchmark::State& state) {
  const cloud::ColouredCloud& c = tabletop(static_cast<int>(state.range(0)), 1);
  cloud::CentroidMinCutParams p;
  p.solver = state.range(1) == 0 ? cloud::MinCutSolver::MaxFlow : cloud::MinCutSolver::Pcl;
  p.radius = p.solver == cloud::MinCutSolver::MaxFlow ? 0.35 : 0.27;
  std::vector<int> labels;
  for (auto _ : state) {
    labels = cloud::centroid_mincut(c, p);
    benchmark::DoNotOptimize(labels.data());
  }
  std::vector<int> truth(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) truth[i] = c.labels[i] == 1 ? 1 : 0;
  state.counters["f1"] = cloud::f1_score(truth, labels, 1);
  state.counters["points"] = double(c.size());
  state.SetLabel(p.solver == cloud::MinCutSolver::MaxFlow ? "maxflow" : "pcl");
}
BENCHMARK(BM_CentroidMinCut)
    ->ArgNames({"points", "pcl"})
    ->Args({36056, 0})
    ->Args({68042, 0})
    ->Args({100000, 0})
    ->Args({177828, 0})
    ->Args({36056, 1})
    ->Args({100000, 1})
    ->Args({177828, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

// The multi-class MRF on a tabletop of 4 objects (5 labels with the table). Arg: points;
// seeding 1: plane seeding timed too, 0: seeds made before the loop.
void BM_Mrf(benchmark::State& state) {
  const cloud::ColouredCloud& c = tabletop(static_cast<int>(state.range(0)), 4);
  cloud::MrfSeeds seeds = cloud::plane_seeds(c, {});
  cloud::MrfReport rep;
  std::vector<int> labels;
  for (auto _ : state) {
    if (state.range(1)) seeds = cloud::plane_seeds(c, {});
    labels = cloud::mrf_segment(c, seeds, {}, &rep);
    benchmark::DoNotOptimize(labels.data());
  }
  const std::vector<int> map = cloud::seed_truth(c, seeds);
  std::vector<int> mapped(labels.size());
  for (std::size_t i = 0; i < labels.size(); ++i) mapped[i] = map[std::size_t(labels[i])];
  double worst = 1;
  for (int k = 0; k <= 4; ++k) worst = std::min(worst, cloud::f1_score(c.labels, mapped, k));
  state.counters["labels"] = rep.labels;
  state.counters["rounds"] = rep.iterations;
  state.counters["min_f1"] = worst;
  state.counters["points"] = double(c.size());
}
BENCHMARK(BM_Mrf)
    ->ArgNames({"points", "seeding"})
    ->Args({50000, 0})
    ->Args({50000, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

}  // namespace

BENCHMARK_MAIN();
