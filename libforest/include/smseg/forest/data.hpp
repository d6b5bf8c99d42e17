#pragma once
// The input contract of the forest (docs/design.md section 2), in the spirit of Sherwood's
// IDataPointCollection: plain arrays owned by the caller, which features/ fills from a feature stack.
// libforest never sees OpenCV; a cv::Mat made by cv::integral(..., CV_64F) can be passed as is.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace smseg::forest {

/// Label value meaning "void / ignore" in label images.
inline constexpr std::uint8_t kVoidLabel = 255;

/// One frame as the forest sees it. Pointers are borrowed: they must stay valid while in use.
struct FrameData {
  int width = 0, height = 0;
  /// One per feature: (height+1) x (width+1) row-major summed-area table,
  /// sat[y*(width+1)+x] = sum of f over rows < y, cols < x (cv::integral's CV_64F layout).
  std::vector<const double*> sats;
  /// height x width greyscale, row-major (texton tests); may be null when textons are off.
  const std::uint8_t* gray = nullptr;
  /// height x width class ids, kVoidLabel = void (training only); may be null otherwise.
  const std::uint8_t* labels = nullptr;
  /// Optional: training calls it when it is done with the frame for a while (it reads the frames one
  /// at a time), so that an owner mapping the tables from files can drop them from memory; the
  /// pointers must stay valid (reading them again brings the data back).
  std::function<void()> release;
};

/// A set of frames with their feature and class names (what training and corpus export read).
struct Dataset {
  int width = 0, height = 0;                 ///< every frame has this size
  std::vector<std::string> features;         ///< one name per summed-area table ("fH", "fC", ...)
  std::vector<std::string> classes;          ///< class names; label value i is classes[i]
  std::vector<FrameData> frames;

  /// Throws smseg::Error (file = `source`, field = "frames[i].labels", ...) when a frame does not
  /// match: wrong size, wrong number of tables, null pointers, labels outside the class list.
  /// need_labels: every frame must carry labels; need_gray: every frame must carry greyscale.
  void validate(bool need_labels, bool need_gray, const std::string& source = "training data") const;
};

/// Checks one frame against an image size and a feature count (used by the classifier).
void validate_frame(const FrameData& frame, int width, int height, std::size_t num_features,
                    bool need_gray, const std::string& source, const std::string& field);

}  // namespace smseg::forest
