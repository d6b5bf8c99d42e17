// segment-cloud: graph-cut segmentation of a point cloud (the systems of ../shared/papers 000 and 003),
// and synthetic tabletop clouds to try them on. This file is the command line; each method runs in its
// own part (segment_cloud/*.cpp).
#include "smseg/common/cli.hpp"
#include "segment_cloud/runs.hpp"

int main(int argc, char** argv) {
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
      "    --seeds saliency --sequence SEQ --work WORK --frame N: the cloud of an extract-features work folder\n"
      "    (WORK/cloud.pcd unless CLOUD is given) seen from frame N (WORK's camera pose, z-buffered), coloured\n"
      "    from its left image; object seeds = the salient regions of the image (OpenCV saliency, thresholded,\n"
      "    connected components; a region larger than --max-area is split at higher thresholds; each region's\n"
      "    points split by 3D distance and colour), background seeds = its non-salient area (and the rest of\n"
      "    the large regions). Only the visible points are labelled. Writes OUT, OUT.json, the labels\n"
      "    splatted into the frame (OUT.png) and the saliency map (OUT.saliency.png); F1 per object and the\n"
      "    confusion matrix against the frame's instance image (make-sequence --scene tabletop) when it has one.\n"
      "  --method grabcut-sfm (GrabCutSFM, paper 001): the object nearest the camera in one frame of a work\n"
      "    folder (--sequence SEQ --work WORK --frame N; poses and focal from WORK/tracks.json). Defaults with\n"
      "    no distance in metres (--support table): the frame's dense depth (stereo) or the tracks around it,\n"
      "    the table found as the highest wide horizontal patch with points standing on it, the points on it\n"
      "    clustered at the cloud's own spacing, the nearest cluster; --support plane is 001's recipe (RANSAC\n"
      "    plane removal, 3D k-means --k on WORK/cloud.pcd or CLOUD, the nearest cluster centre). Then 2D\n"
      "    RANSAC outlier removal, the bounding box, OpenCV grabCut. -o MASK.png; also\n"
      "    MASK.overlay.png, the baselines' masks MASK.kmeans2.png (2D k-means, k = 2, on colour) and MASK.box.png\n"
      "    (grabCut on the truth's bounding box), and MASK.png.json with F1 of all three against --truth-label\n"
      "    NAME (the frame's label image), --truth-instance nearest|all|ID (instance images) or --truth-mask FILE.\n"
      "With --make-tabletop N, writes a synthetic tabletop cloud of N points instead (label 0 table,\n"
      "1..--objects objects) to -o.",
      "segment-cloud"};
  segment_cloud::SegmentCloudOptions o;
  segment_cloud::add_options(app, o);
  return smseg::run_tool(app, argc, argv, o.threads, [&] { return segment_cloud::run_method(app, o); });
}
