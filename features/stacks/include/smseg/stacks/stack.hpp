#pragma once
// Feature stacks on disk (docs/design.md section 3.3, docs/formats.md). A work folder holds
//   stacks.json                   format "smseg-stacks" version 2: the sequence, image size, feature
//                                 names, class names, the frames written, the options used, and for a
//                                 folder that extends another (add-context) its "base"
//   stacks/NNNNNN.values.bin      the frame's feature rasters (each in the smallest exact type, packed;
//                                 appearance channels as the colour image they are made from), its
//                                 greyscale image and its labels (labelled frames; 255 = void)
// The summed-area tables the forest reads are built in memory when a frame is opened, by the same
// cv::integral over the same doubles as extraction: bit for bit the tables version 1 stored.
// A folder with a base stores only its own channels (after the base's) and reads the rest, the
// greyscale and the labels from the base, whose stacks.json must be the one it was made from.
// Version 1 folders (still read) stored the tables themselves as plain .npy files:
//   stacks/NNNNNN.sat.npy         float64, shape (F, H+1, W+1): one summed-area table per feature
//   stacks/NNNNNN.gray.npy        uint8, shape (H, W): the greyscale image (texton tests)
//   stacks/NNNNNN.labels.npy      uint8, shape (H, W): class positions, 255 = void (labelled frames only)

#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/sequence/sequence.hpp"
#include "smseg/forest/data.hpp"
#include "smseg/stacks/exposure.hpp"
#include "smseg/stacks/mirror.hpp"

namespace smseg::stacks {

inline constexpr const char* kStacksFormat = "smseg-stacks";
/// The names of add-context's posterior channels start with it ("fCtx:Road"; eval/context.hpp makes
/// them): spelled here, below eval, so that stacks can tell them apart (mirror.cpp).
inline constexpr const char* kContextChannelPrefix = "fCtx:";
inline constexpr int kStacksVersion = 2;

/// What a folder that extends another (add-context's output) reads from it.
struct StackBase {
  fs::path work;                      ///< the base work folder (absolute)
  std::string stacks_json_fnv1a64;    ///< its stacks.json's digest when this folder was written
  std::vector<std::string> features;  ///< the base's features this folder reads (its first features)
};

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
  int version = kStacksVersion;       ///< 1: .npy tables per frame; 2: values files
  std::optional<StackBase> base;      ///< version 2: the folder this one extends
  std::shared_ptr<const StackManifest> base_manifest;  ///< loaded and checked with it

  fs::path manifest_path() const { return work / "stacks.json"; }
  bool has_frame(int f) const;
  bool is_labelled(int f) const;
  /// The features this folder's own files hold: all, or those after the base's.
  std::size_t own_features() const { return features.size() - (base ? base->features.size() : 0); }
  /// The file that holds frame f's labels (through the base, if any).
  fs::path labels_file(int f) const;
};

/// Paths of one frame's files: the values file (version 2), the .npy files (version 1).
fs::path values_path(const fs::path& work, int frame);
fs::path sat_path(const fs::path& work, int frame);
fs::path gray_path(const fs::path& work, int frame);
fs::path labels_path(const fs::path& work, int frame);

/// Writes one frame's values file atomically (version 2) and returns its size in bytes. rasters: the
/// channels the folder stores itself (CV_64FC1 of `size`); gray and labels may be empty (not stored:
/// an unlabelled frame, or a folder with a base). With the rasters' names and the frame's colour (BGR)
/// image, the appearance channels that append_appearance_rasters(colour) gives back bit for bit are
/// stored as the colour image and a digest each (made again on reading).
std::uintmax_t write_frame_values(const fs::path& work, int frame, cv::Size size, const std::vector<cv::Mat>& rasters,
                                  const cv::Mat& gray, const cv::Mat& labels, const std::vector<std::string>& names = {},
                                  const cv::Mat& colour = cv::Mat());

/// Writes one frame's files in the version 1 layout (summed-area tables as .npy, labels may be empty
/// for an unlabelled frame): what older work folders hold, kept for the tests that check they load.
void write_frame_stack(const fs::path& work, int frame, const std::vector<cv::Mat>& sats, const cv::Mat& gray,
                       const cv::Mat& labels);

/// The manifest of a folder `out` that extends m's folder (add-context, add-textons): m's sequence, size,
/// classes and options, `keep` (features of m) read from m's folder as its base (with m's stacks.json's
/// digest), then `added`, which `out` stores itself; no frame yet.
StackManifest extending_manifest(const StackManifest& m, const fs::path& out, const std::vector<std::string>& keep,
                                 const std::vector<std::string>& added);

void save_stack_manifest(const StackManifest& m);
/// Reads and validates work/stacks.json (and its base's, which must be the one it was made from: a
/// base moved or written again is refused); Error naming the file and field.
StackManifest load_stack_manifest(const fs::path& work);

/// One frame's stack, validated against the manifest on open: version 1 memory-maps the tables; version 2
/// decodes the values file and builds the tables into an unlinked temporary file (in TMPDIR) that it
/// maps, so that `release` can drop them from memory as it does version 1's.
class FrameStack {
 public:
  /// `wanted`: per feature of m (empty: all); the others' tables are not built (sat() gives nullptr) in
  /// a version 2 folder, which then reads only the blocks asked for.
  static FrameStack open(const StackManifest& m, int frame, bool with_labels, const std::vector<bool>& wanted = {});
  FrameStack(FrameStack&&) noexcept;
  FrameStack& operator=(FrameStack&&) noexcept;
  ~FrameStack();

  int frame() const { return frame_; }
  const double* sat(int feature) const;  ///< (H+1) x (W+1) row-major; nullptr if not wanted
  const std::uint8_t* gray() const;      ///< H x W
  const std::uint8_t* labels() const;    ///< H x W, or nullptr if not opened with labels
  /// The forest's view of this frame (borrowed pointers: keep the FrameStack alive). Its `release`
  /// drops the frame's mapped pages from memory (they are read from the file again when touched).
  forest::FrameData view() const;
  /// `frame` (a stack's view, its features selected) mirrored left to right by `plan` (mirror.hpp):
  /// tables, greyscale and labels in a scratch mapping of its own, its pages dropped once written.
  static FrameStack mirror_of(const forest::FrameData& frame, const std::vector<ChannelMirror>& plan, int frame_number);
  /// `frame` at exposure k by `plan` (exposure.hpp): the changed tables and the greyscale in a scratch
  /// mapping of its own, its pages dropped once written; the unchanged tables and the labels are
  /// `frame`'s own pointers (the set that owns `frame` must outlive the copy).
  static FrameStack exposed_copy(const forest::FrameData& frame, const std::vector<ChannelExposure>& plan, double k,
                                 int frame_number);

 private:
  struct Mapping;
  FrameStack() = default;
  void open_values(const StackManifest& m, int frame, bool with_labels, const std::vector<bool>& wanted);
  int frame_ = -1;
  cv::Size size_;
  std::vector<const double*> sats_;
  const std::uint8_t* gray_ = nullptr;
  const std::uint8_t* labels_ = nullptr;
  std::vector<std::unique_ptr<Mapping>> mappings_;  ///< what the pointers point into
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

/// The frames of m inside the range, ascending; Error naming the folder when there is none.
std::vector<int> frames_in_range(const StackManifest& m, const FrameRange& range);

/// Frames of several work folders as the forest's Dataset, with the memory maps that back it.
struct StackSet {
  std::vector<StackManifest> manifests;
  std::vector<FrameStack> stacks;  ///< owns the mappings that dataset.frames point into
  std::vector<std::pair<int, int>> origin;  ///< per frame read: (work folder index, frame)
  forest::Dataset dataset;  ///< the frames read (origin's order), then their mirrors if any, then darker copies
  bool mirror = false;              ///< add_mirrored_frames added the frames' mirrors
  std::vector<double> exposures;    ///< add_exposed_frames added copies of the frames at these exposures
  std::vector<FrameStack> lightened;  ///< lighten_frames' tables, which dataset.frames point into

  bool mirrored() const { return mirror; }
};

/// Appends the mirror of every frame of `set` (train-forest --mirror, mirror.hpp) to its dataset, the
/// frames mirrored in parallel; Error naming the first work folder's stacks.json for a channel that has
/// no mirror. Call it once, after the checks that read `origin` beside the dataset's frames.
void add_mirrored_frames(StackSet& set);

/// Appends, for each exposure k (train-forest --exposures, exposure.hpp), a copy of every frame of the
/// dataset (mirrors included) as the camera would have seen it with k times the light, the copies made
/// in parallel; Error naming the first work folder's stacks.json for a channel no exposure map follows,
/// an exposure outside [0.01, 0.99], or a repeated one. Call it once, after add_mirrored_frames if any.
void add_exposed_frames(StackSet& set, const std::vector<double>& exposures);

/// Brings `frame` (a stack's view, its channels `features`) to mean lightness `target` (fL's mean over the
/// frame; TrainParams::lightness, exposure.hpp's lightness_plan): its Lab and gradient tables and greyscale
/// are replaced by mapped copies, owned by the FrameStack returned (keep it while `frame` is used); the
/// other tables and the labels stay `frame`'s. Error naming `source` when the channels lack fL or hold one
/// that no exposure map follows.
FrameStack lighten_frame(forest::FrameData& frame, const std::vector<std::string>& features, double target,
                         int frame_number, const std::string& source);

/// lighten_frame on every frame of the set, in parallel (nothing when target is 0). Call it right after
/// open_stacks (before mirrors and darker copies, which then copy the lightened frames).
void lighten_frames(StackSet& set, double target);

/// What a training read from `set`: per work folder its path, a digest of its stacks.json and the
/// labelled frames used, and the features (and "mirrored": true when their mirrors were added). Forest
/// parts record it, so that only parts trained on the same data are merged (forest/parts.hpp).
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
