#pragma once
// k-nearest-neighbour graphs of clouds (PCL kd-tree), shared by the cloud segmenters. Internal.
#include <vector>

#include "smseg/cloud/cloud_segment.hpp"

namespace smseg::cloud {

struct KnnGraph {
  struct Pair {
    int i = 0, j = 0;  ///< i < j
    float distance = 0;
  };
  int k = 0;
  std::vector<int> neighbours;   ///< n x k, -1 where fewer were found
  std::vector<float> distances;  ///< n x k, Euclidean
  std::vector<Pair> pairs;       ///< each unordered neighbour pair once, sorted
  double mean_distance = 0;      ///< mean over all neighbour distances
};

/// Error when k < 1 or the cloud has fewer than k + 1 points. Parallel over points; the result does
/// not depend on the thread count.
KnnGraph knn_graph(const ColouredCloud& cloud, int k);

}  // namespace smseg::cloud
