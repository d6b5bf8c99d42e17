#include "frame_values.hpp"

#include <zlib.h>

#include <cfloat>
#include <cmath>
#include <cstring>

#include <opencv2/imgproc.hpp>

namespace smseg::features::values {

namespace {

static_assert(sizeof(double) == 8 && sizeof(float) == 4, "IEEE doubles and floats");

constexpr char kMagic[8] = {'S', 'M', 'S', 'E', 'G', 'F', 'V', '\x01'};
constexpr std::size_t kHeaderBytes = 8 + 4 * 4, kBlockHeaderBytes = 16;
/// zlib's level: 1 packs a frame several times faster than the default 6 for a few per cent more bytes
/// (measured on CamVid stacks, docs/formats.md).
constexpr int kDeflateLevel = 1;

enum Encoding : std::uint8_t { kZero = 0, kU8 = 1, kU16 = 2, kF32 = 3, kF64 = 4 };

std::size_t element_bytes(Encoding e) { return e == kZero ? 0 : e == kU8 ? 1 : e == kU16 ? 2 : e == kF32 ? 4 : 8; }
bool is_integer(Encoding e) { return e == kU8 || e == kU16; }

std::uint64_t bits_of(double d) {
  std::uint64_t b;
  std::memcpy(&b, &d, 8);
  return b;
}

/// The smallest encoding that gives back every value bit for bit (-0.0 is a float, not an integer).
Encoding smallest_exact(const double* v, std::size_t n) {
  bool zero = true, u8 = true, u16 = true, f32 = true;
  for (std::size_t i = 0; i < n && (zero || u16 || f32); ++i) {
    const double d = v[i];
    const std::uint64_t b = bits_of(d);
    zero = zero && b == 0;
    if (u16 && !(d >= 0 && d <= 65535 && bits_of(double(std::uint16_t(d))) == b)) u16 = u8 = false;
    u8 = u8 && d <= 255;
    if (f32 && !(std::fabs(d) <= FLT_MAX && bits_of(double(float(d))) == b)) f32 = false;
  }
  return zero ? kZero : u8 ? kU8 : u16 ? kU16 : f32 ? kF32 : kF64;
}

std::uint64_t word_of(double d, Encoding e) {
  if (e == kU8 || e == kU16) return static_cast<std::uint64_t>(d);
  if (e == kF64) return bits_of(d);
  const float f = static_cast<float>(d);
  std::uint32_t w;
  std::memcpy(&w, &f, 4);
  return w;
}

double value_of(std::uint64_t w, Encoding e) {
  if (e == kU8 || e == kU16) return static_cast<double>(w);
  if (e == kF64) {
    double d;
    std::memcpy(&d, &w, 8);
    return d;
  }
  const auto w32 = static_cast<std::uint32_t>(w);
  float f;
  std::memcpy(&f, &w32, 4);
  return f;
}

std::uint64_t mask_of(std::size_t bytes) { return bytes == 8 ? ~std::uint64_t{0} : (std::uint64_t{1} << (8 * bytes)) - 1; }

/// Predicted from the pixel before (difference for integers, XOR for floats), then byte planes.
template <class Word>
std::string planes_of(std::size_t n, Encoding e, Word word) {
  const std::size_t eb = element_bytes(e);
  const std::uint64_t mask = mask_of(eb);
  std::string planes(n * eb, '\0');
  std::uint64_t prev = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t w = word(i);
    const std::uint64_t coded = is_integer(e) ? (w - prev) & mask : w ^ prev;
    prev = w;
    for (std::size_t b = 0; b < eb; ++b) planes[b * n + i] = static_cast<char>(coded >> (8 * b));
  }
  return planes;
}

void put_u32(std::string& out, std::uint32_t v) {
  for (int b = 0; b < 4; ++b) out.push_back(static_cast<char>(v >> (8 * b)));
}
void put_u64(std::string& out, std::uint64_t v) {
  for (int b = 0; b < 8; ++b) out.push_back(static_cast<char>(v >> (8 * b)));
}
std::uint64_t get_le(const char* p, int bytes) {
  std::uint64_t v = 0;
  for (int b = 0; b < bytes; ++b) v |= std::uint64_t(static_cast<unsigned char>(p[b])) << (8 * b);
  return v;
}

void append_block(std::string& out, Encoding e, const std::string& planes) {
  out.push_back(static_cast<char>(e));
  out.append(7, '\0');
  if (planes.empty()) {
    put_u64(out, 0);
    return;
  }
  uLongf packed = compressBound(planes.size());
  std::string z(packed, '\0');
  if (compress2(reinterpret_cast<Bytef*>(z.data()), &packed, reinterpret_cast<const Bytef*>(planes.data()),
                planes.size(), kDeflateLevel) != Z_OK)
    throw Error("", "", "zlib could not deflate a stack channel (out of memory?)");
  put_u64(out, packed);
  out.append(z.data(), packed);
}

void append_raster(std::string& out, const cv::Mat& raster) {
  CV_Assert(raster.type() == CV_64FC1);
  const cv::Mat r = raster.isContinuous() ? raster : raster.clone();
  const auto* v = r.ptr<double>();
  const Encoding e = smallest_exact(v, r.total());
  append_block(out, e, planes_of(r.total(), e, [&](std::size_t i) { return word_of(v[i], e); }));
}

void append_image(std::string& out, const cv::Mat& image) {
  CV_Assert(image.type() == CV_8UC1);
  const cv::Mat m = image.isContinuous() ? image : image.clone();
  append_block(out, kU8, planes_of(m.total(), kU8, [&](std::size_t i) { return std::uint64_t{m.data[i]}; }));
}

/// Reads the file block by block, each checked against what the stacks.json expects.
class Reader {
 public:
  Reader(std::string_view bytes, const fs::path& file, const Expected& ex) : bytes_(bytes), file_(file), ex_(ex) {}

  void header() const {
    if (bytes_.size() < kHeaderBytes || std::memcmp(bytes_.data(), kMagic, 8) != 0)
      fail("is not a stack values file (no SMSEGFV1 header; damaged, or not written by extract-features)");
    const auto h = get_le(bytes_.data() + 8, 4), w = get_le(bytes_.data() + 12, 4);
    const auto c = get_le(bytes_.data() + 16, 4), images = get_le(bytes_.data() + 20, 4);
    if (h != std::uint64_t(ex_.size.height) || w != std::uint64_t(ex_.size.width))
      fail("holds " + std::to_string(w) + "x" + std::to_string(h) + " images, the work folder's stacks.json says " +
           std::to_string(ex_.size.width) + "x" + std::to_string(ex_.size.height));
    if (c != ex_.channels)
      fail("holds " + std::to_string(c) + " channels, the work folder's stacks.json says " +
           std::to_string(ex_.channels));
    if (images != ex_.images)
      fail(std::string("images field is ") + std::to_string(images) + ", expected " + std::to_string(ex_.images) +
           " (gray " + ((ex_.images & kGrayImage) ? "stored" : "not stored") + ", labels " +
           ((ex_.images & kLabelsImage) ? "stored" : "not stored") + ")");
  }

  /// The next block's values, inflated into `planes` (sized here from the expected size, never from the
  /// file); returns the encoding.
  Encoding block(const std::string& what, std::string& planes) {
    if (bytes_.size() - at_ < kBlockHeaderBytes) fail("ends inside the header of " + what + " (truncated?)");
    const auto code = static_cast<unsigned char>(bytes_[at_]);
    if (code > kF64) fail(what + " has unknown encoding " + std::to_string(code));
    for (int b = 1; b < 8; ++b)
      if (bytes_[at_ + b] != 0) fail(what + " has non-zero reserved bytes in its header");
    const auto e = static_cast<Encoding>(code);
    const std::uint64_t packed = get_le(bytes_.data() + at_ + 8, 8);
    at_ += kBlockHeaderBytes;
    if (packed > bytes_.size() - at_) fail(what + " says " + std::to_string(packed) + " bytes, the file ends before (truncated?)");
    if ((e == kZero) != (packed == 0)) fail(what + " has " + std::to_string(packed) + " packed bytes for its encoding");
    const std::size_t n = std::size_t(ex_.size.width) * std::size_t(ex_.size.height);
    planes.resize(n * element_bytes(e));
    if (e != kZero) inflate_into(what, packed, planes);
    at_ += packed;
    return e;
  }

  void end() const {
    if (at_ != bytes_.size()) fail("has " + std::to_string(bytes_.size() - at_) + " bytes after its last block");
  }

  [[noreturn]] void fail(const std::string& why) const { throw Error(file_.string(), "", why); }

 private:
  void inflate_into(const std::string& what, std::uint64_t packed, std::string& planes) const {
    uLongf out = planes.size();
    uLong in = packed;
    const int rc = uncompress2(reinterpret_cast<Bytef*>(planes.data()), &out,
                               reinterpret_cast<const Bytef*>(bytes_.data() + at_), &in);
    if (rc == Z_MEM_ERROR) fail(what + ": out of memory inflating it");
    if (rc != Z_OK || out != planes.size() || in != packed)
      fail(what + " does not inflate to its " + std::to_string(planes.size()) + " bytes (damaged file)");
  }

  std::string_view bytes_;
  const fs::path& file_;
  const Expected& ex_;
  std::size_t at_ = kHeaderBytes;
};

/// Undoes planes_of: word i from its byte planes and the word before.
template <class Put>
void unpack(const std::string& planes, std::size_t n, Encoding e, Put put) {
  const std::size_t eb = element_bytes(e);
  const std::uint64_t mask = mask_of(eb);
  const auto* p = reinterpret_cast<const unsigned char*>(planes.data());
  std::uint64_t prev = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::uint64_t coded = 0;
    for (std::size_t b = 0; b < eb; ++b) coded |= std::uint64_t{p[b * n + i]} << (8 * b);
    prev = is_integer(e) ? (prev + coded) & mask : prev ^ coded;
    put(i, prev);
  }
}

void decode_channel(Reader& reader, std::size_t k, const Expected& ex, std::string& planes, cv::Mat& raster,
                    double* sat) {
  const std::string what = "channel " + std::to_string(k);
  const Encoding e = reader.block(what, planes);
  const std::size_t n = raster.total();
  auto* v = raster.ptr<double>();
  if (e == kZero) {
    std::memset(v, 0, n * sizeof(double));
  } else {
    unpack(planes, n, e, [&](std::size_t i, std::uint64_t w) { v[i] = value_of(w, e); });
  }
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(v[i]))
      reader.fail(what + " pixel (" + std::to_string(i % ex.size.width) + ", " + std::to_string(i / ex.size.width) +
                  ") is " + (std::isnan(v[i]) ? "NaN" : "infinite") + "; the file is damaged (extract the frame again)");
  cv::Mat table(ex.size.height + 1, ex.size.width + 1, CV_64FC1, sat);
  cv::integral(raster, table, CV_64F);  // as extraction's summed_area_table: the same doubles
  CV_Assert(table.ptr<double>() == sat);
}

void decode_image(Reader& reader, const std::string& what, std::string& planes, std::uint8_t* out, std::size_t n) {
  if (reader.block(what, planes) != kU8) reader.fail(what + " is not stored as uint8");
  unpack(planes, n, kU8, [&](std::size_t i, std::uint64_t w) { out[i] = static_cast<std::uint8_t>(w); });
}

}  // namespace

std::string encode(const std::vector<cv::Mat>& rasters, const cv::Mat& gray, const cv::Mat& labels, cv::Size size) {
  if (!gray.empty()) size = gray.size();
  std::string out(kMagic, 8);
  put_u32(out, static_cast<std::uint32_t>(size.height));
  put_u32(out, static_cast<std::uint32_t>(size.width));
  put_u32(out, static_cast<std::uint32_t>(rasters.size()));
  put_u32(out, (gray.empty() ? 0 : kGrayImage) | (labels.empty() ? 0 : kLabelsImage));
  for (const cv::Mat& r : rasters) {
    CV_Assert(r.size() == size);
    append_raster(out, r);
  }
  if (!gray.empty()) append_image(out, gray);
  if (!labels.empty()) {
    CV_Assert(labels.size() == size);
    append_image(out, labels);
  }
  return out;
}

void decode(std::string_view bytes, const fs::path& file, const Expected& ex, const Output& out) {
  CV_Assert(out.sats.size() == ex.channels);
  Reader reader(bytes, file, ex);
  reader.header();
  std::string planes;
  cv::Mat raster(ex.size, CV_64FC1);
  for (std::size_t k = 0; k < ex.channels; ++k) decode_channel(reader, k, ex, planes, raster, out.sats[k]);
  const std::size_t n = std::size_t(ex.size.area());
  if (ex.images & kGrayImage) decode_image(reader, "gray", planes, out.gray, n);
  if (ex.images & kLabelsImage) decode_image(reader, "labels", planes, out.labels, n);
  reader.end();
}

std::uintmax_t max_file_bytes(const Expected& ex) {
  const std::uintmax_t n = std::uintmax_t(ex.size.area());
  const std::uintmax_t blocks = ex.channels + 2;
  return kHeaderBytes + blocks * (kBlockHeaderBytes + compressBound(static_cast<uLong>(n * 8)));
}

}  // namespace smseg::features::values
