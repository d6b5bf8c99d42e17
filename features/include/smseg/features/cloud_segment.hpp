#pragma once
// Point-cloud segmentation by graph cuts, the other systems of our papers (../shared/papers):
//   centroid min-cut (003, Aung & Thein): foreground / background of a cloud seeded by its centroid and
//     a radius R, a k-nearest-neighbour graph with smoothness exp(-d / sigma), one min cut.
// Clouds are read and written through PCL (PCD or PLY; defined in the smseg_cloud library, which links
// PCL); the synthetic tabletop clouds of the tests and benchmarks need no PCL.

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "smseg/io.hpp"

namespace smseg::features {

/// A point cloud with optional colours and labels (class or object ids, -1: none).
struct ColouredCloud {
  std::vector<Eigen::Vector3f> points;
  std::vector<std::array<std::uint8_t, 3>> colours;  ///< RGB, one per point, or empty
  std::vector<int> labels;                           ///< one per point, or empty

  std::size_t size() const { return points.size(); }
  bool has_colours() const { return !colours.empty(); }
  bool has_labels() const { return !labels.empty(); }
  /// Error naming `source`: sizes disagree, non-finite coordinates.
  void validate(const std::string& source) const;
};

/// Reads a PCD or PLY cloud (fields x y z; rgb/rgba and label when present; label 255 or negative
/// reads as -1). Error naming the file when it cannot be read, has no points or a non-finite point.
ColouredCloud read_coloured_cloud(const fs::path& path);

/// Writes the cloud with `labels` (one per point, -1: none -> 255) as pcl::PointXYZRGBL, binary PCD for
/// ".pcd", binary PLY for ".ply"; colour: the point's own, or a colour per label when the cloud has
/// none. Atomic.
void write_labelled_cloud(const fs::path& path, const ColouredCloud& cloud, std::span<const int> labels);

/// A synthetic tabletop: a 2 m x 2 m table top (label 0, world Y up at height 0, centred on the origin)
/// with `objects` objects on it (labels 1..objects: a box, a sphere, a cylinder, ... in distinct
/// colours, 0.3-0.5 m across, spread over the table with free space between them; object 1 at the
/// centre). Points sampled uniformly over the visible surfaces (none under the objects), Gaussian
/// position noise, colour noise.
struct TabletopCloudOptions {
  int points = 20000;     ///< total, >= 100
  int objects = 1;        ///< 1..8
  double object_share = 0.35;  ///< share of the points on the objects, in (0, 1)
  double noise = 0.003;   ///< position noise, metres (standard deviation)
  double colour_noise = 12;    ///< colour noise (standard deviation per channel, 0..255 scale)
  std::uint64_t seed = 1;
  void validate() const;
};
ColouredCloud make_tabletop_cloud(const TabletopCloudOptions& opt);

/// F1 of `predicted == label` against `truth == label` over the points whose truth is >= 0.
/// NaN when neither has any such point.
double f1_score(std::span<const int> truth, std::span<const int> predicted, int label);

// ---- Centroid min-cut (paper 003) -------------------------------------------------------------

enum class MinCutSolver {
  MaxFlow,  ///< the paper's energy, our k-NN graph and libmaxflow
  Pcl       ///< pcl::MinCutSegmentation (its own energy: see below), as the paper's reference [15]
};

/// Paper 003's energy over the k-nearest-neighbour graph: D_p(object) = 1 - P_obj(p),
/// D_p(background) = P_obj(p), P_obj(p) = 1 within distance R of the cloud's centroid (3D), else 0;
/// smoothness lambda * exp(-d(p, q) / sigma) on each neighbour pair whose labels differ. sigma = 0:
/// the mean distance of the points to their k nearest neighbours.
/// With solver Pcl, pcl::MinCutSegmentation with the centroid as its one foreground point, radius R,
/// k neighbours, sigma and source weight: PCL's unary is the distance to the centroid across the up
/// axis (a vertical cylinder: `up` names the cloud's up axis 0 = x, 1 = y, 2 = z) over R against the
/// source weight, and its smoothness exp(-d^2 / sigma^2).
struct CentroidMinCutParams {
  double radius = 0;          ///< R, > 0 (required)
  int neighbours = 10;        ///< k, 1..100
  double sigma = 0;           ///< 0: mean k-NN distance; else > 0
  double lambda = 1.0;        ///< weight of the smoothness term (MaxFlow), >= 0
  double source_weight = 0.8; ///< PCL's foreground weight (Pcl), > 0
  int up = 1;                 ///< up axis for Pcl (0, 1, 2)
  MinCutSolver solver = MinCutSolver::MaxFlow;
  void validate() const;      ///< Error naming the option (--radius, --neighbours, ...)
};

struct CentroidMinCutReport {
  Eigen::Vector3f centroid{0, 0, 0};
  double sigma = 0;           ///< the sigma used
  int seeds = 0;              ///< points within R of the centroid
  double flow = 0;            ///< max-flow value
  double seconds = 0;         ///< graph building and cut (not reading)
};

/// Labels 1 (object) or 0 (background) per point. Error when the cloud is empty or has fewer points than
/// k + 1, or no point lies within R of the centroid (bad seed).
std::vector<int> centroid_mincut(const ColouredCloud& cloud, const CentroidMinCutParams& params,
                                 CentroidMinCutReport* report = nullptr);

}  // namespace smseg::features
