#include "smseg/sequence/npy.hpp"

#include <cstring>
#include <regex>

namespace smseg::features {

NpyHeader parse_npy_header(std::string_view bytes, const fs::path& file) {
  const auto fail = [&](const std::string& why) {
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
  if (bytes.size() < start + len) fail("truncated header");
  const std::string dict(bytes.substr(start, len));
  NpyHeader h;
  h.data_offset = start + len;
  std::smatch m;
  if (!std::regex_search(dict, m, std::regex("'descr'\\s*:\\s*'([^']*)'"))) fail("no 'descr'");
  h.descr = m[1];
  if (!std::regex_search(dict, m, std::regex("'fortran_order'\\s*:\\s*(True|False)"))) fail("no 'fortran_order'");
  if (m[1] == "True") fail("Fortran order is not supported");
  if (!std::regex_search(dict, m, std::regex("'shape'\\s*:\\s*\\(([^)]*)\\)"))) fail("no 'shape'");
  const std::string shape = m[1];
  const std::regex number("\\d+");
  for (std::sregex_iterator it(shape.begin(), shape.end(), number), end; it != end; ++it)
    h.shape.push_back(static_cast<std::size_t>(std::stoull(it->str())));
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
  const std::string bytes = read_file(path);
  const NpyHeader h = parse_npy_header(bytes, path);
  if (h.descr != "<f4") throw Error(path.string(), "descr", "is '" + h.descr + "', expected '<f4' (float32)");
  if (h.shape.size() != 2) throw Error(path.string(), "shape", "expected a 2-D array");
  const std::size_t n = h.shape[0] * h.shape[1];
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

}  // namespace smseg::features
