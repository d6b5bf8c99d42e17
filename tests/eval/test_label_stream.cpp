// label-stream's promise (issue "real scale", part 5): a stereo video labelled frame by frame, as it
// comes, gets exactly the labels of `extract-features --causal` + `eval-forest` on the same frames,
// per pixel and by grid voting, with either tracker; and the streamed front end follows the same
// camera path as the whole-sequence one.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "smseg/eval/stream.hpp"
#include "smseg/sequence/kitti.hpp"
#include "smseg/forest/train.hpp"
#include "smseg/stacks/extract.hpp"
#include "smseg/synth/synth.hpp"
#include "error_text.hpp"
#include "run_tool.hpp"
#include "smseg/common/io.hpp"
#include "temp_dir.hpp"

namespace {

using namespace smseg;
namespace fs = std::filesystem;

struct StreamCase {
  std::string name;
  frontend::FrameTracker tracker;
  frontend::KeypointMethod detector;
  int grid = 0;
  bool textons = false;
  frontend::StereoMethod stereo = frontend::stereo_default_stereo().method;  // the tools' default (sparse)
  friend void PrintTo(const StreamCase& c, std::ostream* os) { *os << c.name; }
};

// Every frame's labels as the stream gives them: the first frames through the stream's calibration
// of its disparity offset (auto, the default), then one at a time. `points`: the observations of
// the frames labelled one at a time.
std::vector<cv::Mat> stream_labels(eval::StreamLabeller& stream, const sequence::Sequence& s, int frames,
                                          int& points) {
  std::vector<frontend::StereoFrontEndStream::Prepared> first;
  std::vector<int> indices;
  for (int f = 0; f < std::min(frames, frontend::kOffsetFrames); ++f) {
    first.push_back(stream.prepare(s.load_left_gray(f), s.load_right_gray(f)));
    indices.push_back(f);
  }
  std::vector<cv::Mat> labels;
  for (const auto& tracked : stream.calibrate(std::move(first), indices)) labels.push_back(stream.classify(tracked));
  for (int f = static_cast<int>(labels.size()); f < frames; ++f) {
    labels.push_back(stream.push(s.load_left_gray(f), s.load_right_gray(f), f));
    points += static_cast<int>(stream.last_frame().observations.size());
  }
  return labels;
}

class LabelStream : public ::testing::TestWithParam<StreamCase> {
 protected:
  static fs::path dir;
  static std::optional<sequence::Sequence> seq;
  static void SetUpTestSuite() {
    dir = test::temp_dir("label_stream");
    synth::SynthOptions so;
    so.frames = 36;
    so.label_every = 3;
    seq = synth::make_sequence(so, dir / "seq");
  }
  static void TearDownTestSuite() { fs::remove_all(dir); }

  // extract-features --causal into `work` with the case's front end, and a small forest trained on it.
  static forest::Forest causal_forest(const StreamCase& c, const fs::path& work) {
    stacks::ExtractOptions eo;
    eo.front_end = front_end(c);
    eo.features.causal = true;
    eo.progress = false;
    stacks::extract_features(*seq, work, eo);
    forest::TrainParams tp;
    tp.K = 100;
    tp.Kt = 1500;
    tp.M = 3;
    tp.textons = c.textons;
    return forest::train_forest(stacks::open_stacks({work}, {}, true, true, {}).dataset, tp);
  }

  static frontend::FrontEndOptions front_end(const StreamCase& c) {
    frontend::FrontEndOptions fe;
    fe.tracker = c.tracker;
    fe.tracking.detector = c.detector;
    fe.stereo.method = c.stereo;
    fe.progress = false;
    return fe;
  }
};
fs::path LabelStream::dir;
std::optional<sequence::Sequence> LabelStream::seq;

TEST_P(LabelStream, SameLabelsAsCausalExtractionAndEvaluation) {
  const StreamCase& c = GetParam();
  const fs::path work = dir / ("work-" + c.name);
  const forest::Forest forest = causal_forest(c, work);

  eval::EvalOptions ev;
  ev.grid = c.grid;
  ev.votes = 6;
  const forest::Classifier classifier(forest);
  const auto all = stacks::open_stacks({work}, stacks::FrameRange{}, false, false, forest.features);
  ASSERT_EQ(static_cast<int>(all.stacks.size()), seq->frame_count());

  eval::StreamOptions so;
  so.front_end = front_end(c);
  so.eval = ev;
  eval::StreamLabeller stream(forest, "forest.json", seq->calibration, seq->camera_height, seq->size, so, "seq");
  int points = 0;
  const std::vector<cv::Mat> streamed = stream_labels(stream, *seq, seq->frame_count(), points);
  for (int f = 0; f < seq->frame_count(); ++f) {
    const cv::Mat batch = eval::label_frame(classifier, all.dataset.frames[f], ev, f);
    ASSERT_EQ(cv::countNonZero(batch != streamed[f]), 0) << c.name << ", frame " << f;
  }
  EXPECT_GT(points, 20 * (seq->frame_count() - frontend::kOffsetFrames)) << "the stream must have tracked points to compare";
}

INSTANTIATE_TEST_SUITE_P(
    Trackers, LabelStream,
    ::testing::Values(StreamCase{"descriptors_bm_pixel_textons", frontend::FrameTracker::Descriptors,
                                 frontend::KeypointMethod::Sift, 0, true, frontend::StereoMethod::BM},
                      StreamCase{"descriptors_bm_grid", frontend::FrameTracker::Descriptors,
                                 frontend::KeypointMethod::Sift, 20, false, frontend::StereoMethod::BM},
                      StreamCase{"klt_gftt_bm_pixel", frontend::FrameTracker::Klt, frontend::KeypointMethod::Gftt, 0, false,
                                 frontend::StereoMethod::BM},
                      StreamCase{"klt_gftt_sparse_grid", frontend::FrameTracker::Klt, frontend::KeypointMethod::Gftt, 20,
                                 false, frontend::StereoMethod::Sparse}),
    [](const ::testing::TestParamInfo<StreamCase>& i) { return i.param.name; });

// The pipeline (run_stream: frames tracked in order, classified in parallel, the first ones held for the
// calibration) gives the labels of the labeller frame after frame, to the sink in order, whatever the
// frames in flight; also for a video that ends among the calibration's first frames.
TEST_F(LabelStream, PipelineGivesTheLabelsOfFrameAfterFrame) {
  const StreamCase c{"klt_grid", frontend::FrameTracker::Klt, frontend::KeypointMethod::Gftt, 20, false};
  const forest::Forest forest = causal_forest(c, dir / "work-pipeline");
  eval::StreamOptions so;
  so.front_end = front_end(c);
  so.eval.grid = c.grid;
  so.eval.votes = 6;
  for (const int frames : {seq->frame_count(), frontend::kOffsetFrames, frontend::kOffsetFrames - 5}) {
    int points = 0;
    eval::StreamLabeller one_by_one(forest, "forest.json", seq->calibration, seq->camera_height, seq->size, so, "seq");
    const std::vector<cv::Mat> expected = stream_labels(one_by_one, *seq, frames, points);
    for (const std::size_t in_flight : {1, 2, 5}) {
      eval::StreamLabeller stream(forest, "forest.json", seq->calibration, seq->camera_height, seq->size, so, "seq");
      int next = 0;
      const eval::StreamSource source = [&](eval::StreamInput& in) {
        if (next == frames) return false;
        in.index = next;
        in.left = seq->load_left_gray(next);
        in.right = seq->load_right_gray(next);
        ++next;
        return true;
      };
      std::vector<int> order;
      std::vector<cv::Mat> streamed;
      const eval::StreamSink sink = [&](const eval::StreamInput& in, const cv::Mat& labels, const eval::StreamStageTimes&) {
        order.push_back(in.index);
        streamed.push_back(labels.clone());
      };
      ASSERT_EQ(eval::run_stream(stream, source, sink, in_flight), frames) << frames << " frames, " << in_flight;
      for (int f = 0; f < frames; ++f) {
        ASSERT_EQ(order[f], f) << frames << " frames, " << in_flight << " in flight: the sink's order";
        ASSERT_EQ(cv::countNonZero(expected[f] != streamed[f]), 0) << frames << " frames, " << in_flight << ", frame " << f;
      }
    }
  }
}

TEST_F(LabelStream, FrontEndFollowsTheWholeSequencePath) {
  for (const auto tracker : {frontend::FrameTracker::Descriptors, frontend::FrameTracker::Klt}) {
    for (const auto stereo : {frontend::StereoMethod::BM, frontend::StereoMethod::Sparse}) {
      StreamCase c{"", tracker,
                   tracker == frontend::FrameTracker::Klt ? frontend::KeypointMethod::Gftt : frontend::KeypointMethod::Sift,
                   0, false, stereo};
      const frontend::FrontEndOptions fe = front_end(c);
      const frontend::FrontEndResult whole = frontend::run_stereo_front_end(*seq, fe);
      frontend::StereoFrontEndStream stream(seq->calibration, seq->camera_height, fe, "seq");
      std::vector<frontend::StereoFrontEndStream::Prepared> first;
      for (int f = 0; f < frontend::kOffsetFrames; ++f)
        first.push_back(stream.prepare(seq->load_left_gray(f), seq->load_right_gray(f)));
      std::vector<frontend::StreamFrame> frames = stream.calibrate(std::move(first));
      EXPECT_EQ(stream.disparity_offset(), whole.summary.disparity_offset);
      for (int f = 0; f < seq->frame_count(); ++f) {
        if (f >= frontend::kOffsetFrames) frames.push_back(stream.push(seq->load_left_gray(f), seq->load_right_gray(f)));
        const frontend::StreamFrame& fr = frames[f];
        EXPECT_EQ(fr.pose.R, whole.poses[f].R) << frontend::frame_tracker_name(tracker) << ", frame " << f;
        EXPECT_EQ(fr.pose.t, whole.poses[f].t) << frontend::frame_tracker_name(tracker) << ", frame " << f;
        if (f > 0) {
          EXPECT_EQ(fr.motion->inliers, whole.pair_motions[f - 1].inliers);
          EXPECT_EQ(fr.motion->bridged, whole.pair_motions[f - 1].bridged);
        }
      }
    }
  }
}

// The tool: from the sequence folder, from a side-by-side video and from two cameras (here image
// sequences, which OpenCV opens as videos, of the same grey frames) it writes the labels eval-forest
// writes for the causal work folder, and a summary with its speed.
TEST_F(LabelStream, ToolLabelsFoldersSideBySideVideoAndTwoCamerasAlike) {
  const StreamCase c{"tool", frontend::FrameTracker::Klt, frontend::KeypointMethod::Gftt};  // the tools' defaults
  const fs::path work = dir / "work-tool", forest_file = dir / "forest-tool.json";
  forest::save_forest(causal_forest(c, work), forest_file);

  for (const char* side : {"sbs", "l", "r"}) fs::create_directories(dir / side);
  for (int f = 0; f < seq->frame_count(); ++f) {
    const cv::Mat l = seq->load_left_gray(f), r = seq->load_right_gray(f);
    char name[16];
    std::snprintf(name, sizeof name, "%06d.png", f);
    cv::Mat sbs;
    cv::hconcat(l, r, sbs);
    ASSERT_TRUE(cv::imwrite((dir / "sbs" / name).string(), sbs));
    ASSERT_TRUE(cv::imwrite((dir / "l" / name).string(), l));
    ASSERT_TRUE(cv::imwrite((dir / "r" / name).string(), r));
  }
  const std::string common = " " + (dir / "seq").string() + " " + forest_file.string() + " -q --grid 20 --votes 6 -o ";
  test::Outcome r = test::run(test::tool("eval-forest") + " -q " + forest_file.string() + " " + work.string() +
                              " --grid 20 --votes 6 -o " + (dir / "eval").string());
  ASSERT_EQ(r.status, 0) << r.out;
  r = test::run(test::tool("label-stream") + common + (dir / "folder").string() + " --overlay-video overlay.avi");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("frames per second"), std::string::npos) << r.out;
  r = test::run(test::tool("label-stream") + common + (dir / "side").string() + " --side-by-side " +
                (dir / "sbs" / "%06d.png").string());
  ASSERT_EQ(r.status, 0) << r.out;
  r = test::run(test::tool("label-stream") + common + (dir / "cams").string() + " --cameras " +
                (dir / "l" / "%06d.png").string() + "," + (dir / "r" / "%06d.png").string());
  ASSERT_EQ(r.status, 0) << r.out;

  int compared = 0;
  for (int f = 0; f < seq->frame_count(); ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "%06d_labels.png", f);
    const std::string folder = read_file(dir / "folder" / "labels" / name);
    EXPECT_EQ(read_file(dir / "side" / "labels" / name), folder) << name;
    EXPECT_EQ(read_file(dir / "cams" / "labels" / name), folder) << name;
    if (seq->is_labelled(f)) {
      EXPECT_EQ(read_file(dir / "eval" / "frames" / name), folder) << name;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 12);
  const Json summary = read_json(dir / "folder" / "summary.json");
  EXPECT_EQ(summary["frames"], seq->frame_count());
  EXPECT_GT(summary["frames_per_second"].get<double>(), 0);
  EXPECT_GT(summary["latency_ms_median"].get<double>(), 0);
  for (const char* stage : {"read", "disparity", "keypoints", "tracking", "motion", "features", "classify", "write"})
    EXPECT_TRUE(summary["stage_ms"].contains(stage)) << stage;
  cv::VideoCapture video((dir / "folder" / "overlay.avi").string());
  ASSERT_TRUE(video.isOpened());
  EXPECT_EQ(static_cast<int>(video.get(cv::CAP_PROP_FRAME_COUNT)), seq->frame_count());
}

TEST_F(LabelStream, RefusesForestsItCannotFeed) {
  forest::Forest forest;
  forest.width = seq->size.width + 1;
  forest.height = seq->size.height;
  forest.features = {"fH"};
  forest.classes = {"a", "b"};
  eval::StreamOptions so;
  so.front_end.progress = false;
  const std::string size_error = test::error_of([&] {
    eval::StreamLabeller(forest, "f.json", seq->calibration, seq->camera_height, seq->size, so, "seq");
  });
  EXPECT_NE(size_error.find("f.json was trained on"), std::string::npos) << size_error;
  forest.width = seq->size.width;
  forest.features = {"fH", "depth"};
  const std::string feature_error = test::error_of([&] {
    eval::StreamLabeller(forest, "f.json", seq->calibration, seq->camera_height, seq->size, so, "seq");
  });
  EXPECT_NE(feature_error.find("'depth'"), std::string::npos) << feature_error;
  forest.features = {"fH"};
  so.front_end.filters.require_label = true;
  const std::string label_error = test::error_of([&] {
    eval::StreamLabeller(forest, "f.json", seq->calibration, seq->camera_height, seq->size, so, "seq");
  });
  EXPECT_NE(label_error.find("require_label"), std::string::npos) << label_error;
}

}  // namespace

// Black (featureless) frames: nothing to track, every frame labelled from the class prior alone. That
// is said (a warning, and summary.json's frames_without_points), not passed over with exit 0 alone.
TEST_F(LabelStream, FramesWithoutATrackedPointAreSaid) {
  const StreamCase c{"black", frontend::FrameTracker::Klt, frontend::KeypointMethod::Gftt};
  const fs::path forest_file = dir / "forest-black.json";
  forest::save_forest(causal_forest(c, dir / "work-black"), forest_file);
  fs::create_directories(dir / "black");
  const cv::Mat black = cv::Mat::zeros(seq->size, CV_8UC1);
  for (int f = 0; f < 5; ++f) {
    char name[16];
    std::snprintf(name, sizeof name, "%06d.png", f);
    ASSERT_TRUE(cv::imwrite((dir / "black" / name).string(), black));
  }
  const std::string frames = (dir / "black" / "%06d.png").string();
  const test::Outcome r = test::run(test::tool("label-stream") + " " + (dir / "seq").string() + " " +
                                    forest_file.string() + " -q --cameras " + frames + "," + frames + " -o " +
                                    (dir / "black-out").string());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("label-stream: warning: 5 of 5 frames had no tracked point"), std::string::npos) << r.out;
  EXPECT_EQ(read_json(dir / "black-out" / "summary.json")["frames_without_points"].get<int>(), 5);
}

// On real video: KITTI seq2's first frames (its right image is offset: the stream self-calibrates on its
// first 11 frames as extract-features does) labelled per pixel by a stand-in forest of their size
// (KITTI has no labels: trained on a synthetic corridor rendered at 1241x376) equal the files' labels,
// with dense block matching and with the sparse matcher.
TEST(LabelStreamKitti, SameLabelsAsCausalExtractionOnRealFrames) {
  const fs::path kitti = fs::path(SMSEG_SHARED_DIR) / "data" / "kitti-stereo" / "seq2";
  if (!fs::exists(kitti / "calib.txt")) GTEST_SKIP() << "no shared KITTI slice at " << kitti;
  const fs::path dir = test::temp_dir("label_stream_kitti");
  const sequence::Sequence seq = sequence::import_kitti(kitti, dir / "seq", sequence::KittiImportOptions{});
  synth::SynthOptions so;
  so.frames = 4;
  so.label_every = 1;
  so.width = seq.size.width;
  so.height = seq.size.height;
  stacks::ExtractOptions eo;
  eo.features.causal = true;
  eo.progress = false;
  stacks::extract_features(synth::make_sequence(so, dir / "corridor"), dir / "corridor-work", eo);
  forest::TrainParams tp;
  tp.K = 50;
  tp.Kt = 500;
  tp.M = 2;
  const forest::Forest forest = forest::train_forest(stacks::open_stacks({dir / "corridor-work"}, {}, true, true, {}).dataset, tp);

  const int frames = frontend::kOffsetFrames + 4;
  eo.frames = stacks::FrameRange::parse("0:" + std::to_string(frames), "frames");
  const forest::Classifier classifier(forest);
  for (const auto stereo : {frontend::StereoMethod::BM, frontend::StereoMethod::Sparse}) {
    const std::string method = frontend::stereo_method_name(stereo);
    eo.front_end.stereo.method = stereo;
    stacks::extract_features(seq, dir / ("work-" + method), eo);
    const auto files = stacks::open_stacks({dir / ("work-" + method)}, eo.frames, false, false, forest.features);
    ASSERT_EQ(static_cast<int>(files.dataset.frames.size()), frames);
    eval::StreamOptions opt;
    opt.front_end.progress = false;
    opt.front_end.stereo.method = stereo;
    eval::StreamLabeller stream(forest, "forest.json", seq.calibration, seq.camera_height, seq.size, opt, "seq2");
    int points = 0;
    const std::vector<cv::Mat> streamed = stream_labels(stream, seq, frames, points);
    EXPECT_GT(stream.disparity_offset(), 0.5) << method << ": seq2's offset, self-calibrated";
    EXPECT_GT(points, 100 * (frames - frontend::kOffsetFrames)) << method;
    for (int f = 0; f < frames; ++f)
      ASSERT_EQ(cv::countNonZero(eval::label_frame(classifier, files.dataset.frames[f], opt.eval, f) != streamed[f]), 0)
          << method << ", frame " << f;
  }
  fs::remove_all(dir);
}
