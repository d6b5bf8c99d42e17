#pragma once
// Point-cloud segmentation by graph cuts, the other systems of our papers (../shared/papers):
//   centroid min-cut (003, Aung & Thein): foreground / background of a cloud seeded by its centroid and
//     a radius R, a k-nearest-neighbour graph with smoothness exp(-d / sigma), one min cut.
//   multi-class MRF (000, "Attention-based active 3D point cloud segmentation"): one label per seeded
//     object plus the supporting plane, a colour GMM per label, contrast-sensitive Potts over the
//     4-nearest-neighbour graph, alpha-expansion, GMMs re-estimated until the energy settles.
// Clouds (PCD or PLY) are read by our own reader and written through PCL (both defined in the smseg_cloud
// library, which links PCL); the synthetic tabletop clouds of the tests and benchmarks need no PCL.

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "smseg/common/io.hpp"

namespace smseg::cloud {

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
/// reads as -1, as does any label above 255). PCD: DATA ascii, binary or binary_compressed; PLY 1.0:
/// ascii or binary of either byte order, colours from red/green/blue or a packed rgb. Our own reader,
/// not PCL's (which damaged the heap on malformed files): every count is checked against the file's
/// size before anything is allocated. Error naming the file, in one line, when it cannot be read, is
/// malformed, has no points or a non-finite point.
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

// ---- Multi-class MRF (paper 000) ----------------------------------------------------------------

/// Seeds: for each label, the points that initialise its colour model. Label 0 is the supporting plane
/// (background) when plane seeding made it.
struct MrfSeeds {
  std::vector<std::vector<int>> regions;  ///< per label, point indices (each non-empty)
  std::vector<Eigen::Vector3f> positions; ///< per label, where the seed is (region mean)
  std::string method;                     ///< "plane" | "file"
};

/// Geometric plane seeding (000 IV-A.1): RANSAC plane (pcl::SACSegmentation, inliers within
/// plane_distance) = label 0; the points above it (the side holding most off-plane points, farther than
/// plane_distance) clustered by distance (cluster_tolerance; 0: 3 x the mean 4-NN distance) and colour
/// (neighbours within colour_tolerance in RGB) with pcl::ConditionalEuclideanClustering; clusters of at
/// least min_cluster points become labels 1.. (largest first). Error when there is no plane or no cluster.
struct PlaneSeedParams {
  double plane_distance = 0.01;  ///< metres
  double cluster_tolerance = 0;  ///< metres; 0: 3 x mean 4-NN distance
  double colour_tolerance = 60;  ///< RGB distance between neighbours of one cluster
  int min_cluster = 50;
  void validate() const;
};
MrfSeeds plane_seeds(const ColouredCloud& cloud, const PlaneSeedParams& params);

/// Seeds from a JSON file {"format": "smseg-seeds", "version": 1, "radius": r,
///   "seeds": [{"label": 0, "position": [x, y, z]}, ...]}: label l's region = the points within r of
/// its positions; labels 0..L-1 each used. Error naming the file for a bad file or a seed with no point
/// within r.
MrfSeeds file_seeds(const ColouredCloud& cloud, const fs::path& path);

struct MrfParams {
  int neighbours = 4;        ///< k of the k-NN graph (000: 4)
  int components = 5;        ///< K of each label's colour GMM (GrabCut's 5)
  double lambda = 2.0;       ///< weight of the pairwise term, >= 0
  int max_iterations = 10;   ///< GMM re-estimation rounds, >= 1
  double tolerance = 1e-3;   ///< stop when the energy changes by less than this fraction
  void validate() const;
};

struct MrfReport {
  int labels = 0;
  int iterations = 0;
  double beta = 0;
  double mean_distance = 0;
  std::vector<double> energies;  ///< after each round's alpha-expansion
  double seconds = 0;            ///< graph, GMMs and cuts (not seeding)
};

/// The MRF labelling (labels 0..L-1 of the seeds): unary -log sum_k pi_k N(c; mu_k, Sigma_k) of the
/// label's RGB GMM (000 eq. 1, without the constant (2 pi)^-3/2), pairwise
/// lambda * (dbar / dist(i, j)) * exp(-beta |c_i - c_j|^2) [x_i != x_j] on the k-NN graph (000 eq. 2;
/// the distance normalised by the mean neighbour distance dbar so that lambda has no unit), beta =
/// 1 / (2 <|c_i - c_j|^2>) over the graph's edges; alpha-expansion, then each GMM refitted to the points
/// of its label, until the energy changes by less than the tolerance. Needs colours.
std::vector<int> mrf_segment(const ColouredCloud& cloud, const MrfSeeds& seeds, const MrfParams& params,
                             MrfReport* report = nullptr);

/// Maps each predicted label to the ground-truth label most of its seed region carries (-1: none).
std::vector<int> seed_truth(const ColouredCloud& cloud, const MrfSeeds& seeds);

}  // namespace smseg::cloud
