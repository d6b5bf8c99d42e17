// The sequence format: a valid manifest loads; every kind of bad input gives one Error naming the file
// and the problem.
#include <unistd.h>

#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include <opencv2/imgcodecs.hpp>

#include "smseg/common/error.hpp"
#include "smseg/sequence/image_file.hpp"
#include "smseg/sequence/sequence.hpp"

namespace fs = std::filesystem;
using namespace smseg::sequence;
using smseg::Json;

namespace {

class SequenceFormat : public ::testing::Test {
 protected:
  fs::path dir;
  Json manifest;

  void SetUp() override {
    dir = fs::temp_directory_path() / ("smseg_seq_test_" + std::to_string(::getpid()) + "_" +
                                       ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir / "left");
    fs::create_directories(dir / "right");
    fs::create_directories(dir / "labels");
    Json frames = Json::array();
    for (int i = 0; i < 3; ++i) {
      cv::Mat img(12, 16, CV_8UC3, cv::Scalar(10 * i, 20, 30));
      cv::imwrite((dir / "left" / (std::to_string(i) + ".png")).string(), img);
      cv::imwrite((dir / "right" / (std::to_string(i) + ".png")).string(), img);
      cv::Mat lab(12, 16, CV_8UC3, cv::Scalar(0, 0, 255));  // BGR of class "floor" (255,0,0)
      lab(cv::Rect(0, 0, 8, 12)).setTo(cv::Scalar(0, 255, 0));  // "wall" (0,255,0)
      lab.at<cv::Vec3b>(0, 15) = cv::Vec3b(0, 0, 0);              // void
      cv::imwrite((dir / "labels" / (std::to_string(i) + ".png")).string(), lab);
      frames.push_back({{"left", "left/" + std::to_string(i) + ".png"},
                        {"right", "right/" + std::to_string(i) + ".png"},
                        {"label", "labels/" + std::to_string(i) + ".png"},
                        {"time", 0.1 * i}});
    }
    manifest = {{"format", "smseg-sequence"},
                {"version", 1},
                {"name", "tiny"},
                {"kind", "stereo"},
                {"image_size", {{"width", 16}, {"height", 12}}},
                {"calibration", {{"fx", 20.0}, {"fy", 20.0}, {"cx", 7.5}, {"cy", 5.5}, {"baseline", 0.12}}},
                {"camera_height", 1.0},
                {"labels",
                 {{"encoding", "rgb"},
                  {"classes", Json::array({{{"name", "floor"}, {"value", 0}, {"colour", {255, 0, 0}}},
                                           {{"name", "wall"}, {"value", 1}, {"colour", {0, 255, 0}}}})},
                  {"void", {{"name", "void"}, {"value", 255}, {"colour", {0, 0, 0}}}},
                  {"labelled_frames", {0, 2}}}},
                {"frames", frames}};
  }
  void TearDown() override { fs::remove_all(dir); }

  void write(const Json& j) { std::ofstream(dir / "sequence.json") << j.dump(1); }

  // Loads (and decodes every image); returns the error message, or "" if it loaded.
  std::string error_of() {
    try {
      validate_images(load_sequence(dir));
    } catch (const smseg::Error& e) {
      return e.what();
    }
    return "";
  }
  std::string error_with(const Json& j) {
    write(j);
    return error_of();
  }
};

}  // namespace

TEST_F(SequenceFormat, ValidManifestLoadsAndRoundTrips) {
  write(manifest);
  const Sequence seq = load_sequence(dir);
  EXPECT_EQ(seq.frame_count(), 3);
  EXPECT_EQ(seq.size, cv::Size(16, 12));
  EXPECT_EQ(seq.kind, SequenceKind::Stereo);
  EXPECT_EQ(seq.labelled_frames, (std::vector<int>{0, 2}));
  EXPECT_TRUE(seq.is_labelled(2));
  EXPECT_FALSE(seq.is_labelled(1));
  const cv::Mat lab = seq.load_labels(0);
  EXPECT_EQ(lab.at<std::uint8_t>(5, 2), 1);   // wall
  EXPECT_EQ(lab.at<std::uint8_t>(5, 12), 0);  // floor
  EXPECT_EQ(lab.at<std::uint8_t>(0, 15), kVoid);
  EXPECT_EQ(seq.load_left_gray(1).type(), CV_8UC1);

  // save_sequence writes what load_sequence reads.
  Sequence copy = seq;
  save_sequence(copy);
  const Sequence again = load_sequence(dir / "sequence.json");
  EXPECT_EQ(sequence_to_json(again), sequence_to_json(seq));
}

TEST_F(SequenceFormat, IndexEncodingMapsValuesAndRejectsUnknownOnes) {
  manifest["labels"]["encoding"] = "index";
  manifest["labels"]["classes"][0]["value"] = 3;
  manifest["labels"]["classes"][1]["value"] = 7;
  manifest["labels"]["void"]["value"] = 11;
  cv::Mat lab(12, 16, CV_8UC1, cv::Scalar(3));
  lab.at<std::uint8_t>(1, 1) = 7;
  lab.at<std::uint8_t>(2, 2) = 11;
  cv::imwrite((dir / "labels/0.png").string(), lab);
  cv::imwrite((dir / "labels/2.png").string(), lab);
  manifest["frames"][1].erase("label");
  manifest["labels"]["labelled_frames"] = {0, 2};
  write(manifest);
  const Sequence seq = load_sequence(dir);
  const cv::Mat m = seq.load_labels(0);
  EXPECT_EQ(m.at<std::uint8_t>(0, 0), 0);
  EXPECT_EQ(m.at<std::uint8_t>(1, 1), 1);
  EXPECT_EQ(m.at<std::uint8_t>(2, 2), kVoid);

  lab.at<std::uint8_t>(4, 5) = 9;  // not a class
  cv::imwrite((dir / "labels/2.png").string(), lab);
  const std::string e = error_of();
  EXPECT_NE(e.find("labels/2.png"), std::string::npos) << e;
  EXPECT_NE(e.find("(5, 4)"), std::string::npos) << e;
  EXPECT_NE(e.find("label value 9"), std::string::npos) << e;
}

TEST_F(SequenceFormat, UnknownLabelColour) {
  cv::Mat lab = cv::imread((dir / "labels/2.png").string());
  lab.at<cv::Vec3b>(3, 4) = cv::Vec3b(1, 2, 3);
  cv::imwrite((dir / "labels/2.png").string(), lab);
  const std::string e = error_with(manifest);
  EXPECT_NE(e.find("labels/2.png"), std::string::npos) << e;
  EXPECT_NE(e.find("colour (3, 2, 1)"), std::string::npos) << e;
}

TEST_F(SequenceFormat, MissingImage) {
  fs::remove(dir / "right/1.png");
  const std::string e = error_with(manifest);
  EXPECT_NE(e.find("frames[1].right"), std::string::npos) << e;
  EXPECT_NE(e.find("does not exist"), std::string::npos) << e;
}

TEST_F(SequenceFormat, AFolderWhereAnImageShouldBeIsCalledAFolder) {
  fs::remove(dir / "right/1.png");
  fs::create_directories(dir / "right/1.png");
  const std::string e = error_with(manifest);
  EXPECT_NE(e.find("frames[1].right"), std::string::npos) << e;
  EXPECT_NE(e.find("is a folder"), std::string::npos) << e;
}

TEST_F(SequenceFormat, AMissingTimeIsBlamedOnItsOwnFrame) {
  manifest["frames"][1].erase("time");
  std::string e = error_with(manifest);
  EXPECT_NE(e.find("frames[1].time: missing"), std::string::npos) << e;
  // Times on none of the frames is fine (the index is the time); on some but not the first is not.
  for (auto& f : manifest["frames"]) f.erase("time");
  EXPECT_EQ(error_with(manifest), "");
  manifest["frames"][2]["time"] = 0.5;
  e = error_with(manifest);
  EXPECT_NE(e.find("frames[2].time: given, but frames[0] has none"), std::string::npos) << e;
}

TEST_F(SequenceFormat, UnreadableImage) {
  std::ofstream(dir / "left/1.png") << "this is not a PNG";
  const std::string e = error_with(manifest);
  EXPECT_NE(e.find("left/1.png"), std::string::npos) << e;
  EXPECT_NE(e.find("cannot be decoded"), std::string::npos) << e;
}

TEST_F(SequenceFormat, ATruncatedPngGetsOurLineOnly) {
  const std::string png = smseg::read_file(dir / "left/1.png");
  for (const std::size_t keep : {std::size_t{8}, std::size_t{40}, png.size() / 2, png.size() - 4}) {
    std::ofstream(dir / "left/1.png", std::ios::binary) << png.substr(0, keep);
    testing::internal::CaptureStderr();
    const std::string e = error_with(manifest);
    const std::string printed = testing::internal::GetCapturedStderr();
    EXPECT_NE(e.find("left/1.png: cannot be decoded"), std::string::npos) << keep << ": " << e;
    EXPECT_NE(e.find("truncated"), std::string::npos) << keep << ": " << e;
    EXPECT_EQ(printed, "") << keep << ": libpng or OpenCV printed their own lines";
  }
}

// Found by fuzz_label_image: OpenCV hands a file to any of its codecs whose signature matches, and a
// damaged file with DICOM's "DICM" at byte 128 went to GDCM, which aborted the process (an assertion).
// Only the formats a sequence holds reach OpenCV now; this is the fuzzer's file.
TEST_F(SequenceFormat, AnImageOfAnotherFormatNeverReachesOpenCV) {
  const std::string dicom_magic_at_128(
      "\x89\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x00\xde\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\xba\xff\xff\xff\x00\x00\x00\x00\x00\x00\x00\x00\x42\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x49\x49\x2a\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x79\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x10\xf2\x00\x00\x00\x4e\x8c\x62\x5d\x00"
      "\x00\x11\x49\x44\x41\x54\x45\x45\x44\x49\x43\x4d\x60\x82",
      134);
  ASSERT_EQ(dicom_magic_at_128.substr(128, 4), "DICM");
  std::ofstream(dir / "left/1.png", std::ios::binary) << dicom_magic_at_128;
  const std::string e = error_with(manifest);
  EXPECT_NE(e.find("left/1.png: cannot be decoded as an image (not PNG, JPEG, BMP, TIFF, PNM or PFM)"),
            std::string::npos) << e;
}

TEST(ImageFile, EachFormatASequenceHoldsIsToldByItsFirstBytesAndDecoded) {
  const fs::path dir = fs::temp_directory_path() / ("smseg_image_file_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  cv::Mat image(6, 8, CV_8UC1);
  cv::randu(image, 0, 256);
  for (const auto& [ext, name] : std::vector<std::pair<std::string, std::string>>{
           {".png", "PNG"}, {".jpg", "JPEG"}, {".bmp", "BMP"}, {".tiff", "TIFF"}, {".pgm", "PNM"}}) {
    std::vector<std::uint8_t> bytes;
    ASSERT_TRUE(cv::imencode(ext, image, bytes)) << ext;
    EXPECT_EQ(image_format(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size())), name) << ext;
    const fs::path file = dir / ("image" + ext);
    std::ofstream(file, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    const cv::Mat back = read_image_file(file, cv::IMREAD_GRAYSCALE);
    EXPECT_EQ(back.size(), image.size()) << ext;
  }
  EXPECT_EQ(image_format("Pf\n8 6\n-1\n"), "PFM");
  // Found by fuzz_label_image: a RIFF/WEBP header that libwebp turns down, DICOM's magic at byte 128.
  const std::string webp_then_dicom =
      std::string("RIFF\x01\0\0@WEBPGG\xff\xff\xff", 17) + std::string(111, '[') + std::string("DICM\x01\0\0", 7);
  EXPECT_EQ(webp_then_dicom.substr(128, 4), "DICM");
  for (const std::string& other : {webp_then_dicom, std::string("P5#x"), std::string("Pfx"), std::string(128, '\0') + "DICM", std::string("#?RADIANCE\n"),
                                  std::string("\x76\x2f\x31\x01", 4), std::string("\x59\xa6\x6a\x95"), std::string()})
    EXPECT_EQ(image_format(other), "") << other;
  fs::remove_all(dir);
}

// OpenCV's PFM decoder cannot read from memory: imdecode copies the bytes to a temporary file and, when
// decoding fails, leaves it behind (one __opencv_temp.* in /tmp per corrupt PFM; the fuzzers left
// thousands). A PFM is read from its own file instead: no temporary is made, good or corrupt.
TEST(ImageFile, APfmGoodOrCorruptLeavesNoTemporaryFileBehind) {
  const fs::path dir = fs::temp_directory_path() / ("smseg_image_pfm_" + std::to_string(::getpid()));
  fs::create_directories(dir / "opencv_temp");
  ::setenv("OPENCV_TEMP_PATH", (dir / "opencv_temp").c_str(), 1);
  cv::Mat image(6, 8, CV_32FC1);
  cv::randu(image, -5.f, 5.f);
  ASSERT_TRUE(cv::imwrite((dir / "good.pfm").string(), image));
  const cv::Mat back = read_image_file(dir / "good.pfm", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(back.size(), image.size());
  EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0);
  for (const std::string& corrupt : {std::string("Pf\n8 6\n-1\n") + std::string(10, 'x'), std::string("PF\n99999 2\n-1\n"),
                                     std::string("Pf\n-3 6\n-1\n")}) {
    std::ofstream(dir / "bad.pfm", std::ios::binary | std::ios::trunc) << corrupt;
    EXPECT_THROW(read_image_file(dir / "bad.pfm", cv::IMREAD_UNCHANGED), smseg::Error) << corrupt;
  }
  EXPECT_TRUE(fs::is_empty(dir / "opencv_temp"));
  ::unsetenv("OPENCV_TEMP_PATH");
  fs::remove_all(dir);
}

// A PNG declaring another size than the sequence's is refused by its header, before anything is
// decoded: a small PNG can declare 30000 x 30000 pixels (2.7 GB decoded). This one has nothing but the
// header (a decoder would fail on it): the line must be about the size.
TEST_F(SequenceFormat, APngOfAnotherSizeIsRefusedBeforeItIsDecoded) {
  std::string png("\x89PNG\r\n\x1a\n", 8);
  png += std::string("\0\0\0\x0dIHDR\0\0\x75\x30\0\0\x75\x30\x08\x02\0\0\0", 21) + "CRC!";
  png += std::string("\0\0\0\0IEND", 8) + "CRC!";
  std::ofstream(dir / "left/2.png", std::ios::binary) << png;
  const std::string e = error_with(manifest);
  EXPECT_NE(e.find("left/2.png: image is 30000x30000, the sequence"), std::string::npos) << e;
  EXPECT_NE(e.find("says 16x12"), std::string::npos) << e;
}

// A damaged byte anywhere in a PNG breaks its chunk's CRC: our line, and nothing from libpng.
TEST_F(SequenceFormat, ADamagedPngGetsOurLineOnly) {
  std::string png = smseg::read_file(dir / "left/1.png");
  png[png.size() / 2] = static_cast<char>(png[png.size() / 2] ^ 0x10);
  std::ofstream(dir / "left/1.png", std::ios::binary) << png;
  testing::internal::CaptureStderr();
  const std::string e = error_with(manifest);
  const std::string printed = testing::internal::GetCapturedStderr();
  EXPECT_NE(e.find("left/1.png: cannot be decoded: PNG chunk"), std::string::npos) << e;
  EXPECT_NE(e.find("is damaged (its CRC does not match)"), std::string::npos) << e;
  EXPECT_EQ(printed, "") << "libpng or OpenCV printed their own lines";
}

TEST_F(SequenceFormat, WrongImageSize) {
  cv::imwrite((dir / "left/2.png").string(), cv::Mat(10, 16, CV_8UC3, cv::Scalar::all(0)));
  const std::string e = error_with(manifest);
  EXPECT_NE(e.find("left/2.png"), std::string::npos) << e;
  EXPECT_NE(e.find("16x10"), std::string::npos) << e;
  EXPECT_NE(e.find("16x12"), std::string::npos) << e;
}

TEST_F(SequenceFormat, LabelledFrameOutOfRange) {
  manifest["labels"]["labelled_frames"] = {0, 3};
  const std::string e = error_with(manifest);
  EXPECT_NE(e.find("sequence.json"), std::string::npos) << e;
  EXPECT_NE(e.find("labelled frame 3 is out of range"), std::string::npos) << e;
}

TEST_F(SequenceFormat, LabelledFrameWithoutLabel) {
  manifest["frames"][2].erase("label");
  const std::string e = error_with(manifest);
  EXPECT_NE(e.find("has no \"label\""), std::string::npos) << e;
}

TEST_F(SequenceFormat, MalformedJson) {
  std::ofstream(dir / "sequence.json") << "{\n  \"format\": \"smseg-sequence\",\n  \"version\": 1,,\n}";
  const std::string e = error_of();
  EXPECT_NE(e.find("sequence.json"), std::string::npos) << e;
  EXPECT_NE(e.find("malformed JSON at line 3"), std::string::npos) << e;
}

TEST_F(SequenceFormat, UnknownVersionAndForeignFormat) {
  manifest["version"] = 7;
  std::string e = error_with(manifest);
  EXPECT_NE(e.find("unsupported version 7"), std::string::npos) << e;
  manifest["version"] = 1;
  manifest["format"] = "smseg-forest";
  e = error_with(manifest);
  EXPECT_NE(e.find("expected \"smseg-sequence\""), std::string::npos) << e;
}

TEST_F(SequenceFormat, StereoWithoutRightOrDisparity) {
  manifest["frames"][1].erase("right");
  const std::string e = error_with(manifest);
  EXPECT_NE(e.find("frames[1]"), std::string::npos) << e;
  EXPECT_NE(e.find("needs a \"right\" image or a \"disparity\""), std::string::npos) << e;
}

TEST_F(SequenceFormat, FieldErrorsNameTheField) {
  Json j = manifest;
  j["image_size"]["width"] = "sixteen";
  EXPECT_NE(error_with(j).find("image_size.width: expected an integer"), std::string::npos) << error_of();
  j = manifest;
  j["kind"] = "trinocular";
  EXPECT_NE(error_with(j).find("kind: is \"trinocular\""), std::string::npos) << error_of();
  j = manifest;
  j["calibration"].erase("baseline");
  EXPECT_NE(error_with(j).find("calibration.baseline"), std::string::npos) << error_of();
  j = manifest;
  j["labels"]["classes"][1]["colour"] = {255, 0, 0};
  EXPECT_NE(error_with(j).find("colour is used by another class"), std::string::npos) << error_of();
  j = manifest;
  j["frames"] = Json::array();
  EXPECT_NE(error_with(j).find("no frames"), std::string::npos) << error_of();
}

// Ground-truth poses are rotations, as in a tracks file: the reader refused a scaled, reflected or
// zero matrix in tracks.json but took it from sequence.json (and SfM's evaluation then used it).
TEST_F(SequenceFormat, PosesThatAreNotRotationsAreRefused) {
  const Json identity = {{"R", {1, 0, 0, 0, 1, 0, 0, 0, 1}}, {"t", {0, 1, 0}}};
  Json j = manifest;
  j["ground_truth"]["poses"] = {identity, identity, identity};
  EXPECT_EQ(error_with(j), "");
  const fs::path file = dir / "sequence.json";
  for (const Json& R : {Json{2, 0, 0, 0, 1, 0, 0, 0, 1}, Json{-1, 0, 0, 0, 1, 0, 0, 0, 1}, Json{0, 0, 0, 0, 0, 0, 0, 0, 0}}) {
    j["ground_truth"]["poses"][1]["R"] = R;
    EXPECT_EQ(error_with(j), file.string() + ": ground_truth.poses[1].R: is not a rotation matrix");
  }
  // A rotation of a quarter turn about the vertical axis, to six digits.
  j["ground_truth"]["poses"][1]["R"] = {0.707107, 0, 0.707107, 0, 1, 0, -0.707107, 0, 0.707107};
  EXPECT_EQ(error_with(j), "");
}

TEST_F(SequenceFormat, MissingManifest) {
  try {
    load_sequence(dir);
    FAIL() << "expected an error";
  } catch (const smseg::Error& e) {
    EXPECT_NE(std::string(e.what()).find("not a sequence: no sequence.json"), std::string::npos) << e.what();
  }
}

TEST_F(SequenceFormat, GivenDisparityFromNpy) {
  cv::Mat d(12, 16, CV_32FC1, cv::Scalar(4.5f));
  d.at<float>(0, 0) = std::numeric_limits<float>::infinity();
  write_npy_f32_atomic(dir / "disp0.npy", d);
  manifest["frames"][0].erase("right");
  manifest["frames"][0]["disparity"] = "disp0.npy";
  write(manifest);
  const Sequence seq = load_sequence(dir);
  const cv::Mat got = seq.load_disparity(0);
  EXPECT_FLOAT_EQ(got.at<float>(3, 3), 4.5f);
  EXPECT_LT(got.at<float>(0, 0), 0.0f);  // unknown
}

TEST(Npy, RoundTripAndCorruption) {
  const fs::path p = fs::temp_directory_path() / ("smseg_npy_" + std::to_string(::getpid()) + ".npy");
  cv::Mat m(5, 7, CV_32FC1);
  std::mt19937 rng(3);
  for (int i = 0; i < 35; ++i) m.at<float>(i / 7, i % 7) = std::uniform_real_distribution<float>(-9, 9)(rng);
  write_npy_f32_atomic(p, m);
  const cv::Mat r = read_npy_f32(p);
  ASSERT_EQ(r.size(), m.size());
  EXPECT_EQ(cv::norm(r, m, cv::NORM_INF), 0.0);
  // Truncated file.
  const std::string bytes = smseg::read_file(p);
  smseg::write_file_atomic(p, bytes.substr(0, bytes.size() - 4));
  EXPECT_THROW(read_npy_f32(p), smseg::Error);
  smseg::write_file_atomic(p, "garbage");
  EXPECT_THROW(read_npy_f32(p), smseg::Error);
  fs::remove(p);
}

namespace {

/// A version 1.0 .npy header with the given dict (no padding: the reader does not need it).
std::string npy_with_dict(const std::string& dict) {
  std::string h("\x93NUMPY\x01\x00", 8);
  h += static_cast<char>(dict.size() & 0xff);
  h += static_cast<char>((dict.size() >> 8) & 0xff);
  return h + dict;
}

std::string npy_error(const std::string& bytes) {
  try {
    parse_npy_header(bytes, "x.npy");
  } catch (const smseg::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// issue 19, defect 3: a negative dimension used to be read without its minus sign.
TEST(Npy, NegativeShapeIsRefused) {
  const std::string e = npy_error(npy_with_dict("{'descr': '<f4', 'fortran_order': False, 'shape': (-3, 4), }"));
  EXPECT_EQ(e, "x.npy: not a valid .npy file: negative dimension in 'shape'");
}

// The old regex reader let std::stoull's std::out_of_range escape for a huge dimension, and a product of
// dimensions that overflows could pass the size check of a short file; anything but non-negative
// integers in the tuple is refused too.
TEST(Npy, ShapesBeyondTheLimitsOrMalformedAreRefused) {
  const auto shape_error = [](const std::string& shape) {
    return npy_error(npy_with_dict("{'descr': '<f4', 'fortran_order': False, 'shape': " + shape + ", }"));
  };
  EXPECT_NE(shape_error("(99999999999999999999999, 4)").find("larger than 2147483647"), std::string::npos);
  EXPECT_NE(shape_error("(2147483647, 2147483647)").find("more than 2^48 elements"), std::string::npos);
  EXPECT_NE(shape_error("(3; 4)").find("separated by commas"), std::string::npos);
  EXPECT_NE(shape_error("(3, x)").find("other than non-negative integers"), std::string::npos);
  EXPECT_NE(npy_error(npy_with_dict("{'descr': '<f4', 'fortran_order': False, 'shape': (3, 4")).find("not closed"),
            std::string::npos);
  EXPECT_NE(shape_error("[3, 4]").find("not a tuple"), std::string::npos);
  // What numpy writes is read: 2-D, 1-D with its trailing comma, 0-D.
  EXPECT_EQ(parse_npy_header(npy_with_dict("{'descr': '<f4', 'fortran_order': False, 'shape': (3, 4), }"), "x").shape,
            (std::vector<std::size_t>{3, 4}));
  EXPECT_EQ(parse_npy_header(npy_with_dict("{'descr':'|u1','fortran_order':False,'shape':(5,)}"), "x").shape,
            (std::vector<std::size_t>{5}));
  EXPECT_TRUE(parse_npy_header(npy_with_dict("{'descr': '<f8', 'fortran_order': False, 'shape': ()}"), "x").shape.empty());
}

TEST(Npy, EmptyArrayIsRefused) {
  const fs::path p = fs::temp_directory_path() / ("smseg_npy_empty_" + std::to_string(::getpid()) + ".npy");
  smseg::write_file_atomic(p, make_npy_header("<f4", {0, 7}));
  EXPECT_THROW(
      {
        try {
          read_npy_f32(p);
        } catch (const smseg::Error& e) {
          EXPECT_NE(std::string(e.what()).find("shape: the array is empty"), std::string::npos) << e.what();
          throw;
        }
      },
      smseg::Error);
  fs::remove(p);
}
