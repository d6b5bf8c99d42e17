#include "smseg/sequence/image_file.hpp"

#include <cstdint>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "smseg/common/error.hpp"

namespace smseg::features {

namespace {

/// What is wrong with the chunk structure of a PNG file (empty: nothing, or not a PNG): the chunks
/// must follow each other inside the file up to IEND. A truncated or overwritten PNG is refused here,
/// by our one line, before libpng sees it and prints its own "libpng error" line on stderr.
std::string png_structure_problem(std::string_view bytes) {
  static constexpr std::string_view kSignature("\x89PNG\r\n\x1a\n", 8);
  if (bytes.substr(0, 8) != kSignature) return {};
  std::size_t at = 8;
  while (at + 12 <= bytes.size()) {
    const auto byte = [&](std::size_t i) { return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + i])); };
    const std::uint32_t length = byte(0) << 24 | byte(1) << 16 | byte(2) << 8 | byte(3);
    const std::string_view type = bytes.substr(at + 4, 4);
    if (length > bytes.size() - at - 12) return "PNG chunk " + std::string(type) + " runs past the end of the file (truncated?)";
    if (type == "IEND") return {};
    at += 12 + length;
  }
  return "PNG ends before its IEND chunk (truncated?)";
}

}  // namespace

// OpenCV's imdecode hands a file to the first of all its built-in codecs whose signature matches,
// wherever that signature lies: a damaged file with DICOM's "DICM" at byte 128 went to GDCM, which
// aborts the process on a failed assertion (found by fuzz_label_image). Images of a sequence come in
// the formats below, each told by its first bytes, so that no other decoder ever sees a user's file.
std::string_view image_format(std::string_view b) {
  const auto starts = [&](std::string_view s) { return b.substr(0, s.size()) == s; };
  if (starts(std::string_view("\x89PNG\r\n\x1a\n", 8))) return "PNG";
  if (starts("\xff\xd8\xff")) return "JPEG";
  if (starts("BM")) return "BMP";
  if (starts(std::string_view("II*\0", 4)) || starts(std::string_view("MM\0*", 4))) return "TIFF";
  if (b.size() >= 2 && b[0] == 'P' && b[1] >= '1' && b[1] <= '6') return "PNM";
  if (starts("Pf") || starts("PF")) return "PFM";
  if (b.size() >= 12 && starts("RIFF") && b.substr(8, 4) == "WEBP") return "WebP";
  return {};
}

cv::Mat read_image_file(const fs::path& path, int flags) {
  // Decoded from memory, so that the file is read once, bounded (an image beyond what cv::Mat and the
  // decoders index with int is refused), and checked before a decoder sees it.
  const std::string bytes = read_file(path, kMaxImageBytes);
  if (image_format(bytes).empty())
    throw Error(path.string(), "", "cannot be decoded as an image (not PNG, JPEG, BMP, TIFF, PNM, PFM or WebP)");
  if (const std::string problem = png_structure_problem(bytes); !problem.empty())
    throw Error(path.string(), "", "cannot be decoded: " + problem);
  cv::Mat m;
  try {
    m = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data())), flags);
  } catch (const cv::Exception& e) {
    throw Error(path.string(), "", std::string("cannot be decoded: ") + e.what());
  }
  if (m.empty()) throw Error(path.string(), "", "cannot be decoded as an image (corrupt or not an image)");
  return m;
}

}  // namespace smseg::features
