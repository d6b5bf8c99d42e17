#pragma once
// Our own PCD and PLY reader (cloud_read.cpp, internal to smseg_cloud): PCL's readers damaged the heap on
// malformed files (fuzz_cloud), so no PCL code touches a file we read; PCL still writes our clouds.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "smseg/cloud/cloud_segment.hpp"

namespace smseg::cloud::cloud_read {

/// The whole bytes of a PCD file (`file` names it in errors): header as PCL writes it, DATA ascii,
/// binary or binary_compressed; fields x y z (F4 or F8), rgb/rgba (4 bytes, packed 0x00RRGGBB), label
/// (integer of 1, 2 or 4 bytes), others skipped. Error naming the file for anything else.
ColouredCloud parse_pcd(std::string_view bytes, const std::string& file);

/// The whole bytes of a PLY 1.0 file (ascii, binary_little_endian, binary_big_endian): the vertex
/// element's x y z, red green blue (or rgb/rgba) and label; elements before it skipped, those after it
/// not read. Error naming the file for anything else.
ColouredCloud parse_ply(std::string_view bytes, const std::string& file);

/// LZF decompression (liblzf's format, as PCL's binary_compressed PCD uses it) of `in` into exactly
/// `out_size` bytes; false when the stream is malformed or does not make exactly that many bytes.
bool lzf_decompress(std::string_view in, std::string& out, std::size_t out_size);

}  // namespace smseg::cloud::cloud_read
