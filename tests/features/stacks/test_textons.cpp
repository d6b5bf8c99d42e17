// Textons (learn-textons, add-textons): the filter bank says what it claims on images whose answer is
// known, k-means finds clusters that are there and gives the same dictionary whatever the thread count,
// the dictionary file round-trips and refuses damage in one line, and a work folder extended with the
// texton channels reads as its base's features followed by the indicators of each pixel's texton.
#include <gtest/gtest.h>

#include <fstream>

#include <oneapi/tbb/task_arena.h>
#include <opencv2/imgproc.hpp>

#include "smseg/common/error.hpp"
#include "smseg/stacks/appearance.hpp"
#include "smseg/stacks/extract.hpp"
#include "smseg/stacks/textons.hpp"
#include "damaged_file.hpp"
#include "error_text.hpp"
#include "extended_folder.hpp"
#include "small_corridor.hpp"
#include "temp_dir.hpp"

namespace {

using namespace smseg;
using namespace smseg::stacks;
namespace fs = std::filesystem;

/// Four flat quadrants: red, blue, green and grey.
cv::Mat four_colours() {
  cv::Mat bgr(40, 60, CV_8UC3, cv::Scalar(0, 0, 200));
  bgr(cv::Rect(30, 0, 30, 20)).setTo(cv::Scalar(200, 0, 0));
  bgr(cv::Rect(0, 20, 30, 20)).setTo(cv::Scalar(0, 200, 0));
  bgr(cv::Rect(30, 20, 30, 20)).setTo(cv::Scalar(128, 128, 128));
  return bgr;
}

TextonDictionary learned_on(const cv::Mat& bgr, int textons, std::uint64_t seed) {
  TextonLearning o;
  o.textons = textons;
  o.seed = seed;
  return learn_textons(sample_filter_responses(bgr, 3000, seed), o);
}

}  // namespace

TEST(Textons, SeventeenResponsesPerPixelFlatOnAFlatImage) {
  const cv::Mat grey(20, 30, CV_8UC3, cv::Scalar(90, 120, 150));
  const cv::Mat r = filter_bank_responses(grey);
  ASSERT_EQ(r.type(), CV_32FC1);
  ASSERT_EQ(r.rows, 20 * 30);
  ASSERT_EQ(r.cols, kFilterBankSize);
  std::vector<cv::Mat> lab;
  append_lab_rasters(grey, lab);
  for (int i = 0; i < r.rows; i += 37) {
    const float* p = r.ptr<float>(i);
    for (int s = 0; s < 3; ++s)  // the Gaussians give the colour back
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(p[3 * s + c], lab[c].at<double>(0, 0), 1e-5);
    for (int k = 9; k < kFilterBankSize; ++k) EXPECT_NEAR(p[k], 0.0, 1e-5) << k;  // no edge, no blob
  }
  EXPECT_THROW(filter_bank_responses(cv::Mat(4, 4, CV_8UC1, cv::Scalar(0))), Error);
  EXPECT_THROW(filter_bank_responses(cv::Mat()), Error);
}

TEST(Textons, AVerticalEdgeAnswersInXNotInY) {
  cv::Mat bgr(30, 30, CV_8UC3, cv::Scalar::all(30));
  bgr(cv::Rect(15, 0, 15, 30)).setTo(cv::Scalar::all(220));
  const cv::Mat r = filter_bank_responses(bgr);
  const float* at_edge = r.ptr<float>(15 * 30 + 15);
  EXPECT_GT(at_edge[13], 0.05f);               // d/dx, sigma 2: dark to bright
  EXPECT_NEAR(at_edge[14], 0.0f, 1e-5f);       // d/dy, sigma 2
  EXPECT_GT(at_edge[15], at_edge[14] + 0.05f); // d/dx, sigma 4
}

TEST(Textons, EachOfFourFlatColoursGetsATextonOfItsOwn) {
  const cv::Mat bgr = four_colours();
  // More textons than colours: the pixels near the edges, whose blob and edge responses are far from
  // the flat ones', take some of them.
  const TextonDictionary d = learned_on(bgr, 8, 7);
  ASSERT_EQ(d.count(), 8);
  const cv::Mat index = assign_textons(bgr, d);
  ASSERT_EQ(index.size(), bgr.size());
  // The quadrants' inner pixels (away from the Gaussians' reach): one texton each, four different ones.
  const cv::Point centres[] = {{15, 10}, {45, 10}, {15, 30}, {45, 30}};
  std::set<int> seen;
  for (const cv::Point& c : centres) {
    const int t = index.at<std::uint8_t>(c);
    EXPECT_EQ(index.at<std::uint8_t>(c + cv::Point(3, 2)), t);
    seen.insert(t);
  }
  EXPECT_EQ(seen.size(), 4u);
  const std::vector<cv::Mat> rasters = texton_rasters(index, d.count());
  ASSERT_EQ(rasters.size(), 8u);
  cv::Mat total = cv::Mat::zeros(bgr.size(), CV_64F);
  for (const cv::Mat& r : rasters) total += r;
  EXPECT_EQ(cv::countNonZero(total != 1.0), 0);  // exactly one indicator per pixel
  EXPECT_EQ(rasters[static_cast<std::size_t>(index.at<std::uint8_t>(10, 15))].at<double>(10, 15), 1.0);
}

TEST(Textons, SameSeedSameDictionaryWhateverTheThreadCount) {
  cv::Mat bgr(48, 64, CV_8UC3);
  cv::RNG(3).fill(bgr, cv::RNG::UNIFORM, 0, 256);
  const TextonDictionary one = tbb::task_arena(1).execute([&] { return learned_on(bgr, 8, 11); });
  const TextonDictionary two = tbb::task_arena(2).execute([&] { return learned_on(bgr, 8, 11); });
  EXPECT_EQ(cv::norm(one.centres, two.centres, cv::NORM_INF), 0.0);
  EXPECT_EQ(one.mean, two.mean);
  const TextonDictionary other = learned_on(bgr, 8, 12);
  EXPECT_GT(cv::norm(one.centres, other.centres, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::countNonZero(assign_textons(bgr, one) != assign_textons(bgr, two)), 0);
}

TEST(Textons, FewerSamplesThanTextonsOrAbsurdCountsAreRefused) {
  TextonLearning o;
  o.textons = 8;
  EXPECT_NE(test::error_of([&] { learn_textons(cv::Mat(5, kFilterBankSize, CV_32FC1, cv::Scalar(0)), o); }).find("samples"),
            std::string::npos);
  o.textons = 1;
  EXPECT_NE(test::error_of([&] { learn_textons(cv::Mat(50, kFilterBankSize, CV_32FC1, cv::Scalar(0)), o); }).find("--textons"),
            std::string::npos);
}

TEST(Textons, DictionaryFileRoundTripsAndDamageIsRefusedNamingTheFile) {
  const fs::path dir = test::temp_dir("textons_file");
  const test::RemovedAtEnd cleanup{dir};
  TextonDictionary d = learned_on(four_colours(), 4, 7);
  d.provenance = {{"note", "test"}};
  save_texton_dictionary(dir / "d.json", d);
  const TextonDictionary back = load_texton_dictionary(dir / "d.json");
  EXPECT_EQ(cv::norm(d.centres, back.centres, cv::NORM_INF), 0.0);
  EXPECT_EQ(d.mean, back.mean);
  EXPECT_EQ(d.scale, back.scale);
  EXPECT_EQ(back.provenance["note"], "test");

  const Json good = read_json(dir / "d.json");
  const auto refused = [&](const std::function<void(Json&)>& damage, const std::string& what) {
    test::expect_damage_refused(good, dir / "bad.json", [](const fs::path& f) { load_texton_dictionary(f); }, damage, what);
  };
  refused([](Json& j) { j["format"] = "smseg-forest"; }, "format");
  refused([](Json& j) { j["version"] = 9; }, "version");
  refused([](Json& j) { j["filter_bank"] = "lm48"; }, "filter_bank");
  refused([](Json& j) { j["textons"] = 5; }, "centres");
  refused([](Json& j) { j["textons"] = 1; }, "textons");
  refused([](Json& j) { j["mean"].erase(0); }, "mean");
  refused([](Json& j) { j["scale"][3] = 0; }, "scale");
  refused([](Json& j) { j["centres"][1][2] = "x"; }, "centres");
  std::ofstream(dir / "bad.json") << "{\"format\": ";
  EXPECT_NE(test::error_of([&] { load_texton_dictionary(dir / "bad.json"); }).find("bad.json"), std::string::npos);
}

TEST(Textons, ExtendedFolderReadsTheBaseThenEachPixelsIndicator) {
  const fs::path dir = test::temp_dir("textons_folder");
  const test::RemovedAtEnd cleanup{dir};
  const sequence::Sequence seq = test::small_corridor(dir / "seq", 8, 4);
  ExtractOptions eo = test::quiet_extract_options();
  eo.features.appearance = true;
  extract_features(seq, dir / "work", eo);
  const FrameRange all;
  const TextonDictionary d = [&] {
    TextonLearning o;
    o.textons = 6;
    TextonDictionary learned = learn_textons(texton_samples({dir / "work"}, all, 500, 1, false), o);
    save_texton_dictionary(dir / "d.json", learned);
    return learned;
  }();
  EXPECT_EQ(add_texton_channels(d, dir / "d.json", {dir / "work"}, {dir / "tx"}, all, false), 8);

  const StackManifest base = load_stack_manifest(dir / "work");
  const StackManifest m = load_stack_manifest(dir / "tx");
  EXPECT_EQ(m.options["textons"]["textons"], 6);
  const FrameStack ours = test::expect_extends(base, m, d.feature_names());
  const int f = m.labelled_frames.at(0);
  const std::size_t cells = std::size_t(seq.size.height + 1) * std::size_t(seq.size.width + 1);
  const cv::Mat index = assign_textons(seq.load_left(f), d);
  for (int k = 0; k < 6; ++k) {  // each texton's table sums its pixels
    const double* sat = ours.sat(int(base.features.size()) + k);
    EXPECT_EQ(sat[cells - 1], cv::countNonZero(index == k)) << k;
  }
  // Texton channels are not added twice.
  EXPECT_NE(test::error_of([&] { add_texton_channels(d, dir / "d.json", {dir / "tx"}, {dir / "tx2"}, all, false); })
                .find("already has the channel fTx0"),
            std::string::npos);
}
