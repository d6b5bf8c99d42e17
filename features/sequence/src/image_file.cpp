#include "smseg/sequence/image_file.hpp"

#include <array>
#include <cctype>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>

#include <opencv2/imgcodecs.hpp>

#include "smseg/common/error.hpp"

namespace smseg::sequence {

namespace {

/// The CRC-32 (ISO 3309, as PNG uses it) of `bytes`.
std::uint32_t crc32(std::string_view bytes) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t n = 0; n < 256; ++n) {
      std::uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  std::uint32_t c = 0xffffffffu;
  for (const char b : bytes) c = table[(c ^ static_cast<unsigned char>(b)) & 0xff] ^ (c >> 8);
  return c ^ 0xffffffffu;
}

constexpr std::string_view kPngSignature("\x89PNG\r\n\x1a\n", 8);

/// The big-endian 32-bit number at bytes[at..at+4) (PNG's byte order); the caller checked the bounds.
std::uint32_t be32(std::string_view bytes, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v = v << 8 | static_cast<unsigned char>(bytes[at + i]);
  return v;
}

/// What is wrong with the chunk structure of a PNG file (empty: nothing): the chunks must follow each
/// other inside the file up to IEND, each with its CRC. A truncated, overwritten or damaged PNG is
/// refused here, by our one line, before libpng sees it and prints its own "libpng error" line on
/// stderr (a damaged byte anywhere in a chunk breaks that chunk's CRC).
std::string png_structure_problem(std::string_view png) {
  // Each chunk: length (4 bytes), type (4), data (length), CRC of type and data (4).
  for (std::size_t at = kPngSignature.size(); at + 12 <= png.size();) {
    const std::uint32_t length = be32(png, at);
    const std::string type(png.substr(at + 4, 4));
    if (length > png.size() - at - 12) return "PNG chunk " + type + " runs past the end of the file (truncated?)";
    if (be32(png, at + 8 + length) != crc32(png.substr(at + 4, 4 + length)))
      return "PNG chunk " + type + " is damaged (its CRC does not match)";
    if (type == "IEND") return {};
    at += 12 + length;
  }
  return "PNG ends before its IEND chunk (truncated?)";
}

/// The width and height the IHDR chunk of a PNG declares (it comes first, right after the signature);
/// nothing when it is not there (png_structure_problem and libpng judge such a file).
std::optional<std::pair<std::uint32_t, std::uint32_t>> png_declared_size(std::string_view png) {
  if (png.size() < 24 || png.substr(12, 4) != "IHDR") return std::nullopt;
  return std::make_pair(be32(png, 16), be32(png, 20));
}

void check_image_size(const fs::path& path, std::uint64_t width, std::uint64_t height, const ExpectedImageSize& e) {
  if (width == std::uint64_t(e.size.width) && height == std::uint64_t(e.size.height)) return;
  throw Error(path.string(), "",
              "image is " + std::to_string(width) + "x" + std::to_string(height) + ", " + e.said_by + " says " +
                  std::to_string(e.size.width) + "x" + std::to_string(e.size.height));
}

}  // namespace

// OpenCV's imdecode hands a file to the first of all its built-in codecs whose signature matches,
// wherever that signature lies: a damaged file with DICOM's "DICM" at byte 128 went to GDCM, which
// aborts the process on a failed assertion (found twice by fuzz_label_image). Images of a sequence
// come in the formats below, each told by its first bytes exactly as OpenCV's own decoder of that
// format tells it (or more strictly), and those decoders come before GDCM's in OpenCV's list, so no
// other decoder ever sees a user's file. (WebP is not among them: OpenCV asks libwebp whether the
// first 32 bytes are WebP, and a file it turns down went on to GDCM.)
std::string_view image_format(std::string_view b) {
  const auto starts = [&](std::string_view s) { return b.substr(0, s.size()) == s; };
  const bool third_is_space = b.size() >= 3 && std::isspace(static_cast<unsigned char>(b[2]));
  if (starts(kPngSignature)) return "PNG";
  if (starts("\xff\xd8\xff")) return "JPEG";
  if (starts("BM")) return "BMP";
  if (starts(std::string_view("II*\0", 4)) || starts(std::string_view("MM\0*", 4))) return "TIFF";
  if (b.size() >= 2 && b[0] == 'P' && b[1] >= '1' && b[1] <= '6' && third_is_space) return "PNM";
  if ((starts("Pf") || starts("PF")) && third_is_space) return "PFM";
  return {};
}

cv::Mat read_image_file(const fs::path& path, int flags, const ExpectedImageSize* expected) {
  // Decoded from memory, so that the file is read once, bounded (an image beyond what cv::Mat and the
  // decoders index with int is refused), and checked before a decoder sees it.
  const std::string bytes = read_file(path, kMaxImageBytes);
  const std::string_view format = image_format(bytes);
  if (format.empty())
    throw Error(path.string(), "", "cannot be decoded as an image (not PNG, JPEG, BMP, TIFF, PNM or PFM)");
  if (format == "PNG") {
    if (const auto declared = png_declared_size(bytes); declared && expected)
      check_image_size(path, declared->first, declared->second, *expected);
    if (const std::string problem = png_structure_problem(bytes); !problem.empty())
      throw Error(path.string(), "", "cannot be decoded: " + problem);
  }
  cv::Mat m;
  try {
    // OpenCV's PFM decoder cannot read from memory: imdecode would copy the bytes to a temporary file
    // (cv::tempfile) and leave it behind when decoding fails. A PFM is decoded from its own file.
    if (format == "PFM")
      m = cv::imread(path.string(), flags);
    else
      m = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data())), flags);
  } catch (const cv::Exception& e) {
    throw Error(path.string(), "", std::string("cannot be decoded: ") + e.what());
  }
  if (m.empty()) throw Error(path.string(), "", "cannot be decoded as an image (corrupt or not an image)");
  if (expected) check_image_size(path, std::uint64_t(m.cols), std::uint64_t(m.rows), *expected);
  return m;
}

}  // namespace smseg::sequence
