// Middlebury 2014 helpers: PFM reading/writing, calib.txt parsing, disparity scoring.

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <map>
#include <sstream>

#include "smseg/frontend/stereo.hpp"

namespace smseg::frontend {

namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

// Reads one whitespace-delimited token starting at pos (skipping leading whitespace).
std::string token(const std::string& bytes, std::size_t& pos) {
  while (pos < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[pos]))) ++pos;
  const std::size_t b = pos;
  while (pos < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[pos]))) ++pos;
  return bytes.substr(b, pos - b);
}

double parse_number(const std::string& text, const fs::path& file, const std::string& field) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used != text.size()) throw std::invalid_argument("trailing");
    return v;
  } catch (const std::exception&) {
    throw Error(file.string(), field, "expected a number, found '" + text + "'");
  }
}

}  // namespace

cv::Mat read_pfm(const fs::path& path) {
  const std::string bytes = read_file(path);
  std::size_t pos = 0;
  const std::string magic = token(bytes, pos);
  if (magic != "Pf") {
    if (magic == "PF") throw Error(path.string(), "header", "colour PFM (PF) is not supported, expected Pf");
    throw Error(path.string(), "header", "not a PFM file (magic '" + magic.substr(0, 8) + "', expected Pf)");
  }
  const double w = parse_number(token(bytes, pos), path, "width");
  const double h = parse_number(token(bytes, pos), path, "height");
  const double scale = parse_number(token(bytes, pos), path, "scale");
  if (w < 1 || h < 1 || w > 1e5 || h > 1e5 || w != std::floor(w) || h != std::floor(h))
    throw Error(path.string(), "header", "bad image size");
  if (scale == 0) throw Error(path.string(), "scale", "must not be 0");
  ++pos;  // the single whitespace character after the scale
  const int W = static_cast<int>(w), H = static_cast<int>(h);
  const std::size_t need = static_cast<std::size_t>(W) * H * 4;
  if (pos > bytes.size() || bytes.size() - pos < need)
    throw Error(path.string(), "data",
                "truncated: " + std::to_string(W) + "x" + std::to_string(H) + " floats need " + std::to_string(need) +
                    " bytes, found " + std::to_string(pos > bytes.size() ? 0 : bytes.size() - pos));
  const bool little = scale < 0;
  cv::Mat out(H, W, CV_32FC1);
  for (int r = 0; r < H; ++r) {
    const char* src = bytes.data() + pos + static_cast<std::size_t>(H - 1 - r) * W * 4;  // bottom row first
    auto* dst = out.ptr<float>(r);
    for (int x = 0; x < W; ++x) {
      unsigned char b[4];
      std::memcpy(b, src + 4 * x, 4);
      const bool host_little = std::endian::native == std::endian::little;
      if (little != host_little) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
      std::memcpy(&dst[x], b, 4);
    }
  }
  return out;
}

void write_pfm(const fs::path& path, const cv::Mat& image) {
  if (image.type() != CV_32FC1) throw Error(path.string(), "", "write_pfm needs a CV_32FC1 image");
  static_assert(std::endian::native == std::endian::little, "little-endian host assumed");
  std::string bytes = "Pf\n" + std::to_string(image.cols) + " " + std::to_string(image.rows) + "\n-1\n";
  for (int r = image.rows - 1; r >= 0; --r)
    bytes.append(reinterpret_cast<const char*>(image.ptr<float>(r)), static_cast<std::size_t>(image.cols) * 4);
  write_file_atomic(path, bytes);
}

MiddleburyCalib read_middlebury_calib(const fs::path& path) {
  const std::string text = read_file(path);
  std::map<std::string, std::string> kv;
  std::istringstream in(text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (trim(line).empty()) continue;
    const auto eq = line.find('=');
    if (eq == std::string::npos)
      throw Error(path.string(), "line " + std::to_string(n), "expected key=value, found '" + trim(line) + "'");
    kv[trim(line.substr(0, eq))] = trim(line.substr(eq + 1));
  }
  auto get = [&](const std::string& key) -> const std::string& {
    auto it = kv.find(key);
    if (it == kv.end()) throw Error(path.string(), key, "missing");
    return it->second;
  };
  auto matrix = [&](const std::string& key) {
    std::string s = get(key);
    if (s.size() < 2 || s.front() != '[' || s.back() != ']')
      throw Error(path.string(), key, "expected [f 0 cx; 0 f cy; 0 0 1]");
    s = s.substr(1, s.size() - 2);
    std::replace(s.begin(), s.end(), ';', ' ');
    std::istringstream ms(s);
    std::vector<double> v;
    std::string tok;
    while (ms >> tok) v.push_back(parse_number(tok, path, key));
    if (v.size() != 9) throw Error(path.string(), key, "expected 9 numbers, found " + std::to_string(v.size()));
    return v;
  };
  MiddleburyCalib c;
  const auto cam0 = matrix("cam0"), cam1 = matrix("cam1");
  c.fx = cam0[0];
  c.cx0 = cam0[2];
  c.fy = cam0[4];
  c.cy = cam0[5];
  c.cx1 = cam1[2];
  auto integer = [&](const std::string& key) {
    const double v = parse_number(get(key), path, key);
    if (v != std::floor(v)) throw Error(path.string(), key, "expected an integer");
    return static_cast<int>(v);
  };
  c.doffs = parse_number(get("doffs"), path, "doffs");
  c.baseline = parse_number(get("baseline"), path, "baseline");
  c.width = integer("width");
  c.height = integer("height");
  c.ndisp = integer("ndisp");
  if (kv.count("vmin")) c.vmin = integer("vmin");
  if (kv.count("vmax")) c.vmax = integer("vmax");
  if (c.fx <= 0) throw Error(path.string(), "cam0", "focal length must be positive");
  if (c.width <= 0 || c.height <= 0) throw Error(path.string(), "width", "image size must be positive");
  if (c.ndisp <= 0) throw Error(path.string(), "ndisp", "must be positive");
  return c;
}

DisparityScore score_disparity(const cv::Mat& est, const cv::Mat& gt, const cv::Mat& mask, double threshold) {
  if (est.type() != CV_32FC1 || gt.type() != CV_32FC1)
    throw Error("", "disparity", "scoring needs CV_32FC1 estimate and ground truth");
  if (est.size() != gt.size()) throw Error("", "disparity", "estimate and ground truth differ in size");
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != gt.size()))
    throw Error("", "mask", "the non-occluded mask must be CV_8UC1 of the ground truth's size");
  DisparityScore s;
  double abs_sum = 0;
  for (int y = 0; y < gt.rows; ++y) {
    const auto* e = est.ptr<float>(y);
    const auto* g = gt.ptr<float>(y);
    const auto* m = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < gt.cols; ++x) {
      ++s.pixels;
      const bool valid = std::isfinite(e[x]) && e[x] > 0;
      if (valid) ++s.valid;
      const bool known = std::isfinite(g[x]) && g[x] > 0 && (m == nullptr || m[x] == 255);
      if (!known) continue;
      ++s.nonocc_known;
      if (!valid) continue;
      ++s.evaluated;
      const double err = std::abs(static_cast<double>(e[x]) - g[x]);
      abs_sum += err;
      if (err > threshold) ++s.bad;
    }
  }
  s.valid_share = s.pixels ? static_cast<double>(s.valid) / s.pixels : 0;
  s.nonocc_valid_share = s.nonocc_known ? static_cast<double>(s.evaluated) / s.nonocc_known : 0;
  s.bad_rate = s.evaluated ? static_cast<double>(s.bad) / s.evaluated : 0;
  s.mean_abs_error = s.evaluated ? abs_sum / s.evaluated : 0;
  return s;
}

}  // namespace smseg::frontend
