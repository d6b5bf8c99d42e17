#include "frame_values.hpp"

#include <zstd.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

#include <opencv2/imgproc.hpp>

#include "smseg/stacks/appearance.hpp"

namespace smseg::stacks::values {

namespace {

static_assert(sizeof(double) == 8 && sizeof(float) == 4, "IEEE doubles and floats");

constexpr char kMagic[8] = {'S', 'M', 'S', 'E', 'G', 'F', 'V', '\x01'};
constexpr std::size_t kHeaderBytes = 8 + 4 * 4, kBlockHeaderBytes = 16;
/// zstd's level (measured on CamVid stacks, docs/formats.md). Every frame carries zstd's checksum of
/// its content, so that a damaged stream is refused rather than read.
constexpr int kZstdLevel = 3;

enum Encoding : std::uint8_t { kZero = 0, kU8 = 1, kU16 = 2, kF32 = 3, kF64 = 4, kFromColour = 5 };
constexpr std::size_t kDigestBytes = 16;  // digest_of: 16 hex digits

std::size_t element_bytes(Encoding e) {
  return e == kU8 ? 1 : e == kU16 ? 2 : e == kF32 ? 4 : e == kF64 ? 8 : 0;
}



/// Where `name` is among the appearance channels, or -1.
int appearance_index(const std::string& name) {
  const auto& n = appearance_feature_names();
  const auto it = std::find(n.begin(), n.end(), name);
  return it == n.end() ? -1 : static_cast<int>(it - n.begin());
}
bool is_integer(Encoding e) { return e == kU8 || e == kU16; }

std::uint64_t bits_of(double d) {
  std::uint64_t b;
  std::memcpy(&b, &d, 8);
  return b;
}

/// FNV-1a taken over the raster's doubles as 64-bit words (a byte at a time costs eight times as many
/// multiplications, and readers digest every appearance channel of every frame they open).
std::string digest_of(const cv::Mat& raster) {
  std::uint64_t h = 1469598103934665603ull;
  const auto* v = raster.ptr<double>();
  for (std::size_t i = 0; i < raster.total(); ++i) {
    h ^= bits_of(v[i]);
    h *= 1099511628211ull;
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
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
  if (e == kFromColour) {  // the digest, as it is
    put_u64(out, planes.size());
    out += planes;
    return;
  }
  if (planes.empty()) {
    put_u64(out, 0);
    return;
  }
  static thread_local const std::unique_ptr<ZSTD_CCtx, std::size_t (*)(ZSTD_CCtx*)> cctx = [] {
    std::unique_ptr<ZSTD_CCtx, std::size_t (*)(ZSTD_CCtx*)> c(ZSTD_createCCtx(), ZSTD_freeCCtx);
    if (!c || ZSTD_isError(ZSTD_CCtx_setParameter(c.get(), ZSTD_c_compressionLevel, kZstdLevel)) ||
        ZSTD_isError(ZSTD_CCtx_setParameter(c.get(), ZSTD_c_checksumFlag, 1)))
      throw Error("", "", "zstd could not be set up (out of memory?)");
    return c;
  }();
  std::string z(ZSTD_compressBound(planes.size()), '\0');
  const std::size_t packed = ZSTD_compress2(cctx.get(), z.data(), z.size(), planes.data(), planes.size());
  if (ZSTD_isError(packed)) throw Error("", "", std::string("zstd could not pack a stack channel: ") + ZSTD_getErrorName(packed));
  put_u64(out, packed);
  out.append(z.data(), packed);
}

void append_raster(std::string& out, const cv::Mat& raster, bool from_colour) {
  if (from_colour) return append_block(out, kFromColour, digest_of(raster));
  const auto* v = raster.ptr<double>();
  const Encoding e = smallest_exact(v, raster.total());
  append_block(out, e, planes_of(raster.total(), e, [&](std::size_t i) { return word_of(v[i], e); }));
}

/// Which rasters the colour image gives back bit for bit (appearance channels made from it).
std::vector<bool> from_colour(const std::vector<cv::Mat>& rasters, const std::vector<std::string>& names,
                              const cv::Mat& colour) {
  std::vector<bool> derived(rasters.size(), false);
  if (colour.empty()) return derived;
  std::vector<cv::Mat> again;
  append_appearance_rasters(colour, again);
  for (std::size_t k = 0; k < rasters.size(); ++k) {
    const int a = appearance_index(names[k]);
    derived[k] = a >= 0 && std::memcmp(again[a].data, rasters[k].data, rasters[k].total() * sizeof(double)) == 0;
  }
  return derived;
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

  void header() {
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
    if ((images & ~kColourImage) != ex_.images)
      fail(std::string("images field is ") + std::to_string(images) + ", expected " + std::to_string(ex_.images) +
           " (gray " + ((ex_.images & kGrayImage) ? "stored" : "not stored") + ", labels " +
           ((ex_.images & kLabelsImage) ? "stored" : "not stored") + ")");
    colour_ = (images & kColourImage) != 0;
  }
  bool has_colour() const { return colour_; }

  /// The next block's values, inflated into `planes` (sized here from the expected size, never from the
  /// file); returns the encoding.
  Encoding block(const std::string& what, std::string& planes) {
    std::uint64_t packed = 0;
    const Encoding e = block_header(what, packed);
    const std::size_t n = std::size_t(ex_.size.width) * std::size_t(ex_.size.height);
    if (e == kFromColour) {
      planes.assign(bytes_.data() + at_, kDigestBytes);
    } else {
      planes.resize(n * element_bytes(e));
      if (e != kZero) inflate_into(what, packed, planes);
    }
    at_ += packed;
    return e;
  }

  /// Passes over the next block, its header checked but its values not unpacked (a channel the reader
  /// did not ask for).
  void skip(const std::string& what) {
    std::uint64_t packed = 0;
    block_header(what, packed);
    at_ += packed;
  }

  void end() const {
    if (at_ != bytes_.size()) fail("has " + std::to_string(bytes_.size() - at_) + " bytes after its last block");
  }

  [[noreturn]] void fail(const std::string& why) const { throw Error(file_.string(), "", why); }

 private:
  // The next block's header, checked against the file's length; leaves at_ at its packed bytes.
  Encoding block_header(const std::string& what, std::uint64_t& packed) {
    if (bytes_.size() - at_ < kBlockHeaderBytes) fail("ends inside the header of " + what + " (truncated?)");
    const auto code = static_cast<unsigned char>(bytes_[at_]);
    if (code > kFromColour) fail(what + " has unknown encoding " + std::to_string(code));
    for (int b = 1; b < 8; ++b)
      if (bytes_[at_ + b] != 0) fail(what + " has non-zero reserved bytes in its header");
    const auto e = static_cast<Encoding>(code);
    packed = get_le(bytes_.data() + at_ + 8, 8);
    at_ += kBlockHeaderBytes;
    if (packed > bytes_.size() - at_) fail(what + " says " + std::to_string(packed) + " bytes, the file ends before (truncated?)");
    if ((e == kZero) != (packed == 0) || (e == kFromColour) != (packed == kDigestBytes))
      fail(what + " has " + std::to_string(packed) + " packed bytes for its encoding");
    return e;
  }

  void inflate_into(const std::string& what, std::uint64_t packed, std::string& planes) const {
    static thread_local const std::unique_ptr<ZSTD_DCtx, std::size_t (*)(ZSTD_DCtx*)> dctx(ZSTD_createDCtx(),
                                                                                         ZSTD_freeDCtx);
    if (!dctx) fail(what + ": out of memory unpacking it");
    const std::size_t got = ZSTD_decompressDCtx(dctx.get(), planes.data(), planes.size(), bytes_.data() + at_, packed);
    if (ZSTD_isError(got) || got != planes.size())
      fail(what + " does not unpack to its " + std::to_string(planes.size()) + " bytes (damaged file" +
           (ZSTD_isError(got) ? std::string(": ") + ZSTD_getErrorName(got) : std::string()) + ")");
  }

  std::string_view bytes_;
  const fs::path& file_;
  const Expected& ex_;
  std::size_t at_ = kHeaderBytes;
  bool colour_ = false;
};

/// Undoes planes_of for words of EB bytes: word i from its byte planes and the word before (constant
/// sizes, so that the gather unrolls).
template <std::size_t EB, bool kInteger, class Put>
void unpack_words(const unsigned char* p, std::size_t n, Put put) {
  constexpr std::uint64_t mask = EB == 8 ? ~std::uint64_t{0} : (std::uint64_t{1} << (8 * EB)) - 1;
  std::uint64_t prev = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::uint64_t coded = 0;
    for (std::size_t b = 0; b < EB; ++b) coded |= std::uint64_t{p[b * n + i]} << (8 * b);
    prev = kInteger ? (prev + coded) & mask : prev ^ coded;
    put(i, prev);
  }
}

/// The doubles of a block of encoding e (not kZero or kFromColour).
void unpack_values(const std::string& planes, std::size_t n, Encoding e, double* v) {
  const auto* p = reinterpret_cast<const unsigned char*>(planes.data());
  switch (e) {
    case kU8: return unpack_words<1, true>(p, n, [&](std::size_t i, std::uint64_t w) { v[i] = double(w); });
    case kU16: return unpack_words<2, true>(p, n, [&](std::size_t i, std::uint64_t w) { v[i] = double(w); });
    case kF32: return unpack_words<4, false>(p, n, [&](std::size_t i, std::uint64_t w) { v[i] = value_of(w, kF32); });
    default: return unpack_words<8, false>(p, n, [&](std::size_t i, std::uint64_t w) { std::memcpy(v + i, &w, 8); });
  }
}

/// The decoder's state across blocks: the colour image and the appearance rasters made from it.
struct Decoding {
  std::string planes;
  cv::Mat raster, colour;
  std::vector<cv::Mat> appearance;  ///< made on first use
};

/// An appearance channel made again from the colour image; refused unless it is the raster extraction
/// stored (its digest), so that another build whose maths library rounds differently cannot pass.
void channel_from_colour(Reader& reader, const std::string& what, const std::string& name, Decoding& d) {
  const int a = appearance_index(name);
  if (a < 0) reader.fail(what + " (" + name + ") is not an appearance channel, but refers to the colour image");
  if (d.colour.empty()) reader.fail(what + " refers to the colour image, which the file does not hold");
  if (d.appearance.empty()) append_appearance_rasters(d.colour, d.appearance);
  if (digest_of(d.appearance[a]) != d.planes)
    reader.fail(what + " (" + name + ") made again from the colour image differs from the one extracted (damaged, "
                "or another build's maths library); extract the frame again");
  d.appearance[a].copyTo(d.raster);
}

void decode_channel(Reader& reader, std::size_t k, const Expected& ex, Decoding& d, double* sat) {
  const std::string what = "channel " + std::to_string(k);
  if (!sat) return reader.skip(what);
  const Encoding e = reader.block(what, d.planes);
  const std::size_t n = d.raster.total();
  auto* v = d.raster.ptr<double>();
  if (e == kFromColour) {
    channel_from_colour(reader, what, ex.names.at(k), d);
  } else if (e == kZero) {
    std::memset(v, 0, n * sizeof(double));
  } else {
    unpack_values(d.planes, n, e, v);
  }
  const bool may_be_infinite = e == kF32 || e == kF64 || e == kFromColour;
  for (std::size_t i = 0; i < n && may_be_infinite; ++i)
    if (!std::isfinite(v[i]))
      reader.fail(what + " pixel (" + std::to_string(i % ex.size.width) + ", " + std::to_string(i / ex.size.width) +
                  ") is " + (std::isnan(v[i]) ? "NaN" : "infinite") + "; the file is damaged (extract the frame again)");
  cv::Mat table(ex.size.height + 1, ex.size.width + 1, CV_64FC1, sat);
  cv::integral(d.raster, table, CV_64F);  // as extraction's summed_area_table: the same doubles
  CV_Assert(table.ptr<double>() == sat);
}

void decode_image(Reader& reader, const std::string& what, std::string& planes, std::uint8_t* out, std::size_t n) {
  if (reader.block(what, planes) != kU8) reader.fail(what + " is not stored as uint8");
  unpack_words<1, true>(reinterpret_cast<const unsigned char*>(planes.data()), n,
                        [&](std::size_t i, std::uint64_t w) { out[i] = static_cast<std::uint8_t>(w); });
}

}  // namespace

std::string encode(const std::vector<cv::Mat>& rasters, const std::vector<std::string>& names, const cv::Mat& gray,
                   const cv::Mat& labels, const cv::Mat& colour, cv::Size size) {
  if (!gray.empty()) size = gray.size();
  std::vector<cv::Mat> values;
  for (const cv::Mat& r : rasters) {
    CV_Assert(r.type() == CV_64FC1 && r.size() == size);
    values.push_back(r.isContinuous() ? r : r.clone());
  }
  CV_Assert(colour.empty() || (colour.type() == CV_8UC3 && colour.size() == size && names.size() == rasters.size()));
  const std::vector<bool> derived = from_colour(values, names, colour);
  const bool with_colour = std::find(derived.begin(), derived.end(), true) != derived.end();
  std::string out(kMagic, 8);
  put_u32(out, static_cast<std::uint32_t>(size.height));
  put_u32(out, static_cast<std::uint32_t>(size.width));
  put_u32(out, static_cast<std::uint32_t>(rasters.size()));
  put_u32(out, (gray.empty() ? 0 : kGrayImage) | (labels.empty() ? 0 : kLabelsImage) | (with_colour ? kColourImage : 0));
  if (with_colour) {
    std::vector<cv::Mat> bgr;
    cv::split(colour, bgr);
    for (const cv::Mat& c : bgr) append_image(out, c);
  }
  for (std::size_t k = 0; k < values.size(); ++k) append_raster(out, values[k], derived[k]);
  if (!gray.empty()) append_image(out, gray);
  if (!labels.empty()) {
    CV_Assert(labels.size() == size);
    append_image(out, labels);
  }
  return out;
}

void decode(std::string_view bytes, const fs::path& file, const Expected& ex, const Output& out) {
  CV_Assert(out.sats.size() == ex.channels && ex.names.size() == ex.channels);
  Reader reader(bytes, file, ex);
  reader.header();
  Decoding d;
  d.raster.create(ex.size, CV_64FC1);
  const std::size_t n = std::size_t(ex.size.area());
  if (reader.has_colour()) {
    // Unpacked only when a channel asked for may be made from it.
    bool wanted = false;
    for (std::size_t k = 0; k < ex.channels; ++k) wanted = wanted || (out.sats[k] && appearance_index(ex.names[k]) >= 0);
    std::vector<cv::Mat> bgr(3);
    for (int c = 0; c < 3; ++c) {
      const std::string what = std::string("colour plane ") + "BGR"[c];
      if (!wanted) {
        reader.skip(what);
        continue;
      }
      bgr[c].create(ex.size, CV_8UC1);
      decode_image(reader, what, d.planes, bgr[c].data, n);
    }
    if (wanted) cv::merge(bgr, d.colour);
  }
  for (std::size_t k = 0; k < ex.channels; ++k) decode_channel(reader, k, ex, d, out.sats[k]);
  if (ex.images & kGrayImage) decode_image(reader, "gray", d.planes, out.gray, n);
  if (ex.images & kLabelsImage) decode_image(reader, "labels", d.planes, out.labels, n);
  reader.end();
}

std::uintmax_t max_file_bytes(const Expected& ex) {
  const std::uintmax_t n = std::uintmax_t(ex.size.area());
  const std::uintmax_t blocks = ex.channels + 5;
  return kHeaderBytes + blocks * (kBlockHeaderBytes + ZSTD_compressBound(n * 8));
}

}  // namespace smseg::stacks::values
