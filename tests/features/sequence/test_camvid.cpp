// import-camvid on the shared CamVid train+val, and on a made-up folder with a `test` split.
#include <gtest/gtest.h>

#include <fstream>
#include <map>

#include <opencv2/imgcodecs.hpp>

#include "smseg/sequence/camvid.hpp"

namespace fs = std::filesystem;
using namespace smseg::sequence;

namespace {
fs::path temp_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("smseg_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}
}  // namespace

TEST(ImportCamvid, SharedTrainAndValGiveTheExpectedRuns) {
  const fs::path camvid = fs::path(SMSEG_SHARED_DIR) / "data" / "camvid";
  if (!fs::exists(camvid / "frames.csv")) GTEST_SKIP() << "no shared CamVid at " << camvid;
  const fs::path out = temp_dir("camvid_import");
  const auto runs = import_camvid(camvid, out, CamvidImportOptions{});
  std::map<std::string, int> frames;
  int total = 0;
  for (const auto& r : runs) {
    frames[r.name] = r.frames;
    total += r.frames;
  }
  EXPECT_EQ(total, 468);  // 367 train + 101 val
  ASSERT_EQ(runs.size(), 6u);
  EXPECT_EQ(frames["0001TP_006690-008520"], 62);
  EXPECT_EQ(frames["0006R0_f00930-f03930"], 101);
  EXPECT_EQ(frames["0016E5_00390-02400"], 68);    // ends at the 1950-frame gap
  EXPECT_EQ(frames["0016E5_04350-07920"], 120);
  EXPECT_EQ(frames["0016E5_07959-08159"], 101);   // the 15 Hz run, all of val
  EXPECT_EQ(frames["0016E5_08190-08640"], 16);

  const Sequence val = load_sequence(out / "0016E5_07959-08159");
  EXPECT_EQ(val.kind, SequenceKind::Mono);
  EXPECT_EQ(val.size, cv::Size(480, 360));
  EXPECT_EQ(val.classes.size(), 11u);
  EXPECT_EQ(val.void_class.file_value, 11);
  EXPECT_FALSE(val.calibration.fx.has_value());
  EXPECT_EQ(val.labelled_frames.size(), 101u);
  EXPECT_NEAR(val.frames[1].time - val.frames[0].time, 2.0 / 30.0, 1e-9);  // 15 Hz
  // Images are referred to where they are, not copied.
  EXPECT_TRUE(val.frames[0].left.is_absolute());
  EXPECT_EQ(fs::canonical(val.frames[0].left).parent_path(), fs::canonical(camvid / "val"));
  // Labels decode: void (11) becomes kVoid, road (3) is class 3.
  const cv::Mat lab = val.load_labels(0);
  const cv::Mat raw = cv::imread(val.frames[0].label.string(), cv::IMREAD_UNCHANGED);
  for (int y = 0; y < raw.rows; y += 37)
    for (int x = 0; x < raw.cols; x += 41) {
      const int v = raw.at<std::uint8_t>(y, x);
      EXPECT_EQ(lab.at<std::uint8_t>(y, x), v == 11 ? kVoid : v);
    }
  fs::remove_all(out);
}

TEST(ImportCamvid, AnySplitNameImportsTheSameWay) {
  const fs::path src = temp_dir("camvid_fake");
  fs::create_directories(src / "test");
  fs::create_directories(src / "testannot");
  std::ofstream(src / "classes.csv") << "index,name,r,g,b\n0,Sky,128,128,128\n1,Road,128,64,128\n2,Void,0,0,0\n";
  std::ofstream csv(src / "frames.csv");
  csv << "sequence,frame,split,image,label,gap_to_previous_labelled_frame\n";
  // Seq05VD at 1 Hz (3 frames), then 0001TP at 15 Hz (4 frames), then a jump of 100 s.
  const std::vector<std::pair<std::string, int>> rows = {{"Seq05VD", 30}, {"Seq05VD", 60}, {"Seq05VD", 90},
                                                         {"0001TP", 100}, {"0001TP", 102}, {"0001TP", 104},
                                                         {"0001TP", 106}, {"0001TP", 3106}};
  for (const auto& [s, f] : rows) {
    const std::string stem = s + "_" + std::to_string(f);
    cv::imwrite((src / "test" / (stem + ".png")).string(), cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(50)));
    cv::Mat lab(6, 8, CV_8UC1, cv::Scalar(1));
    lab.at<std::uint8_t>(0, 0) = 2;
    cv::imwrite((src / "testannot" / (stem + ".png")).string(), lab);
    csv << s << "," << f << ",test,test/" << stem << ".png,testannot/" << stem << ".png,\n";
  }
  csv.close();
  const fs::path out = temp_dir("camvid_fake_out");
  CamvidImportOptions opt;
  opt.splits = {"test"};
  const auto runs = import_camvid(src, out, opt);
  ASSERT_EQ(runs.size(), 3u);
  EXPECT_EQ(runs[0].frames, 3);
  EXPECT_EQ(runs[0].frame_gap, 30);
  EXPECT_EQ(runs[1].frames, 4);
  EXPECT_EQ(runs[1].frame_gap, 2);
  EXPECT_EQ(runs[2].frames, 1);
  const Sequence s = load_sequence(runs[1].folder);
  EXPECT_EQ(s.load_labels(0).at<std::uint8_t>(0, 0), kVoid);
  EXPECT_EQ(s.load_labels(0).at<std::uint8_t>(1, 1), 1);

  // Asking for a split the folder does not have is a clear error.
  opt.splits = {"val"};
  try {
    import_camvid(src, out, opt);
    FAIL();
  } catch (const smseg::Error& e) {
    EXPECT_NE(std::string(e.what()).find("no frames of split \"val\" (it has: test)"), std::string::npos) << e.what();
  }
  // A missing image is named with its frames.csv line.
  fs::remove(src / "test" / "0001TP_104.png");
  opt.splits = {"test"};
  try {
    import_camvid(src, out, opt);
    FAIL();
  } catch (const smseg::Error& e) {
    EXPECT_NE(std::string(e.what()).find("line 7"), std::string::npos) << e.what();
  }
  fs::remove_all(src);
  fs::remove_all(out);
}

namespace {

std::string import_error(const fs::path& src, const fs::path& out) {
  CamvidImportOptions opt;
  opt.splits = {"train"};
  try {
    import_camvid(src, out, opt);
  } catch (const smseg::Error& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

// Found by fuzz_camvid_frames: a frames.csv cell that is not UTF-8 (a sequence name with byte 0xFF)
// reached sequence.json's writer, where nlohmann threw type_error 316 instead of our one-line error.
// Also: class indices outside 0..255 and frame numbers whose differences overflow are refused.
TEST(ImportCamvid, NonUtf8AndOutOfRangeCellsAreRefusedNamingTheLine) {
  const fs::path src = temp_dir("camvid_bad"), out = temp_dir("camvid_bad_out");
  fs::create_directories(src / "train");
  fs::create_directories(src / "trainannot");
  for (const char* stem : {"A_1", "A_31"}) {
    cv::imwrite((src / "train" / (std::string(stem) + ".png")).string(), cv::Mat(3, 4, CV_8UC3, cv::Scalar::all(9)));
    cv::imwrite((src / "trainannot" / (std::string(stem) + ".png")).string(), cv::Mat(3, 4, CV_8UC1, cv::Scalar(0)));
  }
  const auto write = [&](const std::string& classes, const std::string& frames) {
    std::ofstream(src / "classes.csv") << "index,name,r,g,b\n" << classes;
    std::ofstream(src / "frames.csv") << "sequence,frame,split,image,label\n" << frames;
  };
  const std::string good_classes = "0,Sky,128,128,128\n11,Void,0,0,0\n";
  const std::string good_frames = "A,1,train,train/A_1.png,trainannot/A_1.png\nA,31,train,train/A_31.png,trainannot/A_31.png\n";
  write(good_classes, good_frames);
  EXPECT_EQ(import_error(src, out), "(accepted)");
  write(good_classes, "A\xff\xff,1,train,train/A_1.png,trainannot/A_1.png\n");
  EXPECT_EQ(import_error(src, out), (src / "frames.csv").string() + ": line 2: is not UTF-8 text");
  write("0,Sky\xc3,128,128,128\n11,Void,0,0,0\n", good_frames);
  EXPECT_EQ(import_error(src, out), (src / "classes.csv").string() + ": line 2: is not UTF-8 text");
  write("0,Sky,128,128,128\n256,Void,0,0,0\n", good_frames);
  EXPECT_EQ(import_error(src, out), (src / "classes.csv").string() + ": line 3, index: is 256, expected 0..255");
  write(good_classes, "A,-9223372036854775807,train,train/A_1.png,trainannot/A_1.png\n"
                      "A,9223372036854775807,train,train/A_31.png,trainannot/A_31.png\n");
  EXPECT_EQ(import_error(src, out),
            (src / "frames.csv").string() + ": line 2, frame: is -9223372036854775807, expected 0..1000000000");
  // UTF-8 names are fine.
  write("0,Himmel \xc3\xa9\xe2\x82\xac,128,128,128\n11,Void,0,0,0\n", good_frames);
  EXPECT_EQ(import_error(src, out), "(accepted)");
  fs::remove_all(src);
  fs::remove_all(out);
}

// What the sequence reader refuses, the import refuses first, naming the CSV line: two classes of one
// label value (the sequence.json written was unreadable), two Void rows (one was dropped silently) and
// a video frame listed twice (it became a run of its own, written over another run of the same name,
// or a frame of the train and the test split).
TEST(ImportCamvid, RepeatedClassIndicesAndFramesAreRefusedNamingBothLines) {
  const fs::path src = temp_dir("camvid_repeat"), out = temp_dir("camvid_repeat_out");
  fs::create_directories(src / "train");
  fs::create_directories(src / "trainannot");
  for (const char* stem : {"A_1", "A_31", "A_61"}) {
    cv::imwrite((src / "train" / (std::string(stem) + ".png")).string(), cv::Mat(3, 4, CV_8UC3, cv::Scalar::all(9)));
    cv::imwrite((src / "trainannot" / (std::string(stem) + ".png")).string(), cv::Mat(3, 4, CV_8UC1, cv::Scalar(0)));
  }
  const auto write = [&](const std::string& classes, const std::string& frames) {
    std::ofstream(src / "classes.csv") << "index,name,r,g,b\n" << classes;
    std::ofstream(src / "frames.csv") << "sequence,frame,split,image,label\n" << frames;
  };
  const std::string row1 = "A,1,train,train/A_1.png,trainannot/A_1.png\n",
                    row31 = "A,31,train,train/A_31.png,trainannot/A_31.png\n",
                    row61 = "A,61,train,train/A_61.png,trainannot/A_61.png\n";
  const std::string good_classes = "0,Sky,128,128,128\n1,Road,128,64,128\n11,Void,0,0,0\n";
  write(good_classes, row1 + row31 + row61);
  EXPECT_EQ(import_error(src, out), "(accepted)");
  const fs::path classes = src / "classes.csv", frames = src / "frames.csv";
  write("0,Sky,128,128,128\n0,Road,128,64,128\n11,Void,0,0,0\n", row1 + row31);
  EXPECT_EQ(import_error(src, out),
            classes.string() + ": line 3, index: is 0, as on line 2 (each class needs its own label value)");
  write("0,Sky,128,128,128\n1,Sky,128,64,128\n11,Void,0,0,0\n", row1 + row31);
  EXPECT_EQ(import_error(src, out), classes.string() + ": line 3, name: \"Sky\" is also the name on line 2");
  write("0,Sky,128,128,128\n11,Void,0,0,0\n12,void,1,1,1\n", row1 + row31);
  EXPECT_EQ(import_error(src, out), classes.string() + ": line 4, name: a second Void row (line 3 is the ignore label)");
  write(good_classes, row1 + row31 + row31 + row61);
  EXPECT_EQ(import_error(src, out),
            frames.string() + ": line 4: frame 31 of sequence A is listed again (first on line 3)");
  write(good_classes, row1 + row31 + "A,1,val,train/A_1.png,trainannot/A_1.png\n");
  EXPECT_EQ(import_error(src, out), frames.string() + ": line 4: frame 1 of sequence A is listed again (first on line 2)");
  fs::remove_all(src);
  fs::remove_all(out);
}
