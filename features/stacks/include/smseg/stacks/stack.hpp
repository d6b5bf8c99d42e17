#pragma once
// Feature stacks on disk (docs/design.md section 3.3). A work folder holds
//   stacks.json                   format "smseg-stacks" version 1: the sequence, image size, feature
//                                 names, class names, the frames written, and the options used
//   stacks/NNNNNN.sat.npy         float64, shape (F, H+1, W+1): one summed-area table per feature
//   stacks/NNNNNN.gray.npy        uint8, shape (H, W): the greyscale image (texton tests)
//   stacks/NNNNNN.labels.npy      uint8, shape (H, W): class positions, 255 = void (labelled frames only)
// Every file is a plain .npy that numpy reads (and memory-maps) without our code:
//   sat = numpy.load("work/stacks/000010.sat.npy", mmap_mode="r")   # sat[f, y, x]
// In C++ a FrameStack memory-maps the files and hands the forest its FrameData.

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/sequence/sequence.hpp"
#include "smseg/forest/data.hpp"

namespace smseg::stacks {

inline constexpr const char* kStacksFormat = "smseg-stacks";
inline constexpr int kStacksVersion = 1;

struct StackManifest {
  fs::path work;                      ///< the work folder
  fs::path sequence;                  ///< the sequence folder it was made from
  std::string sequence_name;
  cv::Size size;
  std::vector<std::string> features;  ///< in table order
  std::vector<std::string> classes;   ///< class names; label value i is classes[i]
  std::vector<int> frames;            ///< frames with a stack, ascending
  std::vector<int> labelled_frames;   ///< frames whose stack carries labels, ascending
  Json options = Json::object();      ///< how the stacks were made (front end, feature options)

  fs::path manifest_path() const { return work / "stacks.json"; }
  bool has_frame(int f) const;
  bool is_labelled(int f) const;
};

/// Paths of one frame's files.
fs::path sat_path(const fs::path& work, int frame);
fs::path gray_path(const fs::path& work, int frame);
fs::path labels_path(const fs::path& work, int frame);

/// Writes one frame's files atomically (labels may be empty for an unlabelled frame).
void write_frame_stack(const fs::path& work, int frame, const std::vector<cv::Mat>& sats, const cv::Mat& gray,
                       const cv::Mat& labels);

void save_stack_manifest(const StackManifest& m);
/// Reads and validates work/stacks.json; Error naming the file and field.
StackManifest load_stack_manifest(const fs::path& work);

/// One frame's stack, memory-mapped, validated against the manifest (shape, dtype) on open.
class FrameStack {
 public:
  static FrameStack open(const StackManifest& m, int frame, bool with_labels);
  FrameStack(FrameStack&&) noexcept;
  FrameStack& operator=(FrameStack&&) noexcept;
  ~FrameStack();

  int frame() const { return frame_; }
  const double* sat(int feature) const;  ///< (H+1) x (W+1) row-major
  const std::uint8_t* gray() const;      ///< H x W
  const std::uint8_t* labels() const;    ///< H x W, or nullptr if not opened with labels
  /// The forest's view of this frame (borrowed pointers: keep the FrameStack alive). Its `release`
  /// drops the frame's mapped pages from memory (they are read from the file again when touched).
  forest::FrameData view() const;

 private:
  struct Mapping;
  FrameStack() = default;
  int frame_ = -1;
  cv::Size size_;
  int features_ = 0;
  std::unique_ptr<Mapping> sat_, gray_, labels_;
};

/// A half-open frame range "A:B" (Python style: A included, B excluded; "A:" to the end, ":B" from 0,
/// "A" alone is the single frame A).
struct FrameRange {
  int begin = 0;
  int end = std::numeric_limits<int>::max();
  bool contains(int f) const { return f >= begin && f < end; }
  static FrameRange parse(const std::string& text, const std::string& option);  ///< Error naming option
  std::string str() const;
};

/// Frames of several work folders as the forest's Dataset, with the memory maps that back it.
struct StackSet {
  std::vector<StackManifest> manifests;
  std::vector<FrameStack> stacks;  ///< owns the mappings that dataset.frames point into
  std::vector<std::pair<int, int>> origin;  ///< per dataset frame: (work folder index, frame)
  forest::Dataset dataset;
};

/// What a training read from `set`: per work folder its path, a digest of its stacks.json and the
/// labelled frames used, and the features. Forest parts record it, so that only parts trained on the
/// same data are merged (forest/parts.hpp).
Json training_data_record(const StackSet& set);

/// Opens the frames of `works` inside `range` (labelled only if `labelled_only`; with labels if
/// `with_labels`), selecting `features` by name (empty: all the stack has). All work folders must share
/// image size and class list; Error naming the folder otherwise, or when no frame is selected.
StackSet open_stacks(const std::vector<fs::path>& works, const FrameRange& range, bool labelled_only,
                     bool with_labels, const std::vector<std::string>& features);

/// The frames of `set` that hold no tracked point, as (work folder index, frame): every feature's
/// table sums to zero over the whole image. Trees learn nothing but the class prior from them, and
/// scores on them say nothing of the features (a camera that does not move, blank frames, a front end
/// that found no points); train-forest and eval-forest say so (frames_without_points_message).
std::vector<std::pair<int, int>> frames_without_points(const StackSet& set);

/// One line for the user: "WORK: 3 of 10 frames hold no tracked point (0, 10, 20)", naming each work
/// folder that has such frames (at most a few frame numbers each).
std::string frames_without_points_message(const StackSet& set, const std::vector<std::pair<int, int>>& empty);

}  // namespace smseg::stacks
