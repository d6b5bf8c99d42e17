// label-stream on a monocular video: the causal visual odometry (sfm/mono_stream.hpp) labelled frame by
// frame gives exactly the labels of `extract-features --motion vo --causal` + `eval-forest`, per pixel
// and by grid voting, from the library and from the tool; and its camera path follows the synthetic
// ground truth. The sequence is the synthetic corridor's left camera alone.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "smseg/eval/stream.hpp"
#include "smseg/forest/train.hpp"
#include "smseg/sfm/mono_stream.hpp"
#include "smseg/sfm/sfm_summary.hpp"
#include "smseg/stacks/extract.hpp"
#include "smseg/synth/synth.hpp"
#include "run_tool.hpp"
#include "smseg/common/io.hpp"
#include "temp_dir.hpp"

namespace {

using namespace smseg;
namespace fs = std::filesystem;

class LabelStreamMono : public ::testing::Test {
 protected:
  static fs::path dir;
  static std::optional<sequence::Sequence> seq;  // mono: the left images of a stereo rendering
  static void SetUpTestSuite() {
    dir = test::temp_dir("label_stream_mono");
    synth::SynthOptions so;
    so.frames = 40;
    so.label_every = 2;
    seq = synth::make_sequence(so, dir / "stereo");
    seq->kind = sequence::SequenceKind::Mono;
    write_mono_manifest(dir / "stereo" / "sequence.json", dir / "mono");
  }
  static void TearDownTestSuite() { fs::remove_all(dir); }

  // The stereo manifest as a mono one (kind, no right images; frame paths made absolute) in `folder`.
  static void write_mono_manifest(const fs::path& stereo_manifest, const fs::path& folder) {
    Json j = read_json(stereo_manifest);
    j["kind"] = "mono";
    j["calibration"].erase("baseline");
    for (Json& f : j["frames"]) {
      f.erase("right");
      for (const char* key : {"left", "label", "gt_depth"})
        if (f.contains(key)) f[key] = (stereo_manifest.parent_path() / f[key].get<std::string>()).string();
    }
    fs::create_directories(folder);
    write_json_atomic(folder / "sequence.json", j);
  }

  static stacks::ExtractOptions vo_options() {
    stacks::ExtractOptions eo;
    eo.motion = "vo";
    eo.features.causal = true;
    eo.progress = false;
    eo.resolve();
    return eo;
  }

  // extract-features --motion vo --causal into `work`, and a small forest trained on it.
  static forest::Forest causal_forest(const fs::path& work) {
    stacks::extract_features(*seq, work, vo_options());
    forest::TrainParams tp;
    tp.K = 100;
    tp.Kt = 1500;
    tp.M = 3;
    return forest::train_forest(stacks::open_stacks({work}, {}, true, true, {}).dataset, tp);
  }
};
fs::path LabelStreamMono::dir;
std::optional<sequence::Sequence> LabelStreamMono::seq;

TEST_F(LabelStreamMono, SameLabelsAsCausalExtractionAndEvaluation) {
  const fs::path work = dir / "work";
  const forest::Forest forest = causal_forest(work);
  const auto all = stacks::open_stacks({work}, stacks::FrameRange{}, false, false, forest.features);
  ASSERT_EQ(static_cast<int>(all.stacks.size()), seq->frame_count());
  const forest::Classifier classifier(forest);
  for (const int grid : {0, 20}) {
    eval::StreamOptions so;
    so.eval.grid = grid;
    so.eval.votes = 6;
    so.mono = stacks::visual_odometry_options(vo_options());
    so.mono->progress = false;
    eval::StreamLabeller stream(forest, "forest.json", seq->calibration, seq->camera_height, seq->size, so, "seq");
    int points = 0;
    for (int f = 0; f < seq->frame_count(); ++f) {
      const cv::Mat batch = eval::label_frame(classifier, all.dataset.frames[f], so.eval, f);
      const cv::Mat streamed = stream.push(seq->load_left_gray(f), cv::Mat(), f);
      ASSERT_EQ(cv::countNonZero(batch != streamed), 0) << "grid " << grid << ", frame " << f;
      points += static_cast<int>(stream.last_frame().observations.size());
    }
    EXPECT_GT(points, 20 * seq->frame_count()) << "the stream must have tracked points to compare";
  }
}

// The camera path against the rendering's ground truth (both: world Y up, origin on the ground under the
// first camera, heading +Z): from the first frame posed by the initial pair on, the path's displacement
// since that frame stays within 10 % of the distance travelled, its scale from the camera height alone.
TEST_F(LabelStreamMono, VisualOdometryFollowsTheGroundTruthPath) {
  ASSERT_EQ(static_cast<int>(seq->gt_poses.size()), seq->frame_count());
  sfm::SfmOptions o = stacks::visual_odometry_options(vo_options());
  o.progress = false;
  const frontend::FrontEndResult vo = sfm::run_mono_stream_front_end(*seq, o);
  const sfm::SfmSummary* summary = sfm::sfm_summary_of(vo.summary);
  ASSERT_TRUE(summary);
  int first = 1;
  while (first < seq->frame_count() && !vo.pair_motions[first - 1].ok) ++first;
  ASSERT_LT(first, seq->frame_count() / 2) << "initialised too late";
  EXPECT_EQ(summary->posed_frames, seq->frame_count() - first) << "every frame after it posed by PnP";
  auto at = [](const sequence::Pose& p) { return Eigen::Vector3d(p.t[0], p.t[1], p.t[2]); };
  double travelled = 0, worst = 0;
  for (int f = first + 1; f < seq->frame_count(); ++f) {
    travelled += (at(seq->gt_poses[f]) - at(seq->gt_poses[f - 1])).norm();
    const Eigen::Vector3d moved = at(vo.poses[f]) - at(vo.poses[first]);
    const Eigen::Vector3d truth = at(seq->gt_poses[f]) - at(seq->gt_poses[first]);
    worst = std::max(worst, (moved - truth).norm());
  }
  EXPECT_GT(travelled, 0.5);
  EXPECT_LT(worst, 0.1 * travelled) << "travelled " << travelled << " m since frame " << first;
}

// The tool on a mono sequence folder writes the labels eval-forest writes for the causal vo work folder.
TEST_F(LabelStreamMono, ToolLabelsAMonoFolderAsEvalForest) {
  const fs::path work = dir / "work-tool", forest_file = dir / "forest-tool.json";
  forest::save_forest(causal_forest(work), forest_file);
  test::Outcome r = test::run(test::tool("eval-forest") + " -q " + forest_file.string() + " " + work.string() +
                              " --grid 20 --votes 6 -o " + (dir / "eval").string());
  ASSERT_EQ(r.status, 0) << r.out;
  r = test::run(test::tool("label-stream") + " " + (dir / "mono").string() + " " + forest_file.string() +
                " -q --grid 20 --votes 6 -o " + (dir / "stream").string());
  ASSERT_EQ(r.status, 0) << r.out;
  int compared = 0;
  for (int f = 0; f < seq->frame_count(); ++f) {
    if (!seq->is_labelled(f)) continue;
    char name[32];
    std::snprintf(name, sizeof name, "%06d_labels.png", f);
    EXPECT_EQ(read_file(dir / "eval" / "frames" / name), read_file(dir / "stream" / "labels" / name)) << name;
    ++compared;
  }
  EXPECT_EQ(compared, 20);
  const Json summary = read_json(dir / "stream" / "summary.json");
  EXPECT_EQ(summary["frames"], seq->frame_count());
  EXPECT_EQ(summary["front_end"]["method"], "vo");
  // A live source is a stereo pair: refused on a mono sequence, in one line.
  r = test::run(test::tool("label-stream") + " " + (dir / "mono").string() + " " + forest_file.string() +
                " -o " + (dir / "live").string() + " --cameras 0,1");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("mono"), std::string::npos) << r.out;
}

}  // namespace
