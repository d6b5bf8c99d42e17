#pragma once
// The benchmarks' default forest and frame when no real data is named (bench_eval, bench_graphcut):
// a forest (K = 400, M = 7) trained on 11 synthetic frames of libforest's make_synthetic, with a class
// signal low enough that its trees grow to a realistic size (as in bench_forest), and one more frame
// (another seed) to label.
#include "smseg/forest/synthetic.hpp"
#include "smseg/forest/train.hpp"

namespace synthetic_bench {

struct ForestAndFrame {
  smseg::forest::Forest forest;
  smseg::forest::SyntheticData frame;  ///< owns the frame to label: frame.data.frames.front()
};

inline ForestAndFrame forest_and_frame(int width, int height) {
  using namespace smseg;
  forest::SyntheticOptions o;
  o.width = width;
  o.height = height;
  o.frames = 11;
  o.seed = 7;
  o.signal = 0.25;
  forest::TrainParams p;
  p.K = 400;
  p.M = 7;
  ForestAndFrame out;
  out.forest = forest::train_forest(forest::make_synthetic(o).data, p);
  o.frames = 1;
  o.seed = 99;
  out.frame = forest::make_synthetic(o);
  return out;
}

}  // namespace synthetic_bench
