#pragma once
// A point cloud seen from one frame of a sequence, for the attention-based MRF of paper 000
// ("Attention-based active 3D point cloud segmentation"): project the cloud into the frame (pinhole,
// z-buffered), find the salient regions of the frame's image (OpenCV's saliency module), seed one object
// label per salient region and the background from the non-salient area, and score a labelling of the
// visible points against the frame's instance image.
//
// Conventions (docs/design.md 3.2): poses are camera-to-world, camera x right, y down, z forward; a world point X
// is at camera coordinates R^T (X - t) and pixel (fx x / z + cx, fy y / z + cy), pixel centres at
// integer coordinates.

#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/cloud/cloud_segment.hpp"
#include "smseg/sequence/sequence.hpp"

namespace smseg::cloud {

struct ViewCamera {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  cv::Size size;
  sequence::Pose pose;  ///< camera-to-world
};

struct ProjectionParams {
  double min_depth = 0.05;   ///< metres in front of the camera
  int splat_radius = 2;      ///< pixels: each point covers a disc of this radius in the z-buffer and picture
  double depth_tolerance = 0.03;  ///< a point is visible within max(this, 2% of its depth) behind the z-buffer
  void validate() const;     ///< Error naming the option (--splat-radius, ...)
};

/// Per cloud point its pixel (rounded) and depth; visible points are in front of the camera, inside the
/// image and not hidden behind nearer points (z-buffer of discs of splat_radius pixels).
struct CloudProjection {
  std::vector<cv::Point> pixel;   ///< per point; (-1, -1) when behind the camera or outside the image
  std::vector<float> depth;       ///< per point, z in the camera (metres); may be <= 0
  std::vector<int> visible;       ///< ascending indices of the visible points
};
CloudProjection project_cloud(const ColouredCloud& cloud, const ViewCamera& camera, const ProjectionParams& params);

struct SaliencyParams {
  /// "colour" (fine-grained saliency of intensity, R-G and B-Y, averaged), "fine-grained"
  /// (StaticSaliencyFineGrained on the image) or "spectral-residual" (StaticSaliencySpectralResidual)
  std::string method = "colour";
  double threshold = 0.3;   ///< on the saliency normalised to 0..1; 0: Otsu's threshold
  double background = 0.5;  ///< background seeds where saliency < background * threshold
  double min_area = 0.002;  ///< share of the image a salient region must cover
  double max_area = 0.04;   ///< a larger salient component is a structure: split at higher levels
  double step = 0.05;       ///< how much higher each split level is
  int blur = 2;             ///< radius of the box filter that smooths the map before thresholding (0: none)
  double scale = 0.5;       ///< the image is resized by this factor before the saliency (coarser conspicuity)
  void validate() const;    ///< Error naming the option (--saliency, --saliency-threshold, ...)
};

struct SalientRegions {
  cv::Mat saliency;    ///< CV_32FC1 in 0..1 (normalised, smoothed)
  cv::Mat regions;     ///< CV_32SC1: 0 = not salient, 1..count = salient region (largest first)
  cv::Mat structure;   ///< CV_8UC1: 255 = part of a salient structure (too large) outside every region
  double threshold = 0;  ///< the threshold used (0..1)
  int count = 0;
};
/// Saliency of a BGR image and its connected salient regions (8-connected, after a 3x3 opening), each of
/// min_area..max_area of the image; a component larger than max_area (a salient structure such as the
/// table under the objects) is thresholded again inside itself `step` higher, recursively, and what is
/// left of it marks `structure`. count may be 0.
SalientRegions salient_regions(const cv::Mat& bgr, const SaliencyParams& params);

/// Seeds for mrf_segment over a sub-cloud: label 0 = the points (indices into `pixels`) whose pixel is
/// not salient (saliency < background * threshold) or in a salient structure outside the regions, label k = the points inside salient region k. A region
/// holding fewer than min_points points is dropped (labels stay consecutive). method = "saliency".
/// background is SaliencyParams::background. Error (field "--seeds saliency") when no point is background
/// or no region keeps enough points. region_of_label: per seed label, its salient region (0: background).
MrfSeeds saliency_seeds(const std::vector<cv::Point>& pixels, const std::vector<Eigen::Vector3f>& positions,
                        const SalientRegions& regions, double background, int min_points,
                        std::vector<int>* region_of_label = nullptr);

/// Splits every object seed label (>= 1) of a sub-cloud into the connected groups of its points linked by
/// 3D distance < `distance` and RGB distance < `colour_tolerance` (salient regions that cover several
/// touching objects in the image, or an object and the table around it, come apart in 3D or colour);
/// groups of fewer than min_points points are dropped, the background (label 0) stays whole. Labels stay
/// consecutive, largest group first per region; region_of_label follows. Error when no object label is left.
void split_seed_regions(const ColouredCloud& view, MrfSeeds& seeds, double distance, double colour_tolerance,
                        int min_points, std::vector<int>* region_of_label = nullptr);

/// Colour for a label in pictures: label 0 (background) grey, then distinct colours (BGR).
cv::Vec3b label_colour(int label);

/// The labelled points splatted into the image (discs of radius pixels, nearest point wins), BGR, black
/// where no point falls. labels[i] < 0: point i is not drawn.
cv::Mat splat_labels(const CloudProjection& projection, std::span<const int> labels, cv::Size size, int radius);

/// Scores a labelling of points against ground-truth object ids (0 = background, 1..K objects, -1 =
/// unknown): each predicted label stands for the ground-truth id it overlaps most (ties: the smaller id);
/// per ground-truth id the F1 of (mapped == id) against (truth == id); the confusion matrix counts points
/// with rows = ground-truth ids 0..K, columns = predicted labels 0..L-1.
struct InstanceScore {
  std::vector<int> label_to_truth;             ///< per predicted label
  std::vector<double> f1;                      ///< per ground-truth id 0..K (NaN when neither side has it)
  std::vector<long> truth_points;              ///< per ground-truth id
  std::vector<std::vector<long>> confusion;    ///< [truth id][predicted label]
};
InstanceScore score_instances(std::span<const int> truth, std::span<const int> predicted, int truth_ids, int labels);

}  // namespace smseg::cloud
