// read_coloured_cloud (cloud_segment.hpp): our own PCD and PLY reader. PCL 1.13's readers damaged the
// heap on malformed files even behind strict header checks (fuzz_cloud, docs/reliability.md), so no PCL
// code reads a file: the file is read whole (bounded by kMaxLargeFileBytes), its header parsed strictly,
// and every count checked against the bytes that are there before anything is allocated for it.
#include "cloud_read.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <set>
#include <vector>

#include "smseg/common/error.hpp"
#include "smseg/common/io.hpp"

namespace smseg::cloud {

namespace cloud_read {

namespace {

constexpr std::size_t kMaxHeaderBytes = 64 * 1024;  // ours are a few hundred bytes

/// `text` with every byte that is not printable ASCII shown as '?', at most `max` bytes, for an error line.
std::string printable(std::string_view text, std::size_t max = 40) {
  std::string s(text.substr(0, max));
  for (char& c : s)
    if (c < 0x20 || c > 0x7e) c = '?';
  return s;
}

// ---- Lines and words --------------------------------------------------------------------------

/// Walks `text` line by line ('\n', a trailing '\r' dropped), counting lines from 1.
class Lines {
 public:
  explicit Lines(std::string_view text, std::size_t start = 0, int first_number = 1)
      : text_(text), pos_(start), number_(first_number - 1) {}
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
    line = text_.substr(pos_, end - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    terminated_ = end < text_.size();
    pos_ = end + (terminated_ ? 1 : 0);
    ++number_;
    return true;
  }
  /// Like next(), skipping lines of only white space (data files may end in blank lines).
  bool next_nonblank(std::string_view& line) {
    while (next(line))
      if (line.find_first_not_of(" \t\r\v\f") != std::string_view::npos) return true;
    return false;
  }
  std::size_t pos() const { return pos_; }
  int number() const { return number_; }
  bool terminated() const { return terminated_; }  ///< the last line ended in '\n'

 private:
  std::string_view text_;
  std::size_t pos_;
  int number_;
  bool terminated_ = false;
};

/// The white-space separated words of `line`, into `words` (reused, so that data lines allocate nothing).
void split(std::string_view line, std::vector<std::string_view>& words) {
  words.clear();
  constexpr std::string_view space = " \t\r\v\f";
  for (std::size_t b = line.find_first_not_of(space); b != std::string_view::npos;
       b = line.find_first_not_of(space, b)) {
    const std::size_t e = std::min(line.find_first_of(space, b), line.size());
    words.push_back(line.substr(b, e - b));
    b = e;
  }
}

/// A whole number of at most `digits` digits without a sign or leading zero, as the PCD header writes them.
bool whole_number(std::string_view v, std::size_t digits, std::uint64_t& out) {
  if (v.empty() || v.size() > digits || (v.size() > 1 && v.front() == '0')) return false;
  const auto r = std::from_chars(v.data(), v.data() + v.size(), out);
  return r.ec == std::errc() && r.ptr == v.data() + v.size();
}

// ---- Numbers: one scalar type for PCD and PLY, values kept as raw bits ------------------------

/// A numeric type: PCD's TYPE and SIZE, or one of PLY's char..double.
struct Scalar {
  enum Kind { Int, UInt, Float } kind = Float;
  std::size_t size = 4;  ///< bytes: 1, 2, 4, 8
  bool integer() const { return kind != Float; }
};

/// The value of `size` bytes at `p` as the bits of its type (zero-extended), from either byte order.
std::uint64_t load(const char* p, std::size_t size, bool big_endian) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < size; ++i) v = (v << 8) | static_cast<unsigned char>(p[big_endian ? i : size - 1 - i]);
  return v;
}

std::int64_t signed_value(std::uint64_t bits, std::size_t size) {
  const int unused = 64 - 8 * static_cast<int>(size);
  return static_cast<std::int64_t>(bits << unused) >> unused;  // sign extension (C++20: arithmetic shift)
}

double real_value(std::uint64_t bits, Scalar s) {
  if (s.kind == Scalar::Int) return static_cast<double>(signed_value(bits, s.size));
  if (s.kind == Scalar::UInt) return static_cast<double>(bits);
  if (s.size == 8) return std::bit_cast<double>(bits);
  return std::bit_cast<float>(static_cast<std::uint32_t>(bits));
}

/// An integer value, clamped to int64 (a uint64 above it is still "large" for the range checks).
std::int64_t integer_value(std::uint64_t bits, Scalar s) {
  if (s.kind == Scalar::Int) return signed_value(bits, s.size);
  return bits > std::uint64_t(std::numeric_limits<std::int64_t>::max()) ? std::numeric_limits<std::int64_t>::max()
                                                                        : static_cast<std::int64_t>(bits);
}

/// One ASCII value of type `s` as the bits binary data would hold; false when it is not a number of that
/// type. `colour_bits`: a packed colour (rgb/rgba), which PCL writes as an unsigned integer even when the
/// field's TYPE is F; a float there is taken bit for bit.
bool parse_value(std::string_view w, Scalar s, bool colour_bits, std::uint64_t& bits) {
  if (w.size() > 1 && w[0] == '+' && w[1] != '-') w.remove_prefix(1);
  const char* b = w.data();
  const char* e = b + w.size();
  if (colour_bits || s.kind == Scalar::UInt) {
    std::uint64_t v = 0;
    const auto r = std::from_chars(b, e, v);
    const std::size_t size = colour_bits ? 4 : s.size;
    if (r.ec == std::errc() && r.ptr == e) {
      bits = v;
      return size == 8 || v < (std::uint64_t{1} << (8 * size));
    }
    if (!colour_bits) return false;
  }
  if (s.kind == Scalar::Int) {
    std::int64_t v = 0;
    const auto r = std::from_chars(b, e, v);
    if (r.ec != std::errc() || r.ptr != e) return false;
    const int bits_of = 8 * static_cast<int>(s.size);
    if (bits_of < 64 && (v < -(std::int64_t{1} << (bits_of - 1)) || v >= (std::int64_t{1} << (bits_of - 1))))
      return false;
    bits = static_cast<std::uint64_t>(v) & (bits_of < 64 ? (std::uint64_t{1} << bits_of) - 1 : ~std::uint64_t{0});
    return true;
  }
  double v = 0;
  const auto r = std::from_chars(b, e, v);              // takes "nan" and "inf": validate() refuses them in x/y/z
  if (r.ec != std::errc() || r.ptr != e) return false;  // also out of a double's range
  if (s.size == 8 && !colour_bits) {
    bits = std::bit_cast<std::uint64_t>(v);
    return true;
  }
  if (std::abs(v) > double(std::numeric_limits<float>::max()) && std::isfinite(v)) return false;  // not a float
  bits = std::bit_cast<std::uint32_t>(static_cast<float>(v));
  return true;
}

/// "a float of 4 bytes", "an unsigned integer of 1 byte", for error lines.
std::string type_name(Scalar s) {
  const char* kind = s.kind == Scalar::Int    ? "a signed integer"
                     : s.kind == Scalar::UInt ? "an unsigned integer"
                                              : "a float";
  return std::string(kind) + " of " + std::to_string(s.size) + " byte" + (s.size == 1 ? "" : "s");
}

// ---- Records: where each value of a point is, and what the cloud takes from it -----------------

/// What the cloud takes from a point record.
enum Role { X, Y, Z, Rgb, Red, Green, Blue, Label, kRoles };

/// The values of one point record in file order (PCD: each field's COUNT values; PLY: the vertex
/// properties), their byte offsets in a binary record, and which of them the cloud takes.
struct Layout {
  std::vector<Scalar> values;
  std::vector<std::size_t> offsets;
  std::size_t record_bytes = 0;
  std::array<int, kRoles> role{-1, -1, -1, -1, -1, -1, -1, -1};

  void add(Scalar s) {
    values.push_back(s);
    offsets.push_back(record_bytes);
    record_bytes += s.size;
  }
};

using RoleBits = std::array<std::uint64_t, kRoles>;

/// Reserves for `n` points: the caller has checked that the data can hold them.
void reserve(ColouredCloud& c, const Layout& l, std::size_t n) {
  c.points.reserve(n);
  if (l.role[Rgb] >= 0 || l.role[Red] >= 0) c.colours.reserve(n);
  if (l.role[Label] >= 0) c.labels.reserve(n);
}

/// Appends point `index` from the bits of its roles. Colour channels outside 0..255 are an Error; labels
/// 255 (PCL's "none"), above or negative read as -1.
void append_point(ColouredCloud& c, const Layout& l, const RoleBits& bits, const std::string& file, std::size_t index) {
  const auto real = [&](Role r) {
    // A double beyond float's range becomes infinite, which validate() refuses as not finite.
    const double d = real_value(bits[r], l.values[std::size_t(l.role[r])]);
    constexpr float inf = std::numeric_limits<float>::infinity();
    if (std::abs(d) > double(std::numeric_limits<float>::max()) && std::isfinite(d)) return d > 0 ? inf : -inf;
    return static_cast<float>(d);
  };
  c.points.emplace_back(real(X), real(Y), real(Z));
  if (l.role[Rgb] >= 0) {
    const auto packed = static_cast<std::uint32_t>(bits[Rgb]);  // 0x00RRGGBB or 0xAARRGGBB
    c.colours.push_back({std::uint8_t(packed >> 16), std::uint8_t(packed >> 8), std::uint8_t(packed)});
  } else if (l.role[Red] >= 0) {
    static constexpr const char* kChannels[] = {"red", "green", "blue"};
    std::array<std::uint8_t, 3> rgb{};
    for (int k = 0; k < 3; ++k) {
      const std::int64_t v = integer_value(bits[Red + k], l.values[std::size_t(l.role[Red + k])]);
      if (v < 0 || v > 255)
        throw Error(file, "point " + std::to_string(index),
                    std::string(kChannels[k]) + " is " + std::to_string(v) + ", outside 0..255");
      rgb[std::size_t(k)] = static_cast<std::uint8_t>(v);
    }
    c.colours.push_back(rgb);
  }
  if (l.role[Label] >= 0) {
    const std::int64_t v = integer_value(bits[Label], l.values[std::size_t(l.role[Label])]);
    c.labels.push_back(v < 0 || v >= 255 ? -1 : static_cast<int>(v));
  }
}

/// Reads `n` points of ASCII data, one per line with exactly the layout's values (blank lines skipped);
/// more non-blank lines after them are an Error when `trailing_allowed` is false.
void read_ascii_points(Lines& lines, const Layout& l, std::size_t n, bool colour_bits_for_rgb, bool trailing_allowed,
                       ColouredCloud& c, const std::string& file) {
  std::vector<std::string_view> words;
  std::vector<std::uint64_t> row(l.values.size());
  std::string_view line;
  for (std::size_t i = 0; i < n; ++i) {
    if (!lines.next_nonblank(line))
      throw Error(file, "data", "truncated: " + std::to_string(i) + " of " + std::to_string(n) + " points");
    const std::string where = "line " + std::to_string(lines.number());
    split(line, words);
    if (words.size() != l.values.size())
      throw Error(file, where,
                  std::to_string(words.size()) + " values, expected " + std::to_string(l.values.size()) +
                      " (one point per line)");
    for (std::size_t v = 0; v < words.size(); ++v) {
      const bool colour_bits = colour_bits_for_rgb && int(v) == l.role[Rgb];
      if (!parse_value(words[v], l.values[v], colour_bits, row[v]))
        throw Error(file, where, "\"" + printable(words[v], 30) + "\" is not " + type_name(l.values[v]));
    }
    RoleBits bits{};
    for (int r = 0; r < kRoles; ++r)
      if (l.role[r] >= 0) bits[r] = row[std::size_t(l.role[r])];
    append_point(c, l, bits, file, i);
  }
  if (!trailing_allowed && lines.next_nonblank(line))
    throw Error(file, "line " + std::to_string(lines.number()),
                "data after the last of the " + std::to_string(n) + " points");
}

/// Reads `n` binary points, value v of point i at data[address(v, i)] (checked by the caller), either byte order.
template <class Address>
void read_binary_points(std::string_view data, const Layout& l, std::size_t n, bool big_endian, Address address,
                        ColouredCloud& c, const std::string& file) {
  RoleBits bits{};
  for (std::size_t i = 0; i < n; ++i) {
    for (int r = 0; r < kRoles; ++r) {
      if (l.role[r] < 0) continue;
      const auto v = std::size_t(l.role[r]);
      bits[r] = load(data.data() + address(v, i), l.values[v].size, big_endian);
    }
    append_point(c, l, bits, file, i);
  }
}

/// The most points `bytes` of ASCII data can hold with `values` values each (two bytes a value, "1 2 3\n"):
/// the reservation for a count the header claims never exceeds it. A larger claim is then refused by the
/// line that is missing ("truncated: 1 of 50 points"), which tells the user more.
std::size_t ascii_room(std::size_t values, std::size_t bytes) {
  return (bytes + 1) / std::max<std::size_t>(2 * values, 1);
}

}  // namespace

// ---- LZF --------------------------------------------------------------------------------------

bool lzf_decompress(std::string_view in, std::string& out, std::size_t out_size) {
  out.assign(out_size, '\0');
  std::size_t ip = 0, op = 0;
  while (ip < in.size()) {
    const unsigned ctrl = static_cast<unsigned char>(in[ip++]);
    if (ctrl < 32) {  // a literal run of ctrl + 1 bytes
      const std::size_t len = ctrl + 1;
      if (len > in.size() - ip || len > out_size - op) return false;
      std::memcpy(out.data() + op, in.data() + ip, len);
      ip += len;
      op += len;
      continue;
    }
    // A back reference: length (ctrl >> 5) + 2, or 7 + next byte + 2; offset from 13 bits + 1.
    std::size_t len = ctrl >> 5;
    if (len == 7) {
      if (ip >= in.size()) return false;
      len += static_cast<unsigned char>(in[ip++]);
    }
    if (ip >= in.size()) return false;
    const std::size_t back = ((std::size_t(ctrl) & 0x1f) << 8) + static_cast<unsigned char>(in[ip++]) + 1;
    len += 2;
    if (back > op || len > out_size - op) return false;
    for (std::size_t k = 0; k < len; ++k, ++op) out[op] = out[op - back];  // may overlap: byte by byte
  }
  return op == out_size;
}

// ---- PCD --------------------------------------------------------------------------------------

namespace {

struct PcdHeader {
  std::vector<std::string> fields;
  std::vector<Scalar> types;
  std::vector<std::uint64_t> counts;
  std::uint64_t points = 0;
  std::string data;             ///< ascii | binary | binary_compressed
  std::size_t data_offset = 0;  ///< the first byte after the DATA line
  int data_line = 0;            ///< the DATA line's number, for ASCII data errors
};

/// Each field's scalar type and count from the header's SIZE, TYPE and COUNT values (checked before).
void set_field_types(PcdHeader& h, const std::vector<std::string_view>& sizes_given,
                     const std::vector<std::string_view>& types_given, const std::vector<std::string_view>& counts_given) {
  for (std::size_t f = 0; f < h.fields.size(); ++f) {
    const char t = types_given[f][0];
    h.types.push_back({t == 'I'   ? Scalar::Int
                       : t == 'U' ? Scalar::UInt
                                  : Scalar::Float,
                       std::size_t(sizes_given[f][0] - '0')});
    std::uint64_t count = 1;
    if (!counts_given.empty()) whole_number(counts_given[f], 4, count);
    h.counts.push_back(count);
  }
}

/// The PCD header exactly as PCL writes it: each keyword once, in the format's order (VERSION, COUNT and
/// VIEWPOINT optional), FIELDS/SIZE/TYPE/COUNT of one length with the format's values, WIDTH x HEIGHT =
/// POINTS > 0, DATA ascii, binary or binary_compressed; all within the first 64 KiB.
PcdHeader parse_pcd_header(std::string_view bytes, const std::string& file) {
  static const std::vector<std::string_view> order = {"VERSION", "FIELDS", "SIZE",      "TYPE",   "COUNT",
                                                      "WIDTH",   "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
  static const std::set<std::string_view> sizes = {"1", "2", "4", "8"}, types = {"I", "U", "F"},
                                          data_kinds = {"ascii", "binary", "binary_compressed"};
  const auto bad = [&](const std::string& key, const std::string& why) { throw Error(file, key, why); };
  const auto check_count = [&](std::uint64_t count, const std::string& what) {
    if (count > bytes.size())
      bad(what,
          "is " + std::to_string(count) + ", more than the file's " + std::to_string(bytes.size()) + " bytes can hold");
  };
  PcdHeader h;
  Lines lines(bytes.substr(0, kMaxHeaderBytes));
  std::string_view line;
  std::vector<std::string_view> words;
  std::size_t next = 0;
  std::vector<std::string_view> sizes_given, types_given, counts_given;
  std::uint64_t width = 0, height = 0;
  bool have_width = false, have_height = false, have_points = false;
  for (int n = 0; n < 100 && next < order.size() && lines.next(line); ++n) {
    if (line.empty() || line[0] == '#') continue;
    split(line, words);
    const std::string_view key = words.empty() ? std::string_view() : words[0];
    const std::vector<std::string_view> values(words.begin() + (words.empty() ? 0 : 1), words.end());
    if (key != order[next]) {
      // VERSION, COUNT and VIEWPOINT may be left out; the others come in the format's order.
      while (next < order.size() && key != order[next] &&
             (order[next] == "VERSION" || order[next] == "COUNT" || order[next] == "VIEWPOINT"))
        ++next;
      if (next == order.size() || key != order[next])
        bad("", "not a PCD file (header line \"" + printable(line) + "\" out of place or unknown)");
    }
    ++next;
    const std::string k(key);
    if (key == "FIELDS") {
      if (values.empty() || values.size() > 64) bad(k, "expected 1 to 64 fields");
      for (const auto v : values) h.fields.emplace_back(v);
    }
    if (key == "SIZE" || key == "TYPE" || key == "COUNT") {
      if (values.size() != h.fields.size())
        bad(k, "has " + std::to_string(values.size()) + " values for " + std::to_string(h.fields.size()) + " fields");
      for (const auto v : values) {
        std::uint64_t count = 0;
        const bool ok = key == "SIZE"   ? sizes.count(v) > 0
                        : key == "TYPE" ? types.count(v) > 0
                                        : whole_number(v, 4, count) && count > 0;
        if (!ok) bad(k, "\"" + printable(v, 20) + "\" is not a value of the PCD format");
      }
      (key == "SIZE" ? sizes_given : key == "TYPE" ? types_given : counts_given) = values;
    }
    if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS") {
      std::uint64_t v = 0;
      if (values.size() != 1 || !whole_number(values[0], 12, v)) bad(k, "expected one whole number");
      check_count(v, k);
      (key == "WIDTH" ? width : key == "HEIGHT" ? height : h.points) = v;
      (key == "WIDTH" ? have_width : key == "HEIGHT" ? have_height : have_points) = true;
    }
    if (key == "DATA") {
      if (values.size() != 1 || !data_kinds.count(values[0])) bad(k, "expected ascii, binary or binary_compressed");
      h.data = values[0];
      h.data_line = lines.number();
    }
  }
  if (next < order.size()) bad("", "not a PCD file (its header ends before DATA)");
  if (!lines.terminated() && bytes.size() > kMaxHeaderBytes)
    bad("", "not a PCD file (no header within the first 64 KiB)");
  if (!have_width || !have_height || !have_points) bad("", "not a PCD file (no WIDTH, HEIGHT or POINTS)");
  // width x height = points without overflow: each is at most the file size, up to 2^32.
  if (height == 0 ? h.points != 0 : h.points % height != 0 || h.points / height != width)
    bad("POINTS", "is " + std::to_string(h.points) + ", not WIDTH x HEIGHT");
  if (h.points == 0) bad("points", "the cloud is empty");
  if (sizes_given.empty() || types_given.empty()) bad("", "not a PCD file (no SIZE or TYPE line)");
  set_field_types(h, sizes_given, types_given, counts_given);
  h.data_offset = lines.pos();
  return h;
}

/// The record layout of the PCD fields, and which of them the cloud takes: x y z (F4 or F8), rgb or rgba
/// (4 bytes), label (an integer of 1, 2 or 4 bytes), each once with COUNT 1; "_" (padding) and other
/// fields are skipped.
Layout pcd_layout(const PcdHeader& h, const std::string& file) {
  static const std::map<std::string, Role> roles = {{"x", X},     {"y", Y},      {"z", Z},
                                                    {"rgb", Rgb}, {"rgba", Rgb}, {"label", Label}};
  Layout l;
  for (std::size_t f = 0; f < h.fields.size(); ++f) {
    const std::string& name = h.fields[f];
    const Scalar s = h.types[f];
    const auto role = roles.find(name);
    if (role != roles.end()) {
      const auto bad = [&](const std::string& why) { throw Error(file, "FIELDS", "field " + name + ": " + why); };
      if (l.role[role->second] >= 0) bad(role->second == Rgb ? "a second colour field (rgb or rgba)" : "given twice");
      if (h.counts[f] != 1) bad("has COUNT " + std::to_string(h.counts[f]) + ", expected 1");
      const Role r = role->second;
      if (r <= Z && !(s.kind == Scalar::Float && (s.size == 4 || s.size == 8)))
        bad("is " + type_name(s) + ", expected a float of 4 or 8 bytes (TYPE F, SIZE 4 or 8)");
      if (r == Rgb && s.size != 4) bad("is " + type_name(s) + ", expected a packed colour of 4 bytes");
      if (r == Label && !(s.integer() && s.size <= 4))
        bad("is " + type_name(s) + ", expected an integer of 1, 2 or 4 bytes (TYPE U or I)");
      l.role[r] = static_cast<int>(l.values.size());
    }
    for (std::uint64_t k = 0; k < h.counts[f]; ++k) l.add(s);
  }
  if (l.role[X] < 0 || l.role[Y] < 0 || l.role[Z] < 0) throw Error(file, "fields", "the cloud has no x, y, z fields");
  return l;
}

/// binary_compressed: uint32 compressed size, uint32 uncompressed size, then LZF data holding the fields
/// one after the other (all x, then all y, ...), as PCL writes it.
std::string pcd_decompress(std::string_view data, std::size_t expected, const std::string& file) {
  if (data.size() < 8) throw Error(file, "data", "truncated: no compressed sizes after the header");
  const auto compressed = static_cast<std::size_t>(load(data.data(), 4, false));
  const auto uncompressed = static_cast<std::size_t>(load(data.data() + 4, 4, false));
  if (compressed > data.size() - 8)
    throw Error(file, "data",
                "compressed size " + std::to_string(compressed) + " is larger than the " +
                    std::to_string(data.size() - 8) + " bytes after the header");
  if (compressed < data.size() - 8)
    throw Error(file, "data", std::to_string(data.size() - 8 - compressed) + " bytes after the compressed data");
  if (uncompressed != expected)
    throw Error(file, "data",
                "uncompressed size " + std::to_string(uncompressed) +
                    ", expected POINTS x point size = " + std::to_string(expected));
  // LZF makes at most 264 bytes from 3 (a long back reference): a larger claim is refused unallocated.
  if (uncompressed / 88 > compressed)
    throw Error(file, "data",
                "uncompressed size " + std::to_string(uncompressed) + " is more than LZF can make from " +
                    std::to_string(compressed) + " bytes");
  std::string out;
  if (!lzf_decompress(data.substr(8, compressed), out, uncompressed))
    throw Error(file, "data", "the LZF-compressed data is damaged");
  return out;
}

}  // namespace

ColouredCloud parse_pcd(std::string_view bytes, const std::string& file) {
  const PcdHeader h = parse_pcd_header(bytes, file);
  const Layout l = pcd_layout(h, file);
  const std::string_view data = bytes.substr(h.data_offset);
  const auto n = static_cast<std::size_t>(h.points);
  ColouredCloud c;
  if (h.data == "ascii") {
    reserve(c, l, std::min(n, ascii_room(l.values.size(), data.size())));
    Lines lines(bytes, h.data_offset, h.data_line + 1);
    read_ascii_points(lines, l, n, true, false, c, file);
    return c;
  }
  // n <= file size and record_bytes <= 64 x 8 x 9999: the product fits.
  const std::size_t need = n * l.record_bytes;
  if (h.data == "binary") {
    if (data.size() < need)
      throw Error(file, "data",
                  "truncated: POINTS x point size = " + std::to_string(need) + " bytes, the file holds " +
                      std::to_string(data.size()) + " after the header");
    if (data.size() > need)
      throw Error(file, "data", std::to_string(data.size() - need) + " bytes after the last point");
    reserve(c, l, n);
    read_binary_points(
        data, l, n, false, [&](std::size_t v, std::size_t i) { return i * l.record_bytes + l.offsets[v]; }, c, file);
    return c;
  }
  const std::string plain = pcd_decompress(data, need, file);
  reserve(c, l, n);
  // Field by field: value v (a field of COUNT 1) of point i after all points' earlier fields.
  read_binary_points(
      plain, l, n, false, [&](std::size_t v, std::size_t i) { return n * l.offsets[v] + i * l.values[v].size; }, c,
      file);
  return c;
}

// ---- PLY --------------------------------------------------------------------------------------

namespace {

struct PlyProperty {
  std::string name;
  Scalar type;
  bool list = false;
  Scalar count_type;  ///< of a list
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  enum Format { Ascii, LittleEndian, BigEndian } format = Ascii;
  std::vector<PlyElement> elements;
  std::size_t data_offset = 0;
  int lines = 0;  ///< header lines, for ASCII data errors
};

bool ply_type(std::string_view name, Scalar& s) {
  static const std::map<std::string_view, Scalar> types = {
      {"char", {Scalar::Int, 1}},     {"int8", {Scalar::Int, 1}},      {"uchar", {Scalar::UInt, 1}},
      {"uint8", {Scalar::UInt, 1}},   {"short", {Scalar::Int, 2}},     {"int16", {Scalar::Int, 2}},
      {"ushort", {Scalar::UInt, 2}},  {"uint16", {Scalar::UInt, 2}},   {"int", {Scalar::Int, 4}},
      {"int32", {Scalar::Int, 4}},    {"uint", {Scalar::UInt, 4}},     {"uint32", {Scalar::UInt, 4}},
      {"float", {Scalar::Float, 4}},  {"float32", {Scalar::Float, 4}}, {"double", {Scalar::Float, 8}},
      {"float64", {Scalar::Float, 8}}};
  const auto t = types.find(name);
  if (t == types.end()) return false;
  s = t->second;
  return true;
}

/// The vertex properties whose types this reader checks: the cloud's, and those PCL writes beside them
/// (skipped, like any other name). Which types each may have: any number (coordinates and the skipped
/// ones), an integer (colour channels, label), or 4 bytes (a packed rgb/rgba).
enum class Accepts { Number, Integer, Packed };
const std::map<std::string_view, Accepts>& vertex_properties() {
  static const std::map<std::string_view, Accepts> known = {
      {"x", Accepts::Number},         {"y", Accepts::Number},         {"z", Accepts::Number},
      {"nx", Accepts::Number},        {"ny", Accepts::Number},        {"nz", Accepts::Number},
      {"normal_x", Accepts::Number},  {"normal_y", Accepts::Number},  {"normal_z", Accepts::Number},
      {"curvature", Accepts::Number}, {"intensity", Accepts::Number}, {"red", Accepts::Integer},
      {"green", Accepts::Integer},    {"blue", Accepts::Integer},     {"alpha", Accepts::Integer},
      {"rgb", Accepts::Packed},       {"rgba", Accepts::Packed},      {"label", Accepts::Integer}};
  return known;
}

/// Reads one "property TYPE NAME" or "property list COUNT_TYPE TYPE NAME" line into the last element.
/// `bad_line(why)` throws an Error naming the line.
template <class Bad>
void add_ply_property(PlyHeader& h, const std::vector<std::string_view>& words, Bad bad_line) {
  if (h.elements.empty()) bad_line("a property before any element");
  PlyElement& e = h.elements.back();
  const bool vertex = e.name == "vertex";
  const std::string unknown_type =
      "a type that is not a PLY type (char, uchar, short, ushort, int, uint, float, double, "
      "int8, uint8, int16, uint16, int32, uint32, float32, float64)";
  PlyProperty p;
  if (words.size() == 5 && words[1] == "list") {
    if (vertex) bad_line("a list property in the vertex element: this reader takes scalar vertex properties only");
    if (!ply_type(words[2], p.count_type) || !ply_type(words[3], p.type)) bad_line(unknown_type);
    if (!p.count_type.integer()) bad_line("a list's count must be of an integer type");
    p.list = true;
    p.name = words[4];
  } else if (words.size() == 3) {
    if (!ply_type(words[1], p.type)) bad_line(unknown_type);
    p.name = words[2];
  } else {
    bad_line(vertex ? "expected property TYPE NAME (no lists in a vertex)"
                    : "expected property TYPE NAME or property list COUNT_TYPE TYPE NAME");
  }
  if (vertex) {
    // Other tools' properties (quality, confidence, scalar_*) are read past, as PCD's other fields are.
    const auto known = vertex_properties().find(p.name);
    if (known != vertex_properties().end() && known->second == Accepts::Integer && !p.type.integer())
      bad_line("property " + p.name + " must be of an integer type (char, uchar, short, ushort, int or uint)");
    if (known != vertex_properties().end() && known->second == Accepts::Packed && p.type.size != 4)
      bad_line("property " + p.name + " must be a packed colour of 4 bytes (int, uint or float)");
    for (const auto& q : e.properties)
      if (q.name == p.name) bad_line("property " + p.name + " given twice");
  }
  e.properties.push_back(p);
}

/// The PLY 1.0 header: "ply", one "format ascii|binary_little_endian|binary_big_endian 1.0", elements
/// with counts the file can hold (a vertex count > 0), their properties (the vertex's scalar, the known
/// ones of their types, red/green/blue all or none), comments; at most 200 lines, within the first 64 KiB.
PlyHeader parse_ply_header(std::string_view bytes, const std::string& file) {
  static const std::map<std::string_view, PlyHeader::Format> formats = {
      {"ascii", PlyHeader::Ascii},
      {"binary_little_endian", PlyHeader::LittleEndian},
      {"binary_big_endian", PlyHeader::BigEndian}};
  Lines lines(bytes.substr(0, kMaxHeaderBytes));
  std::string_view line;
  std::vector<std::string_view> words;
  if (!lines.next(line) || (split(line, words), words.size() != 1 || words[0] != "ply"))
    throw Error(file, "", "not a PLY file (no \"ply\" line)");
  const auto bad_line = [&](const std::string& why) {
    throw Error(file, "header", "line " + std::to_string(lines.number()) + " (\"" + printable(line) + "\"): " + why);
  };
  PlyHeader h;
  bool have_format = false;
  for (int n = 0; n < 200 && lines.next(line); ++n) {
    split(line, words);
    if (words.empty()) bad_line("is empty");
    const std::string_view word = words[0];
    if (word == "comment" || word == "obj_info") continue;
    if (word == "end_header" && words.size() == 1) {
      if (!have_format) throw Error(file, "", "not a PLY file (no format line)");
      if (!lines.terminated() && bytes.size() > kMaxHeaderBytes) break;
      h.data_offset = lines.pos();
      h.lines = lines.number();
      return h;
    }
    if (word == "format") {
      if (words.size() != 3 || !formats.count(words[1]) || words[2] != "1.0")
        bad_line("expected format ascii|binary_little_endian|binary_big_endian 1.0");
      if (have_format) bad_line("a second format line");
      h.format = formats.at(words[1]);
      have_format = true;
    } else if (word == "element") {
      std::uint64_t count = 0;
      const auto r = words.size() == 3 ? std::from_chars(words[2].data(), words[2].data() + words[2].size(), count)
                                       : std::from_chars_result{nullptr, std::errc::invalid_argument};
      if (r.ec != std::errc() || r.ptr != words[2].data() + words[2].size()) bad_line("expected element NAME COUNT");
      const std::string name(words[1]);
      if (count > bytes.size())  // every element takes at least a byte (or a line)
        throw Error(file, "element " + name,
                    "is " + std::to_string(count) + ", more than the file's " + std::to_string(bytes.size()) +
                        " bytes can hold");
      if (name == "vertex" && count == 0) throw Error(file, "points", "the cloud is empty");
      for (const auto& e : h.elements)
        if (e.name == name && name == "vertex") bad_line("a second vertex element");
      h.elements.push_back({name, count, {}});
    } else if (word == "property") {
      add_ply_property(h, words, bad_line);
    } else {
      bad_line("is not a PLY header line");
    }
  }
  throw Error(file, "", "not a PLY file (no end_header)");
}

/// The vertex element's record layout and what the cloud takes from it.
Layout ply_layout(const PlyElement& vertex, const std::string& file) {
  static const std::map<std::string_view, Role> roles = {{"x", X},         {"y", Y},       {"z", Z},
                                                         {"rgb", Rgb},     {"rgba", Rgb},  {"red", Red},
                                                         {"green", Green}, {"blue", Blue}, {"label", Label}};
  Layout l;
  for (const auto& p : vertex.properties) {
    const auto role = roles.find(p.name);
    if (role != roles.end()) {
      if (l.role[role->second] >= 0) throw Error(file, "element vertex", "has both rgb and rgba");
      l.role[role->second] = static_cast<int>(l.values.size());
    }
    l.add(p.type);
  }
  if (l.role[X] < 0 || l.role[Y] < 0 || l.role[Z] < 0) throw Error(file, "fields", "the cloud has no x, y, z fields");
  const int channels = (l.role[Red] >= 0) + (l.role[Green] >= 0) + (l.role[Blue] >= 0);
  if (channels != 0 && channels != 3)
    throw Error(file, "element vertex", "has some of the colour properties red, green, blue but not all three");
  if (channels == 3 && l.role[Rgb] >= 0)
    throw Error(file, "element vertex", "has both red, green, blue and a packed rgb");
  return l;
}

/// Skips binary element `e` starting at data[pos]; returns the position after it.
std::size_t skip_binary(std::string_view data, std::size_t pos, const PlyElement& e, bool big_endian,
                        const std::string& file) {
  const auto truncated = [&] { throw Error(file, "element " + e.name, "truncated: the file ends inside it"); };
  const bool lists = std::any_of(e.properties.begin(), e.properties.end(), [](const PlyProperty& p) { return p.list; });
  if (!lists) {  // fixed-size records: skipped at once, however many (an element of no property takes no byte)
    std::size_t record = 0;
    for (const auto& p : e.properties) record += p.type.size;
    if (record == 0) return pos;
    if (e.count > (data.size() - pos) / record) truncated();
    return pos + static_cast<std::size_t>(e.count) * record;
  }
  for (std::uint64_t i = 0; i < e.count; ++i)  // each record takes at least its list's count: bounded
    for (const auto& p : e.properties) {
      const std::size_t size = p.list ? p.count_type.size : p.type.size;
      if (size > data.size() - pos) truncated();
      if (!p.list) {
        pos += size;
        continue;
      }
      const std::int64_t items = integer_value(load(data.data() + pos, size, big_endian), p.count_type);
      pos += size;
      if (items < 0) throw Error(file, "element " + e.name, "a list of " + std::to_string(items) + " items");
      if (std::uint64_t(items) > (data.size() - pos) / p.type.size) truncated();
      pos += static_cast<std::size_t>(items) * p.type.size;
    }
  return pos;
}

/// Skips ASCII element `e`: one line per record, its values (lists: a count, then that many) checked.
void skip_ascii(Lines& lines, const PlyElement& e, const std::string& file) {
  if (e.properties.empty()) return;
  std::vector<std::string_view> words;
  std::string_view line;
  for (std::uint64_t i = 0; i < e.count; ++i) {
    if (!lines.next_nonblank(line))
      throw Error(file, "element " + e.name,
                  "truncated: " + std::to_string(i) + " of " + std::to_string(e.count) + " lines");
    const auto bad = [&](const std::string& why) {
      throw Error(file, "line " + std::to_string(lines.number()), "element " + e.name + ": " + why);
    };
    split(line, words);
    std::size_t w = 0;
    const auto value = [&](Scalar s) {
      std::uint64_t bits = 0;
      if (w >= words.size()) bad("too few values");
      if (!parse_value(words[w], s, false, bits)) bad("\"" + printable(words[w], 30) + "\" is not " + type_name(s));
      ++w;
      return bits;
    };
    for (const auto& p : e.properties) {
      if (!p.list) {
        value(p.type);
        continue;
      }
      const std::int64_t items = integer_value(value(p.count_type), p.count_type);
      if (items < 0 || std::uint64_t(items) > words.size() - w)
        bad("a list of " + std::to_string(items) + " items, more than the line holds");
      for (std::int64_t k = 0; k < items; ++k) value(p.type);
    }
    if (w != words.size()) bad(std::to_string(words.size() - w) + " values too many");
  }
}

}  // namespace

ColouredCloud parse_ply(std::string_view bytes, const std::string& file) {
  const PlyHeader h = parse_ply_header(bytes, file);
  const auto vertex =
      std::find_if(h.elements.begin(), h.elements.end(), [](const PlyElement& e) { return e.name == "vertex"; });
  if (vertex == h.elements.end()) throw Error(file, "fields", "the cloud has no x, y, z fields (no vertex element)");
  const Layout l = ply_layout(*vertex, file);
  const auto n = static_cast<std::size_t>(vertex->count);
  ColouredCloud c;
  if (h.format == PlyHeader::Ascii) {
    Lines lines(bytes, h.data_offset, h.lines + 1);
    for (auto e = h.elements.begin(); e != vertex; ++e) skip_ascii(lines, *e, file);
    reserve(c, l, std::min(n, ascii_room(l.values.size(), bytes.size() - lines.pos())));
    read_ascii_points(lines, l, n, true, vertex + 1 != h.elements.end(), c, file);
    return c;
  }
  const bool big = h.format == PlyHeader::BigEndian;
  const std::string_view data = bytes.substr(h.data_offset);
  std::size_t pos = 0;
  for (auto e = h.elements.begin(); e != vertex; ++e) pos = skip_binary(data, pos, *e, big, file);
  // n <= file size, record_bytes <= 200 x 8: the product fits. Bytes after the vertices (later elements) are not read.
  if (n * l.record_bytes > data.size() - pos)
    throw Error(file, "data",
                "truncated: " + std::to_string(n) + " vertices x " + std::to_string(l.record_bytes) +
                    " bytes, the file holds " + std::to_string(data.size() - pos));
  reserve(c, l, n);
  read_binary_points(
      data, l, n, big, [&](std::size_t v, std::size_t i) { return pos + i * l.record_bytes + l.offsets[v]; }, c, file);
  return c;
}

}  // namespace cloud_read

ColouredCloud read_coloured_cloud(const fs::path& path) {
  const std::string ext = path.extension().string();
  if (ext != ".pcd" && ext != ".ply") throw Error(path.string(), "", "a point cloud file must end in .pcd or .ply");
  // Read whole: read_file names a missing file or a folder, and refuses one above kMaxLargeFileBytes
  // before a byte is read.
  const std::string bytes = read_file(path, kMaxLargeFileBytes);
  ColouredCloud c =
      ext == ".pcd" ? cloud_read::parse_pcd(bytes, path.string()) : cloud_read::parse_ply(bytes, path.string());
  c.validate(path.string());
  return c;
}

}  // namespace smseg::cloud
