// Our own PCD and PLY reader (read_coloured_cloud, features/cloud/src/cloud_read.cpp): every file PCL's
// writers make, the variants of the formats we accept, and one clear Error for each kind of bad file
// (including every input fuzz_cloud found).
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "smseg/common/error.hpp"
#include "smseg/cloud/cloud_segment.hpp"

using namespace smseg;
using namespace smseg::cloud;
namespace fs = std::filesystem;

namespace {

fs::path temp(const std::string& name) {
  return fs::temp_directory_path() / ("smseg_cloud_read_" + std::to_string(::getpid()) + "_" + name);
}

fs::path write(const std::string& name, const std::string& bytes) {
  const fs::path p = temp(name);
  std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes;
  return p;
}

/// The Error read_coloured_cloud gives for `bytes` in a file called `name` ("" when it reads it).
std::string error_of(const std::string& name, const std::string& bytes) {
  const fs::path p = write(name, bytes);
  std::string what;
  try {
    read_coloured_cloud(p);
  } catch (const Error& e) {
    what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << "one line: " << what;
    EXPECT_EQ(what.rfind(p.string() + ": ", 0), 0u) << "names the file: " << what;
  }
  fs::remove(p);
  return what;
}

/// Expects read_coloured_cloud to refuse `bytes` with an Error containing `part`.
void expect_error(const std::string& name, const std::string& bytes, const std::string& part) {
  const std::string what = error_of(name, bytes);
  EXPECT_NE(what.find(part), std::string::npos) << "expected \"" << part << "\", got: \"" << what << "\"";
}

template <class T>
std::string bytes_of(T v, bool big_endian = false) {
  std::string s(sizeof(T), '\0');
  std::memcpy(s.data(), &v, sizeof(T));
  if (big_endian) std::reverse(s.begin(), s.end());
  return s;
}

/// Seven points with colours and labels, two of them 255 (none).
pcl::PointCloud<pcl::PointXYZRGBL> sample() {
  pcl::PointCloud<pcl::PointXYZRGBL> pc;
  const std::vector<std::uint32_t> labels = {0, 1, 2, 255, 3, 255, 7};
  for (std::size_t i = 0; i < labels.size(); ++i) {
    pcl::PointXYZRGBL p;
    p.x = 0.37f * float(i) - 1.2f;
    p.y = 2.5f - 0.113f * float(i);
    p.z = 4.0f + 0.0071f * float(i * i);
    p.r = std::uint8_t(40 * i);
    p.g = std::uint8_t(255 - 30 * i);
    p.b = std::uint8_t(7 * i + 1);
    p.label = labels[i];
    pc.push_back(p);
  }
  pc.width = std::uint32_t(pc.size());
  pc.height = 1;
  return pc;
}

void expect_sample(const ColouredCloud& c, const pcl::PointCloud<pcl::PointXYZRGBL>& pc, float tolerance,
                   const std::string& kind) {
  ASSERT_EQ(c.size(), pc.size()) << kind;
  ASSERT_EQ(c.colours.size(), pc.size()) << kind;
  ASSERT_EQ(c.labels.size(), pc.size()) << kind;
  for (std::size_t i = 0; i < pc.size(); ++i) {
    const auto& p = pc[i];
    if (tolerance == 0) {
      EXPECT_EQ(c.points[i], Eigen::Vector3f(p.x, p.y, p.z)) << kind << " point " << i;
    } else {
      EXPECT_NEAR(c.points[i].x(), p.x, tolerance) << kind;
      EXPECT_NEAR(c.points[i].y(), p.y, tolerance) << kind;
      EXPECT_NEAR(c.points[i].z(), p.z, tolerance) << kind;
    }
    EXPECT_EQ(c.colours[i], (std::array<std::uint8_t, 3>{p.r, p.g, p.b})) << kind << " point " << i;
    EXPECT_EQ(c.labels[i], p.label == 255 ? -1 : int(p.label)) << kind << " point " << i;
  }
}

const std::string kPcdXyz =
    "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n"
    "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\n";
const std::string kPlyXyz = "property float x\nproperty float y\nproperty float z\n";

}  // namespace

// ---- What PCL writes ------------------------------------------------------------------------------

TEST(CloudRead, ReadsEveryKindOfFilePclWrites) {
  const auto pc = sample();
  struct Kind {
    std::string name;
    std::function<int(const std::string&)> save;
    float tolerance;  // ASCII: PCL prints 8 significant digits
  };
  const std::vector<Kind> kinds = {
      {"binary.pcd", [&](const std::string& f) { return pcl::io::savePCDFileBinary(f, pc); }, 0},
      {"ascii.pcd", [&](const std::string& f) { return pcl::io::savePCDFileASCII(f, pc); }, 1e-6f},
      {"compressed.pcd", [&](const std::string& f) { return pcl::io::savePCDFileBinaryCompressed(f, pc); }, 0},
      {"binary.ply", [&](const std::string& f) { return pcl::io::savePLYFileBinary(f, pc); }, 0},
      {"ascii.ply", [&](const std::string& f) { return pcl::io::savePLYFileASCII(f, pc); }, 1e-6f}};
  for (const Kind& k : kinds) {
    const fs::path p = temp(k.name);
    ASSERT_EQ(k.save(p.string()), 0) << k.name;
    expect_sample(read_coloured_cloud(p), pc, k.tolerance, k.name);
    fs::remove(p);
  }
}

TEST(CloudRead, ReadsWhatOurWriterWrites) {
  TabletopCloudOptions o;
  o.points = 300;
  o.objects = 2;
  const ColouredCloud c = make_tabletop_cloud(o);
  std::vector<int> labels = c.labels;
  labels[5] = -1;
  for (const std::string ext : {".pcd", ".ply"}) {
    const fs::path p = temp("ours" + ext);
    write_labelled_cloud(p, c, labels);
    const ColouredCloud r = read_coloured_cloud(p);
    EXPECT_EQ(r.points, c.points) << ext;
    EXPECT_EQ(r.colours, c.colours) << ext;
    EXPECT_EQ(r.labels, labels) << ext;
    fs::remove(p);
  }
}

// ---- PCD variants -------------------------------------------------------------------------------

TEST(CloudRead, PcdPaddingFieldsAndDoubleCoordinates) {
  // x y z as F8, padding "_" (COUNT 3), a float rgb read bit for bit, an I2 label (-1: none), a field we skip.
  const std::string header =
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z _ rgb label intensity\nSIZE 8 8 8 1 4 2 4\n"
      "TYPE F F F U F I F\nCOUNT 1 1 1 3 1 1 1\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
      "POINTS 2\n";
  std::string data;
  const double xyz[2][3] = {{1.25, -2.5, 1e-3}, {0.1, 0.2, 0.3}};
  const std::uint32_t rgb[2] = {0x00102030u, 0xff0000ffu};
  const std::int16_t label[2] = {4, -1};
  for (int i = 0; i < 2; ++i) {
    for (double v : xyz[i]) data += bytes_of(v);
    data += std::string(3, '\x7f');
    data += bytes_of(std::bit_cast<float>(rgb[i]));
    data += bytes_of(label[i]);
    data += bytes_of(9.5f);
  }
  const fs::path p = write("padding.pcd", header + "DATA binary\n" + data);
  const ColouredCloud c = read_coloured_cloud(p);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[0], Eigen::Vector3f(1.25f, -2.5f, 1e-3f));
  EXPECT_EQ(c.points[1], Eigen::Vector3f(0.1f, 0.2f, 0.3f));
  EXPECT_EQ(c.colours[0], (std::array<std::uint8_t, 3>{0x10, 0x20, 0x30}));
  EXPECT_EQ(c.colours[1], (std::array<std::uint8_t, 3>{0x00, 0x00, 0xff}));
  EXPECT_EQ(c.labels, (std::vector<int>{4, -1}));
  // The same in ASCII (a blank line and CRLF line ends are fine; "nan" in a skipped field too).
  std::ofstream(p) << header
                   << "DATA ascii\r\n1.25 -2.5 0.001 0 0 0 1056816 4 nan\r\n\r\n0.1 0.2 0.3 1 2 3 4278190335 -1 2\r\n";
  const ColouredCloud a = read_coloured_cloud(p);
  EXPECT_EQ(a.points, c.points);
  EXPECT_EQ(a.colours, c.colours);
  EXPECT_EQ(a.labels, c.labels);
  fs::remove(p);
}

TEST(CloudRead, PcdFieldsOfTypesThatMakeNoSenseAreRefused) {
  expect_error("t.pcd", "FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n",
               "FIELDS: field z: is a float of 2 bytes, expected a float of 4 or 8 bytes");
  expect_error("t.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F U\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n",
               "field z: is an unsigned integer of 4 bytes, expected a float");
  expect_error("t.pcd",
               "FIELDS x y z rgb\nSIZE 4 4 4 2\nTYPE F F F U\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3 4\n",
               "field rgb: is an unsigned integer of 2 bytes, expected a packed colour of 4 bytes");
  expect_error("t.pcd",
               "FIELDS x y z label\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3 4\n",
               "field label: is a float of 4 bytes, expected an integer of 1, 2 or 4 bytes");
  expect_error("t.pcd",
               "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 2 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3 4\n",
               "field y: has COUNT 2, expected 1");
  expect_error("t.pcd", "FIELDS x y x\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n",
               "field x: given twice");
  expect_error("t.pcd", "FIELDS x y w\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n",
               "fields: the cloud has no x, y, z fields");
}

TEST(CloudRead, PcdNonFiniteCoordinatesAreRefusedByTheCloud) {
  expect_error("nan.pcd", kPcdXyz + "DATA ascii\n1 2 3\nnan 2 3\n", "points: point 1 is not finite");
}

// ---- PLY variants -------------------------------------------------------------------------------

TEST(CloudRead, PlyBigEndianWithAnyScalarTypes) {
  // double x, short y, float z, ushort/uchar/uint colours, int label (-5: none).
  const std::string header =
      "ply\nformat binary_big_endian 1.0\ncomment made by hand\nelement vertex 2\n"
      "property double x\nproperty int16 y\nproperty float z\nproperty ushort red\n"
      "property uchar green\nproperty uint blue\nproperty int label\nend_header\n";
  std::string data;
  data += bytes_of(1.5, true) + bytes_of(std::int16_t(-7), true) + bytes_of(0.25f, true) +
          bytes_of(std::uint16_t(255), true) + bytes_of(std::uint8_t(1), true) + bytes_of(std::uint32_t(2), true) +
          bytes_of(std::int32_t(3), true);
  data += bytes_of(-1.0, true) + bytes_of(std::int16_t(300), true) + bytes_of(8.0f, true) +
          bytes_of(std::uint16_t(0), true) + bytes_of(std::uint8_t(9), true) + bytes_of(std::uint32_t(10), true) +
          bytes_of(std::int32_t(-5), true);
  const fs::path p = write("big.ply", header + data + "extra bytes after the vertices are not read");
  const ColouredCloud c = read_coloured_cloud(p);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[0], Eigen::Vector3f(1.5f, -7.f, 0.25f));
  EXPECT_EQ(c.points[1], Eigen::Vector3f(-1.f, 300.f, 8.f));
  EXPECT_EQ(c.colours[0], (std::array<std::uint8_t, 3>{255, 1, 2}));
  EXPECT_EQ(c.colours[1], (std::array<std::uint8_t, 3>{0, 9, 10}));
  EXPECT_EQ(c.labels, (std::vector<int>{3, -1}));
  // A colour channel outside 0..255 is refused, in binary as in ASCII.
  std::string wide = data;
  wide.replace(8 + 2 + 4, 2, bytes_of(std::uint16_t(256), true));
  expect_error("wide.ply", header + wide, "point 0: red is 256, outside 0..255");
  expect_error("wide.ply",
               "ply\nformat ascii 1.0\nelement vertex 1\n" + kPlyXyz +
                   "property int red\nproperty int green\nproperty int blue\nend_header\n1 2 3 -1 0 0\n",
               "point 0: red is -1, outside 0..255");
  fs::remove(p);
}

TEST(CloudRead, PlyFaceElementsBeforeAndAfterTheVertices) {
  const std::string face = "element face 2\nproperty list uchar int vertex_indices\nproperty uchar flags\n";
  const std::string vertex =
      "element vertex 2\n" + kPlyXyz + "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  // ASCII, faces first.
  const std::string ascii =
      "ply\nformat ascii 1.0\n" + face + vertex + "end_header\n3 0 1 1 7\n0 9\n1 2 3 10 20 30\n4 5 6 40 50 60\n";
  const fs::path p = write("faces.ply", ascii);
  ColouredCloud c = read_coloured_cloud(p);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[1], Eigen::Vector3f(4, 5, 6));
  EXPECT_EQ(c.colours[1], (std::array<std::uint8_t, 3>{40, 50, 60}));
  EXPECT_FALSE(c.has_labels());
  // ASCII, faces after: not read.
  std::ofstream(p) << "ply\nformat ascii 1.0\n" + vertex + face +
                          "end_header\n1 2 3 10 20 30\n4 5 6 40 50 60\n3 0 1 1 7\n0 9\n";
  EXPECT_EQ(read_coloured_cloud(p).points, c.points);
  // Binary little endian, faces first (a list of 3 ints, then one of none).
  std::string faces = bytes_of(std::uint8_t(3)) + bytes_of(0) + bytes_of(1) + bytes_of(1) + bytes_of(std::uint8_t(7)) +
                      bytes_of(std::uint8_t(0)) + bytes_of(std::uint8_t(9));
  std::string points;
  for (int i = 0; i < 2; ++i) {
    points += bytes_of(float(1 + 3 * i)) + bytes_of(float(2 + 3 * i)) + bytes_of(float(3 + 3 * i));
    points += std::string{char(10 + 30 * i), char(20 + 30 * i), char(30 + 30 * i)};
  }
  std::ofstream(p, std::ios::binary) << "ply\nformat binary_little_endian 1.0\n" + face + vertex + "end_header\n" +
                                            faces + points;
  ColouredCloud b = read_coloured_cloud(p);
  EXPECT_EQ(b.points, c.points);
  EXPECT_EQ(b.colours, c.colours);
  std::ofstream(p, std::ios::binary) << "ply\nformat binary_little_endian 1.0\n" + vertex + face + "end_header\n" +
                                            points + faces;
  b = read_coloured_cloud(p);
  EXPECT_EQ(b.points, c.points);
  // A face list that runs past the end of the file.
  std::ofstream(p, std::ios::binary) << "ply\nformat binary_little_endian 1.0\n" + face + vertex + "end_header\n" +
                                            bytes_of(std::uint8_t(200)) + bytes_of(0);
  EXPECT_THROW(read_coloured_cloud(p), Error);
  fs::remove(p);
}

// ---- One clear Error per kind of bad file ------------------------------------------------------------

TEST(CloudRead, TruncatedBinaryDataIsRefused) {
  const std::string point = bytes_of(1.f) + bytes_of(2.f) + bytes_of(3.f);
  expect_error("short.pcd", kPcdXyz + "DATA binary\n" + point + point.substr(0, 11),
               "data: truncated: POINTS x point size = 24 bytes, the file holds 23 after the header");
  expect_error("long.pcd", kPcdXyz + "DATA binary\n" + point + point + "x", "data: 1 bytes after the last point");
  expect_error("short.ply",
               "ply\nformat binary_little_endian 1.0\nelement vertex 2\n" + kPlyXyz + "end_header\n" + point,
               "data: truncated: 2 vertices x 12 bytes, the file holds 12");
}

TEST(CloudRead, AsciiLinesOfTheWrongLengthOrNotNumbersAreRefused) {
  expect_error("a.pcd", kPcdXyz + "DATA ascii\n1.5 2.5 3.5\n4.5 5.5\n",
               "line 12: 2 values, expected 3 (one point per line)");
  expect_error("a.pcd", kPcdXyz + "DATA ascii\n1 2 3\n4 5 6 7\n", "line 12: 4 values, expected 3");
  expect_error("a.pcd", kPcdXyz + "DATA ascii\n1 2 3\n4 five 6\n", "line 12: \"five\" is not a float of 4 bytes");
  expect_error("a.pcd", kPcdXyz + "DATA ascii\n1.5 2.5 3.5\n", "data: truncated: 1 of 2 points");
  expect_error("a.pcd", kPcdXyz + "DATA ascii\n1 2 3\n4 5 6\n7 8 9\n", "line 13: data after the last of the 2 points");
  expect_error("a.ply", "ply\nformat ascii 1.0\nelement vertex 2\n" + kPlyXyz + "end_header\n1.5 2.5 3.5\n4.5 5.5\n",
               "line 9: 2 values, expected 3");
  expect_error("a.ply",
               "ply\nformat ascii 1.0\nelement vertex 1\n" + kPlyXyz +
                   "property uchar red\nproperty uchar green\n"
                   "property uchar blue\nend_header\n1 2 3 300 0 0\n",
               "line 11: \"300\" is not an unsigned integer of 1 byte");
}

TEST(CloudRead, DamagedCompressedPcdIsRefused) {
  const std::string header = kPcdXyz + "DATA binary_compressed\n";
  const auto sizes = [](std::uint32_t compressed, std::uint32_t uncompressed) {
    return bytes_of(compressed) + bytes_of(uncompressed);
  };
  // A literal run of 24 bytes (control byte 23) is a valid stream for two xyz points.
  const std::string literal = std::string(1, char(23)) + std::string(24, '\0');
  const fs::path p = write("ok.pcd", header + sizes(25, 24) + literal);
  EXPECT_EQ(read_coloured_cloud(p).size(), 2u);
  fs::remove(p);
  // A back reference before the start of the output.
  expect_error("lzf.pcd", header + sizes(3, 24) + std::string{char(0xe0), char(20), char(5)},
               "data: the LZF-compressed data is damaged");
  // A literal run longer than the stream, and a stream that makes too few bytes.
  expect_error("lzf.pcd", header + sizes(5, 24) + std::string{char(23), 1, 2, 3, 4},
               "the LZF-compressed data is damaged");
  expect_error("lzf.pcd", header + sizes(3, 24) + std::string{char(1), 1, 2}, "the LZF-compressed data is damaged");
  expect_error("lzf.pcd", header + sizes(1000, 24) + literal,
               "data: compressed size 1000 is larger than the 25 bytes after the header");
  expect_error("lzf.pcd", header + sizes(25, 48) + literal,
               "data: uncompressed size 48, expected POINTS x point size = 24");
  expect_error("lzf.pcd", header + sizes(4, 24), "compressed size 4 is larger than the 0 bytes");
  expect_error("lzf.pcd", header + "\x01\x02", "data: truncated: no compressed sizes after the header");
}

TEST(CloudRead, CountsTheDataCannotHoldAreRefusedBeforeAllocating) {
  const std::string point = bytes_of(1.f) + bytes_of(2.f) + bytes_of(3.f);
  expect_error("many.ply",
               "ply\nformat binary_little_endian 1.0\nelement vertex 100\n" + kPlyXyz + "end_header\n" + point,
               "data: truncated: 100 vertices x 12 bytes, the file holds 12");
  expect_error("many.ply", "ply\nformat ascii 1.0\nelement vertex 100\n" + kPlyXyz + "end_header\n1 2 3\n",
               "data: truncated: 1 of 100 points");
  expect_error("many.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 50\nHEIGHT 1\nPOINTS 50\nDATA ascii\n1 2 3\n",
               "data: truncated: 1 of 50 points");
  expect_error("many.ply",
               "ply\nformat binary_little_endian 1.0\nelement face 90\nproperty list uint int vertex_indices\n"
               "element vertex 1\n" +
                   kPlyXyz + "end_header\n" + bytes_of(std::uint32_t(1u << 30)) + point,
               "element face: truncated: the file ends inside it");
}

TEST(CloudRead, PlyHeadersThisReaderDoesNotTakeAreRefused) {
  const std::string start = "ply\nformat binary_little_endian 1.0\nelement vertex 1\n" + kPlyXyz;
  expect_error("h.ply", start + "property list uchar int vertex_indices\nend_header\n",
               "header: line 7 (\"property list uchar int vertex_indices\"): a list property in the vertex element");
  expect_error("h.ply", start + "property half intensity\nend_header\n",
               "header: line 7 (\"property half intensity\"): a type that is not a PLY type");
  expect_error("h.ply",
               "ply\nformat ascii 1.0\nelement face 1\nproperty list float int v\n" +
                   std::string("element vertex 1\n") + kPlyXyz + "end_header\n",
               "header: line 4 (\"property list float int v\"): a list's count must be of an integer type");
  expect_error("h.ply", start + "property float label\nend_header\n", "property label must be of an integer type");
  expect_error("h.ply", start + "property uchar rgb\nend_header\n", "property rgb must be a packed colour of 4 bytes");
  expect_error("h.ply", start + "property float x\nend_header\n", "property x given twice");
  expect_error("h.ply", "ply\nformat ascii 1.0\nelement face 1\nproperty float x\nend_header\n1\n",
               "fields: the cloud has no x, y, z fields (no vertex element)");
  expect_error("h.ply", "ply\nelement vertex 1\n" + kPlyXyz + "end_header\n1 2 3\n", "not a PLY file (no format line)");
  expect_error("h.ply", "ply\nformat ascii 1.0\nformat ascii 1.0\n", "a second format line");
}

// Every input fuzz_cloud found (against PCL's readers, docs/reliability.md) and the hand-made input classes:
// each one clear line now, from our own reader.
TEST(CloudRead, FuzzFindingsAreOneLineErrors) {
  const std::vector<std::pair<std::string, std::string>> inputs = {
      {"keyword.pcd",
       "# .PCD v0.7\nVERSION 0.7\nFOO 1\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\n"
       "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n1 2 3\n"},
      {"versformat.pcd", "VERSformat ascii 1.0\nFIELDS x y z\n"},
      {"repeated.pcd", kPcdXyz + "DATA asci\x01\nFIELDS x y z\nSIZE 4 4 4\nPOINTS 2\nDATA binary\n"},
      {"size.pcd",
       "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 42222222222222222222\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n"
       "POINTS 1\nDATA ascii\n1 2 3\n"},
      {"huge.pcd",
       "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1000000000\nHEIGHT 1\n"
       "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1000000000\nDATA ascii\n1 2 3\n"},
      {"zero.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 0\nHEIGHT 1\nPOINTS 0\nDATA binary\n"},
      {"no-vertex.ply", "ply\nformat ascii 1.0\nelement vertex 0\n" + kPlyXyz + "end_header\n"},
      {"damaged.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 9\nproperty float x\n"
       "propertIEWPOINT 0 0 0 1 0 0 0\nPOINTS 9\nproperty uchar green\nproperty uchar blue\n"
       "property uint label\nend_header\n"},
      {"green-blue.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" + kPlyXyz +
                             "property uchar green\n"
                             "property uchar blue\nend_header\n1 2 3 4 5\n"},
      {"property-red.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" + kPlyXyz +
                               "property uchar property uchar red\n"
                               "property uchar green\nproperty uchar blue\nend_header\n1 2 3 4 5 6\n"},
      {"huge.ply", "ply\nformat ascii 1.0\nelement vertex 4000000000\n" + kPlyXyz + "end_header\n1 2 3\n"},
      {"no-end.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" + kPlyXyz},
      {"empty.ply", ""},
      {"empty.pcd", ""},
      {"no-line-breaks.pcd", std::string(70000, 'F')},
      {"no-line-breaks.ply", "ply\n" + std::string(70000, 'e')},
  };
  for (const auto& [name, bytes] : inputs) EXPECT_NE(error_of(name, bytes), "") << name << " was accepted";
}

// fuzz_cloud's seeds (byte 0 picks the extension: even .pcd, odd .ply) are clouds the reader takes, so that
// the fuzzer starts from every kind: PCL's binary, ASCII and compressed PCD, ASCII and binary PLY (with the
// camera element PCL writes after the vertices), big-endian PLY with faces first, ASCII PCD with padding.
TEST(CloudRead, FuzzSeedsAreRead) {
  int seeds = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(SMSEG_SOURCE_DIR) / "fuzz/corpus/fuzz_cloud")) {
    std::ifstream in(entry.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_FALSE(bytes.empty()) << entry.path();
    const fs::path p = write(bytes[0] % 2 == 0 ? "seed.pcd" : "seed.ply", bytes.substr(1));
    EXPECT_GT(read_coloured_cloud(p).size(), 0u) << entry.path();
    fs::remove(p);
    ++seeds;
  }
  EXPECT_GE(seeds, 8);
}
