#pragma once
// Reading an image file a user gave us: frames, label and instance images, disparity maps, masks.
#include <string>
#include <string_view>

#include <opencv2/core.hpp>

#include "smseg/common/io.hpp"

namespace smseg::sequence {

/// The largest image file read (2047 MiB: a cv::Mat of the bytes is indexed with int).
constexpr std::uintmax_t kMaxImageBytes = 2047 * kMiB;

/// The image format of a file by its first bytes, as a name for messages ("PNG", "JPEG", "BMP",
/// "TIFF", "PNM", "PFM"), or empty for any other: only these formats go to OpenCV's decoders.
std::string_view image_format(std::string_view bytes);

/// The size an image must have, and who says so, for the message ("the sequence S/sequence.json").
struct ExpectedImageSize {
  cv::Size size;
  std::string said_by;
};

/// Reads and decodes an image file with OpenCV's `flags` (cv::IMREAD_*): read whole and bounded by
/// kMaxImageBytes, only the formats of image_format() decoded, a PNG's chunk structure checked before
/// libpng sees it. With `expected`, an image of another size is refused, a PNG by the size its header
/// declares, before anything is decoded (a small PNG can declare 30000 x 30000 pixels of one colour).
/// Error naming the file when it is missing, too large, of another format or size, or corrupt.
cv::Mat read_image_file(const fs::path& path, int flags, const ExpectedImageSize* expected = nullptr);

}  // namespace smseg::sequence
