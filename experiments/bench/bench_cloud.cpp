// Speed of the point-cloud segmenters (features/cloud_segment.hpp) on synthetic tabletop clouds, at the
// sizes of paper 003's time table (36056, 68042, 177828 points) and 100k. Targets (graph-cut issue):
// centroid min-cut on 100k points under 2 s (2 cores).
// Run: bench_cloud --benchmark_out=cloud.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <map>

#include "smseg/features/cloud_segment.hpp"

using namespace smseg;

namespace {

const features::ColouredCloud& tabletop(int points, int objects) {
  static std::map<std::pair<int, int>, features::ColouredCloud> cache;
  auto it = cache.find({points, objects});
  if (it == cache.end()) {
    features::TabletopCloudOptions o;
    o.points = points;
    o.objects = objects;
    it = cache.emplace(std::make_pair(points, objects), features::make_tabletop_cloud(o)).first;
  }
  return it->second;
}

// Args: points, solver (0 maxflow, 1 pcl)
void BM_CentroidMinCut(benchmark::State& state) {
  const features::ColouredCloud& c = tabletop(static_cast<int>(state.range(0)), 1);
  features::CentroidMinCutParams p;
  p.solver = state.range(1) == 0 ? features::MinCutSolver::MaxFlow : features::MinCutSolver::Pcl;
  p.radius = p.solver == features::MinCutSolver::MaxFlow ? 0.35 : 0.27;
  std::vector<int> labels;
  for (auto _ : state) {
    labels = features::centroid_mincut(c, p);
    benchmark::DoNotOptimize(labels.data());
  }
  std::vector<int> truth(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) truth[i] = c.labels[i] == 1 ? 1 : 0;
  state.counters["f1"] = features::f1_score(truth, labels, 1);
  state.counters["points"] = double(c.size());
  state.SetLabel(p.solver == features::MinCutSolver::MaxFlow ? "maxflow" : "pcl");
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

}  // namespace

BENCHMARK_MAIN();
