// label-stream's surroundings of the streamed labeller: a sequence folder's frames as a stream, the
// per-frame outputs, the stage log's figures, summary.json and the printed report.
#include <gtest/gtest.h>

#include "smseg/eval/stream_output.hpp"
#include "smseg/synth/synth.hpp"
#include "temp_dir.hpp"

namespace {

using namespace smseg;
namespace fs = std::filesystem;

class StreamOutput : public ::testing::Test {
 protected:
  static fs::path dir;
  static std::optional<sequence::Sequence> seq;
  static void SetUpTestSuite() {
    dir = test::temp_dir("stream_output");
    synth::SynthOptions so;
    so.frames = 4;
    so.width = 64;
    so.height = 48;
    so.label_every = 2;
    seq = synth::make_sequence(so, dir / "seq");
  }
  static void TearDownTestSuite() { fs::remove_all(dir); }
};
fs::path StreamOutput::dir;
std::optional<sequence::Sequence> StreamOutput::seq;

TEST_F(StreamOutput, SequenceFramesGiveTheRangeInOrder) {
  eval::SequenceFrames frames(*seq, stacks::FrameRange{1, 10});
  eval::StreamInput in;
  std::vector<int> seen;
  while (frames.next(in, true)) {
    seen.push_back(in.index);
    EXPECT_EQ(in.left.type(), CV_8UC1);
    EXPECT_EQ(in.left_bgr.type(), CV_8UC3);
  }
  EXPECT_EQ(seen, (std::vector<int>{1, 2, 3}));
  EXPECT_THROW(eval::SequenceFrames(*seq, stacks::FrameRange{4, 6}), Error);
}

TEST_F(StreamOutput, WriterWritesLabelsAndOverlays) {
  const fs::path out = dir / "out";
  eval::StreamOutputOptions options;
  options.overlays = true;
  eval::StreamWriter writer(out, out, *seq, options);
  EXPECT_TRUE(writer.needs_colour());
  eval::SequenceFrames frames(*seq, stacks::FrameRange{0, 1});
  eval::StreamInput in;
  ASSERT_TRUE(frames.next(in, writer.needs_colour()));
  EXPECT_TRUE(writer.write(in, cv::Mat(seq->size, CV_8UC1, cv::Scalar(0))));
  EXPECT_TRUE(fs::is_regular_file(out / "labels" / "000000_labels.png"));
  EXPECT_TRUE(fs::is_regular_file(out / "overlays" / "000000_overlay.png"));
}

TEST(StageLog, QuantilesMeansAndSummary) {
  eval::StageLog log;
  for (int k = 1; k <= 10; ++k) {
    eval::StreamStageTimes t;
    t.read = k;
    log.add(t, 0.5, 10.0 * k);
  }
  EXPECT_EQ(log.latency_quantile(0.5), 60);
  EXPECT_EQ(log.latency_quantile(0.9), 100);
  EXPECT_EQ(log.latency_quantile(1.0), 100);
  EXPECT_DOUBLE_EQ(eval::StageLog::mean(log.ms[0]), 5.5);
  EXPECT_EQ(eval::StageLog::median(log.ms[0]), 6);

  eval::StreamRun run{"cameras 0,1", "f.forest", cv::Size(64, 48)};
  run.first_frame = 0;
  run.last_frame = 9;
  run.seconds = 2;
  const Json summary = eval::stream_summary(run, eval::StreamOptions{}, log);
  EXPECT_EQ(summary["format"], "smseg-label-stream");
  EXPECT_EQ(summary["frames"], 10);
  EXPECT_DOUBLE_EQ(summary["frames_per_second"].get<double>(), 5.0);
  EXPECT_DOUBLE_EQ(summary["stage_ms"]["write"]["mean"].get<double>(), 0.5);

  const auto lines = eval::stream_report_lines(run, log, "OUT", false);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0], "10 frames in 2.00 s: 5.0 frames per second, latency median 60.0 ms (p90 100.0 ms)");
  EXPECT_EQ(lines[2], "labels: OUT/labels/, summary: OUT/summary.json");
  EXPECT_EQ(eval::stream_report_lines(run, log, "OUT", true).size(), 1u);
}

}  // namespace
