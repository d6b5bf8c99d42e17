#pragma once
// NumPy .npy files (format 1.0/2.0, little-endian, C order): what numpy.load reads without our code,
// and what numpy.load(..., mmap_mode="r") maps. Used for depth, disparity and feature stacks.

#include <cstddef>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/common/io.hpp"

namespace smseg::sequence {

struct NpyHeader {
  std::string descr;               ///< e.g. "<f4", "<f8", "|u1"
  std::vector<std::size_t> shape;  ///< C order
  std::size_t data_offset = 0;     ///< bytes from the start of the file to the data
};

/// Parses the header of an .npy file's bytes; Error naming the file if it is not a valid C-order npy.
NpyHeader parse_npy_header(std::string_view bytes, const fs::path& file);

/// The header bytes (magic, version 1.0, dict, padding to a multiple of 64) for descr and shape.
std::string make_npy_header(const std::string& descr, const std::vector<std::size_t>& shape);

/// Reads a 2-D float32 array (depth, disparity) into a CV_32FC1 matrix.
cv::Mat read_npy_f32(const fs::path& path);
/// Writes a CV_32FC1 matrix as a 2-D "<f4" array, atomically.
void write_npy_f32_atomic(const fs::path& path, const cv::Mat& m);

}  // namespace smseg::sequence
