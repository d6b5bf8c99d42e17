#pragma once
// The values file of one frame (stacks format version 2, docs/formats.md): the feature rasters, each in
// the smallest type that holds its values exactly, predicted from the pixel before it and packed
// (zstd); the greyscale image and the labels likewise. Appearance channels that the frame's colour
// image gives back bit for bit are not stored: the colour image is, with a digest of each such raster.
// The summed-area tables are not stored: a reader decodes each raster back to the very doubles
// extraction made and runs the same cv::integral over it, so that the tables are the ones extraction
// computed, bit for bit.
//
//   "SMSEGFV\x01"  u32 height  u32 width  u32 channels  u32 images (bit 0 gray, 1 labels, 2 colour)
//   per block (the colour image's B, G and R planes if stored, the channels in order, then gray, then
//   labels):
//     u8 encoding  7 zero bytes  u64 packed size  packed bytes
//   nothing after the last block
// All numbers little-endian. Encodings: 0 every value +0.0 (no bytes), 1 uint8, 2 uint16, 3 float32,
// 4 float64, 5 made from the colour image (the packed bytes: 16 hex digits of FNV-1a 64 over the
// raster's doubles taken as 64-bit words).
// Integers are stored as differences from the pixel before (modulo 2^8 or 2^16), floats as the XOR of
// their bits with those of the pixel before; then byte planes (all first bytes, all second bytes, ...)
// and one zstd frame with its checksum.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/common/io.hpp"

namespace smseg::stacks::values {

inline constexpr unsigned kGrayImage = 1, kLabelsImage = 2, kColourImage = 4;

/// The file's bytes. rasters: CV_64FC1 of gray's size (or of `size` when gray is empty), named by
/// `names`; gray and labels: CV_8UC1 or empty (not stored); colour: the BGR image the appearance
/// channels were made from, or empty: those it gives back bit for bit are stored as a digest.
std::string encode(const std::vector<cv::Mat>& rasters, const std::vector<std::string>& names, const cv::Mat& gray,
                   const cv::Mat& labels, const cv::Mat& colour, cv::Size size);

/// What a reader expects of a file (from the work folder's stacks.json).
struct Expected {
  cv::Size size;
  std::size_t channels = 0;
  std::vector<std::string> names;  ///< one per channel
  unsigned images = 0;  ///< kGrayImage | kLabelsImage as stored (kColourImage is the file's choice)
};

/// Where decode puts the frame: one summed-area table per channel ((H+1) x (W+1) doubles each, built by
/// cv::integral(raster, CV_64F)), and the images asked for (H x W bytes), all preallocated by the caller.
struct Output {
  std::vector<double*> sats;  ///< one per channel; nullptr: not asked for (its block is passed over, its header checked)
  std::uint8_t* gray = nullptr;
  std::uint8_t* labels = nullptr;
};

/// Decodes `bytes` (the contents of `file`) into `out`; Error naming the file on anything that does not
/// fit `expected` exactly: magic, size, counts, encodings, packed sizes, a stream that does not inflate
/// to its size, trailing bytes, values that are not finite. Nothing is allocated from the file's numbers
/// before they are checked against `expected`.
void decode(std::string_view bytes, const fs::path& file, const Expected& expected, const Output& out);

/// The most bytes a values file for `expected` can take (a larger file is refused before it is read).
std::uintmax_t max_file_bytes(const Expected& expected);

}  // namespace smseg::stacks::values
