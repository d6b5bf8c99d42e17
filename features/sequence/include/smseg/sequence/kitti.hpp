#pragma once
// KITTI adapter: turns a rectified stereo slice of the KITTI odometry benchmark into a stereo sequence of
// our format, referring to the images where they are (no copies). Two layouts are read:
//   - KITTI's own: image_0/ (left) and image_1/ (right) PNGs, calib.txt ("P0: 12 numbers" per line),
//     optional times.txt (seconds per frame) and poses.txt (or --poses FILE, e.g. poses/00.txt);
//   - ../shared/data/kitti-stereo: image_l/ and image_r/, calib.txt (two lines of 12 numbers: P0, P1),
//     poses.txt.
// The ground-truth poses (left camera in the first camera's frame, [R | t] row-major, KITTI axes x right,
// y down, z forward) become our world frame: Y up, origin on the ground under the first camera.

#include <optional>
#include <string>
#include <vector>

#include "smseg/sequence/sequence.hpp"

namespace smseg::sequence {

struct KittiImportOptions {
  double camera_height = 1.65;   ///< metres; KITTI's cameras are mounted 1.65 m above the road
  double fps = 10.0;             ///< frame rate when there is no times.txt (KITTI records at 10 Hz)
  std::string name;              ///< sequence name; default: the folder's name
  fs::path poses;                ///< poses file; default: DIR/poses.txt when it exists
  fs::path classes;              ///< CamVid-style classes.csv; default: CamVid's 11 road classes
  /// Pixels added to the disparities (Calibration::disparity_offset); unset: calib.txt's
  /// P1 cx - P0 cx (0 in KITTI's own files, whose images share one principal point).
  std::optional<double> disparity_offset;
  void validate() const;         ///< Error naming the option if a value is out of range
};

/// The left and right projection matrices of calib.txt (rows of 12 numbers, optionally "P0:"-prefixed;
/// the first two are the left and right greyscale cameras). Errors name the file and line.
struct KittiCalibration {
  double fx = 0, fy = 0, cx = 0, cy = 0, baseline = 0;  ///< pixels; baseline in metres
  double cx_right = 0;                                   ///< P1's principal point, pixels
};
KittiCalibration read_kitti_calibration(const fs::path& file);

/// KITTI poses (one [R | t] per line) -> our camera-to-world poses (Y up, origin on the ground under the
/// first camera, camera_height below it). Errors name the file and line.
std::vector<Pose> read_kitti_poses(const fs::path& file, double camera_height);

/// CamVid's 11 classes and void, with their colours: the default class list of an unlabelled road
/// sequence, so that a forest trained on CamVid applies to it.
std::vector<ClassInfo> camvid_road_classes(ClassInfo* void_class);

/// Reads the slice in dir (either layout) and writes out/sequence.json. Checks that every frame has a
/// left and a right image of one size and that the poses, when given, count one per frame.
Sequence import_kitti(const fs::path& dir, const fs::path& out, const KittiImportOptions& opt);

}  // namespace smseg::sequence
