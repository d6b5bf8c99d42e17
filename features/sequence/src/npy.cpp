#include "smseg/sequence/npy.hpp"

#include <cstring>
#include <functional>

namespace smseg::sequence {

namespace {

// The header dict is a Python literal, e.g. {'descr': '<f4', 'fortran_order': False, 'shape': (3, 4), }.
// A small scanner reads the three keys we need; anything else in it is ignored, as numpy does.

/// The largest header numpy itself reads (numpy.lib.format's max_header_size is 10 000 bytes): a
/// longer one is not a file numpy writes, and it bounds the work spent on a hostile header.
constexpr std::size_t kMaxHeaderBytes = 65535;
/// Every dimension fits an OpenCV matrix's int, and the whole array stays far below 2^63 bytes.
constexpr std::size_t kMaxDimension = 2147483647;
constexpr std::size_t kMaxElements = std::size_t{1} << 48;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

std::size_t skip_spaces(std::string_view s, std::size_t i) {
  while (i < s.size() && is_space(s[i])) ++i;
  return i;
}

/// The position just after "'key':" (and any spaces), or npos when the key is absent.
std::size_t value_of(std::string_view dict, std::string_view key) {
  const std::string quoted = "'" + std::string(key) + "'";
  const std::size_t at = dict.find(quoted);
  if (at == std::string_view::npos) return at;
  const std::size_t colon = skip_spaces(dict, at + quoted.size());
  if (colon >= dict.size() || dict[colon] != ':') return std::string_view::npos;
  return skip_spaces(dict, colon + 1);
}

/// The shape tuple at dict[i] ("(3, 4)", "(5,)", "()"): non-negative decimal integers only.
std::vector<std::size_t> parse_shape(std::string_view dict, std::size_t i, const std::function<void(const std::string&)>& fail) {
  if (i >= dict.size() || dict[i] != '(') fail("'shape' is not a tuple");
  std::vector<std::size_t> shape;
  std::size_t elements = 1;
  i = skip_spaces(dict, i + 1);
  while (i < dict.size() && dict[i] != ')') {
    if (dict[i] == '-') fail("negative dimension in 'shape'");
    std::size_t value = 0, digits = 0;
    for (; i < dict.size() && dict[i] >= '0' && dict[i] <= '9'; ++i, ++digits) {
      value = value * 10 + static_cast<std::size_t>(dict[i] - '0');
      if (value > kMaxDimension) fail("a dimension in 'shape' is larger than " + std::to_string(kMaxDimension));
    }
    if (digits == 0) fail("'shape' holds something other than non-negative integers");
    if (value > 0 && elements > kMaxElements / value) fail("'shape' describes more than 2^48 elements");
    elements *= value;
    shape.push_back(value);
    i = skip_spaces(dict, i);
    if (i < dict.size() && dict[i] == ',') i = skip_spaces(dict, i + 1);
    else if (i < dict.size() && dict[i] != ')') fail("'shape' items must be separated by commas");
  }
  if (i >= dict.size()) fail("'shape' tuple is not closed");
  return shape;
}

}  // namespace

NpyHeader parse_npy_header(std::string_view bytes, const fs::path& file) {
  const std::function<void(const std::string&)> fail = [&](const std::string& why) {
    throw Error(file.string(), "", "not a valid .npy file: " + why);
  };
  if (bytes.size() < 10 || std::memcmp(bytes.data(), "\x93NUMPY", 6) != 0) fail("bad magic");
  const int major = static_cast<unsigned char>(bytes[6]);
  std::size_t len = 0, start = 0;
  if (major == 1) {
    len = static_cast<unsigned char>(bytes[8]) | (static_cast<unsigned char>(bytes[9]) << 8);
    start = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) fail("truncated header");
    len = 0;
    for (int k = 0; k < 4; ++k) len |= std::size_t(static_cast<unsigned char>(bytes[8 + k])) << (8 * k);
    start = 12;
  } else {
    fail("unsupported version " + std::to_string(major));
  }
  if (len > kMaxHeaderBytes) fail("header of " + std::to_string(len) + " bytes (at most " + std::to_string(kMaxHeaderBytes) + ")");
  if (bytes.size() < start + len) fail("truncated header");
  const std::string_view dict = bytes.substr(start, len);
  NpyHeader h;
  h.data_offset = start + len;
  std::size_t at = value_of(dict, "descr");
  if (at == std::string_view::npos) fail("no 'descr'");
  const std::size_t descr_end = at < dict.size() && dict[at] == '\'' ? dict.find('\'', at + 1) : std::string_view::npos;
  if (descr_end == std::string_view::npos) fail("'descr' is not a quoted string");
  h.descr = std::string(dict.substr(at + 1, descr_end - at - 1));
  at = value_of(dict, "fortran_order");
  if (at == std::string_view::npos) fail("no 'fortran_order'");
  if (dict.substr(at, 4) == "True") fail("Fortran order is not supported");
  if (dict.substr(at, 5) != "False") fail("'fortran_order' is neither True nor False");
  at = value_of(dict, "shape");
  if (at == std::string_view::npos) fail("no 'shape'");
  h.shape = parse_shape(dict, at, fail);
  return h;
}

std::string make_npy_header(const std::string& descr, const std::vector<std::size_t>& shape) {
  std::string dict = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': (";
  for (std::size_t i = 0; i < shape.size(); ++i) dict += std::to_string(shape[i]) + (shape.size() == 1 || i + 1 < shape.size() ? ", " : "");
  dict += "), }";
  std::size_t total = 10 + dict.size() + 1;
  const std::size_t pad = (64 - total % 64) % 64;
  dict.append(pad, ' ');
  dict += '\n';
  std::string h("\x93NUMPY\x01\x00", 8);
  h += static_cast<char>(dict.size() & 0xff);
  h += static_cast<char>((dict.size() >> 8) & 0xff);
  return h + dict;
}

cv::Mat read_npy_f32(const fs::path& path) {
  // The largest 2-D float32 image a sequence can name (20000 x 20000) after the largest header.
  constexpr std::uintmax_t kMaxBytes = 12 + kMaxHeaderBytes + std::uintmax_t{20000} * 20000 * 4;
  const std::string bytes = read_file(path, kMaxBytes);
  const NpyHeader h = parse_npy_header(bytes, path);
  if (h.descr != "<f4") throw Error(path.string(), "descr", "is '" + h.descr + "', expected '<f4' (float32)");
  if (h.shape.size() != 2) throw Error(path.string(), "shape", "expected a 2-D array");
  const std::size_t n = h.shape[0] * h.shape[1];  // at most 2^48 (parse_npy_header)
  if (n == 0) throw Error(path.string(), "shape", "the array is empty");
  if (bytes.size() != h.data_offset + n * 4)
    throw Error(path.string(), "", "size does not match its shape (truncated?)");
  cv::Mat m(static_cast<int>(h.shape[0]), static_cast<int>(h.shape[1]), CV_32FC1);
  std::memcpy(m.data, bytes.data() + h.data_offset, n * 4);
  return m;
}

void write_npy_f32_atomic(const fs::path& path, const cv::Mat& m) {
  CV_Assert(m.type() == CV_32FC1);
  const cv::Mat c = m.isContinuous() ? m : m.clone();
  std::string out = make_npy_header("<f4", {static_cast<std::size_t>(c.rows), static_cast<std::size_t>(c.cols)});
  out.append(reinterpret_cast<const char*>(c.data), c.total() * 4);
  write_file_atomic(path, out);
}

}  // namespace smseg::sequence
