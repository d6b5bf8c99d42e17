#pragma once
// The sequence format (docs/design.md section 3.1): a folder with a JSON manifest `sequence.json` that names
// the frames, the calibration, the labelled frames and the classes. The reader validates everything it
// can without decoding images; images are validated (existence, size, label values) when loaded.
//
// Internally a label image is CV_8UC1 holding the class's position in `classes` (0..C-1), or kVoid.

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/sequence/npy.hpp"
#include "smseg/common/io.hpp"

namespace smseg::sequence {

inline constexpr std::uint8_t kVoid = 255;  ///< label of void / ignored pixels, everywhere in memory
inline constexpr const char* kSequenceFormat = "smseg-sequence";
inline constexpr int kSequenceVersion = 1;
inline constexpr const char* kManifestName = "sequence.json";

enum class SequenceKind { Stereo, Mono };
enum class LabelEncoding { Rgb, Index };

struct ClassInfo {
  std::string name;
  int file_value = 0;                ///< the pixel value in an index-encoded label file
  std::array<std::uint8_t, 3> rgb{};  ///< display colour (and the file colour for RGB encoding)
};

struct Calibration {
  std::optional<double> fx, fy;  ///< focal length in pixels; may be unknown for mono
  double cx = 0, cy = 0;         ///< principal point in pixels
  std::optional<double> baseline;  ///< metres, stereo only
  /// Pixels added to every computed disparity (stereo): the right image's principal point minus the
  /// left's, cx_right - cx_left, for a pair whose images are offset against each other (a disparity is
  /// x_left - x_right; the true one is that plus this). 0 for a pair rectified to one principal point.
  double disparity_offset = 0;
};

/// A camera pose: camera-to-world rotation R (row-major 3x3) and camera centre t in the world frame,
/// world Y up, origin on the ground under the first camera position (docs/design.md 3.2). Camera frame: x right,
/// y down, z forward (OpenCV convention).
struct Pose {
  std::array<double, 9> R{1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::array<double, 3> t{0, 0, 0};
};

struct FrameEntry {
  fs::path left;       ///< relative to the sequence root, or absolute
  fs::path right;      ///< stereo: right image (empty when a disparity is given instead)
  fs::path disparity;  ///< stereo: precomputed left disparity (float NPY or 16-bit PNG / 256), optional
  fs::path label;      ///< label image, required for labelled frames, optional for others
  fs::path gt_depth;   ///< ground-truth depth (float32 NPY, metres, 0 = none), synthetic sequences
  fs::path instances;  ///< object instance image (8-bit PNG, 1..K = object id, 0 = none), optional
  double time = 0;     ///< seconds since the first frame
};

struct Sequence {
  fs::path manifest;  ///< the manifest file this came from (for error messages)
  fs::path root;      ///< the folder relative paths are resolved against
  std::string name;
  SequenceKind kind = SequenceKind::Stereo;
  cv::Size size;  ///< width x height of every image
  Calibration calibration;
  std::optional<double> camera_height;  ///< metres above the ground
  std::vector<FrameEntry> frames;
  std::vector<int> labelled_frames;  ///< indices into frames, ascending, each with a label path
  LabelEncoding label_encoding = LabelEncoding::Rgb;
  std::vector<ClassInfo> classes;  ///< the learnable classes
  ClassInfo void_class;            ///< the ignore label
  std::vector<Pose> gt_poses;      ///< ground-truth camera poses, one per frame, or empty
  Json extra = Json::object();     ///< free-form provenance (generator, seed, source dataset)

  int frame_count() const { return static_cast<int>(frames.size()); }
  bool is_labelled(int frame) const;
  /// The end of the processed range [first, last) with last = -1 meaning the end of the sequence;
  /// Error(manifest, "frames") when the range does not lie inside the sequence.
  int range_end(int first, int last) const;
  fs::path resolve(const fs::path& p) const { return p.is_absolute() ? p : root / p; }

  /// Images; each throws Error naming the file for a missing/unreadable file or a wrong size.
  cv::Mat load_left(int frame) const;        ///< CV_8UC3 BGR
  cv::Mat load_left_gray(int frame) const;   ///< CV_8UC1
  cv::Mat load_right_gray(int frame) const;  ///< CV_8UC1, stereo with right images only
  cv::Mat load_disparity(int frame) const;   ///< CV_32FC1, <= 0 where unknown
  cv::Mat load_gt_depth(int frame) const;    ///< CV_32FC1 metres, 0 where unknown
  /// CV_8UC1 class positions / kVoid; a pixel whose colour or value is not in the class list (nor
  /// void) is an Error naming the file, the pixel and the value.
  cv::Mat load_labels(int frame) const;
  /// CV_8UC1 object ids (0 = not an object); Error when the frame has none or the file is not an 8-bit
  /// single-channel image of the sequence's size.
  cv::Mat load_instances(int frame) const;
  bool has_instances(int frame) const;
};

/// Reads and validates `dir/sequence.json` (or a manifest file given directly).
Sequence load_sequence(const fs::path& dir_or_manifest);

/// Also decodes every image the manifest names and checks its size and label values (slow: used by
/// `check-sequence` and tests).
void validate_images(const Sequence& seq);

/// Writes the manifest atomically to seq.root / sequence.json (paths stored as given).
void save_sequence(const Sequence& seq);

Json sequence_to_json(const Sequence& seq);

/// Colour a label image (class positions / kVoid) with the classes' display colours; BGR for OpenCV.
cv::Mat colour_labels(const cv::Mat& labels, const Sequence& seq);

/// Writes an image atomically (encoded in memory, then write_file_atomic); extension picks the codec.
void write_image_atomic(const fs::path& path, const cv::Mat& image);

}  // namespace smseg::sequence
