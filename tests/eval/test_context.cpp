// Auto-context (context.hpp): the context channels are the forest's posteriors, and a training frame's
// channels never come from a forest that read its labels (the leak test: change a frame's labels and
// the channels of its fold stay the same bytes, while the given forest's would move).
#include <gtest/gtest.h>

#include <cstring>

#include "eval_fixture.hpp"
#include "error_text.hpp"
#include "run_tool.hpp"
#include "smseg/common/digest.hpp"
#include "smseg/common/io.hpp"
#include "smseg/eval/context.hpp"
#include "smseg/stacks/mirror.hpp"
#include "temp_dir.hpp"

namespace {

using namespace smseg;
namespace fs = std::filesystem;

TEST(Context, FoldsAreContiguousAndEven) {
  EXPECT_EQ(eval::contiguous_folds(7, 3), (std::vector<int>{0, 0, 0, 1, 1, 2, 2}));
  EXPECT_EQ(eval::contiguous_folds(4, 4), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_THROW(eval::contiguous_folds(3, 4), Error);  // more folds than frames
  EXPECT_THROW(eval::contiguous_folds(5, 1), Error);  // one fold holds out everything
}

// add-context's posterior channels mirror as they are, like any channel that does not depend on left
// and right (stacks/mirror.cpp knows them by the prefix eval names them with).
TEST(MirrorPlan, ContextChannelsFlip) {
  const auto names = eval::context_feature_names({"Road", "Car", "Pole"});
  const auto plan = stacks::mirror_plan(names, "test");
  ASSERT_EQ(plan.size(), names.size());
  for (std::size_t k = 0; k < plan.size(); ++k) {
    EXPECT_EQ(plan[k].source, k);
    EXPECT_TRUE(plan[k].flip);
    EXPECT_FALSE(plan[k].negate);
  }
}

TEST(Context, ChannelNames) {
  EXPECT_EQ(eval::context_feature_names({"Sky", "Road"}), (std::vector<std::string>{"fCtx:Sky", "fCtx:Road"}));
  EXPECT_TRUE(eval::is_context_feature("fCtx:Sky"));
  EXPECT_FALSE(eval::is_context_feature("fH"));
}

/// Every byte of one frame's values file (its context channels) in an output work folder.
std::string sat_bytes(const fs::path& work, int frame) { return read_file(stacks::values_path(work, frame)); }

/// Rewrites frame `f` of `work` with every label swapped (floor <-> wall), the rest unchanged. The
/// fixture's values (0, 1, 1.5) make every table difference exact, so the rasters come back whole.
void swap_labels(const fs::path& work, int f) {
  const stacks::StackManifest m = stacks::load_stack_manifest(work);
  const int W = m.size.width, H = m.size.height;
  std::vector<cv::Mat> rasters;
  cv::Mat gray, labels;
  {
    const auto s = stacks::FrameStack::open(m, f, true);
    for (std::size_t k = 0; k < m.features.size(); ++k) {
      const cv::Mat sat(H + 1, W + 1, CV_64FC1, const_cast<double*>(s.sat(static_cast<int>(k))));
      cv::Mat r = sat(cv::Rect(1, 1, W, H)) - sat(cv::Rect(0, 1, W, H)) - sat(cv::Rect(1, 0, W, H)) + sat(cv::Rect(0, 0, W, H));
      ASSERT_EQ(cv::norm(stacks::summed_area_table(r), sat, cv::NORM_INF), 0.0);
      rasters.push_back(r);
    }
    gray = cv::Mat(m.size, CV_8UC1, const_cast<std::uint8_t*>(s.gray())).clone();
    labels = cv::Mat(m.size, CV_8UC1, const_cast<std::uint8_t*>(s.labels())).clone();
  }
  for (auto it = labels.begin<std::uint8_t>(); it != labels.end<std::uint8_t>(); ++it)
    if (*it != forest::kVoidLabel) *it = static_cast<std::uint8_t>(1 - *it);
  stacks::write_frame_values(work, f, m.size, rasters, gray, labels);
}

class AddContext : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = test::temp_dir("context");
    work = eval_test::make_work("context", 6);
    forest = eval_test::train(work, 6, 3);
    forest_file = dir / "forest.json";
    forest::save_forest(forest, forest_file);
  }
  void TearDown() override {
    fs::remove_all(dir);
    fs::remove_all(work);
  }
  eval::ContextReport run(const forest::Forest& f, const fs::path& out, int folds) {
    eval::ContextOptions o;
    o.folds = folds;
    return eval::add_context(f, forest_file, {work}, {out}, o);
  }
  fs::path dir, work, forest_file;
  forest::Forest forest;
};

TEST_F(AddContext, ChannelsAreTheForestsPosteriors) {
  const auto r = run(forest, dir / "test", 0);
  EXPECT_EQ(r.frames_written, 6);
  EXPECT_EQ(r.out_of_fold_frames, 0);
  const stacks::StackManifest m = stacks::load_stack_manifest(dir / "test");
  EXPECT_EQ(m.features, (std::vector<std::string>{"fH", "fD", "fCtx:floor", "fCtx:wall"}));
  EXPECT_EQ(m.labelled_frames, (std::vector<int>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(m.options["context"]["folds"], 0);
  const auto in = stacks::open_stacks({work}, {}, true, true, {});
  const auto out = stacks::open_stacks({dir / "test"}, {}, true, true, {});
  const forest::Classifier classifier(forest);
  const int W = m.size.width, H = m.size.height;
  for (std::size_t i = 0; i < in.dataset.frames.size(); ++i) {
    const auto& a = in.dataset.frames[i];
    const auto& b = out.dataset.frames[i];
    // The features kept are the same tables, the labels the same labels.
    for (int k = 0; k < 2; ++k)
      EXPECT_EQ(0, std::memcmp(a.sats[k], b.sats[k], sizeof(double) * (W + 1) * (H + 1)));
    EXPECT_EQ(0, std::memcmp(a.labels, b.labels, static_cast<std::size_t>(W) * H));
    // Each channel's table holds the posterior: a one-pixel window reads it back.
    const std::size_t stride = W + 1;
    for (const auto& [x, y] : {std::pair{0, 0}, std::pair{5, 40}, std::pair{W - 1, H - 1}, std::pair{30, 20}}) {
      std::vector<float> post(2);
      classifier.posterior(a, x, y, post.data());
      for (int c = 0; c < 2; ++c) {
        const double* s = b.sats[2 + c];
        const double v = s[(y + 1) * stride + x + 1] - s[y * stride + x + 1] - s[(y + 1) * stride + x] + s[y * stride + x];
        EXPECT_NEAR(v, post[c] / 3.0, 1e-9) << "frame " << i << " pixel " << x << "," << y << " class " << c;
      }
    }
    // The posteriors of a pixel sum to one: the channels' tables sum to the image's area.
    const std::size_t total = static_cast<std::size_t>(H) * stride + W;
    EXPECT_NEAR(b.sats[2][total] + b.sats[3][total], double(W) * H, 1e-6 * W * H);  // float sums over trees
  }
}

TEST_F(AddContext, OutOfFoldChannelsNeverReadTheirOwnLabels) {
  // Folds of two frames: {0, 1}, {2, 3}, {4, 5}.
  const auto r = run(forest, dir / "before", 3);
  EXPECT_EQ(r.frames_per_fold, (std::vector<int>{2, 2, 2}));
  EXPECT_EQ(r.out_of_fold_frames, 6);
  run(forest, dir / "again", 3);
  for (int f = 0; f < 6; ++f) EXPECT_EQ(sat_bytes(dir / "before", f), sat_bytes(dir / "again", f)) << f;

  // Frame 0's labels change: the channels of its fold (frames 0 and 1) come from a forest that never read
  // them, so they keep every byte; the other folds' forests trained on frame 0, so theirs move.
  swap_labels(work, 0);
  run(forest, dir / "after", 3);
  for (int f : {0, 1}) EXPECT_EQ(sat_bytes(dir / "before", f), sat_bytes(dir / "after", f)) << f;
  for (int f : {2, 3, 4, 5}) EXPECT_NE(sat_bytes(dir / "before", f), sat_bytes(dir / "after", f)) << f;

  // What the test guards against: the given forest, retrained on the changed labels, moves frame 0's
  // channels (a leaky add-context that labelled training frames with it would fail the check above).
  const forest::Forest retrained = eval_test::train(work, 6, 3);
  run(forest, dir / "leaky-before", 0);
  run(retrained, dir / "leaky-after", 0);
  EXPECT_NE(sat_bytes(dir / "leaky-before", 0), sat_bytes(dir / "leaky-after", 0));
}

TEST_F(AddContext, WritesOnlyItsChannelsBesideItsBase) {
  run(forest, dir / "test", 0);
  const Json j = read_json(dir / "test" / "stacks.json");
  EXPECT_EQ(j["base"]["work"], fs::absolute(work).lexically_normal().string());
  EXPECT_EQ(j["base"]["features"], Json({"fH", "fD"}));
  EXPECT_EQ(j["base"]["stacks_json_fnv1a64"], fnv1a64_hex(read_file(work / "stacks.json")));
  for (const auto& e : fs::directory_iterator(dir / "test" / "stacks"))
    EXPECT_EQ(e.path().extension(), ".bin") << e.path();  // one values file a frame, nothing else
  const auto one_line = [](const std::string& e) { return e.find('\n') == std::string::npos; };
  // The base written again (here: another option recorded) is refused, so is the base moved away.
  const std::string manifest = read_file(work / "stacks.json");
  Json changed = read_json(work / "stacks.json");
  changed["options"]["changed"] = true;
  write_json_atomic(work / "stacks.json", changed);
  const std::string e1 = test::error_of([&] { stacks::load_stack_manifest(dir / "test"); });
  EXPECT_NE(e1.find("whose stacks.json has changed since this folder was written; run add-context again"), std::string::npos) << e1;
  EXPECT_TRUE(one_line(e1)) << e1;
  write_file_atomic(work / "stacks.json", manifest);
  EXPECT_NO_THROW(stacks::open_stacks({dir / "test"}, {}, true, true, {}));
  const fs::path moved = work.string() + "_moved";
  fs::rename(work, moved);
  const std::string e2 = test::error_of([&] { stacks::load_stack_manifest(dir / "test"); });
  fs::rename(moved, work);
  EXPECT_NE(e2.find((dir / "test" / "stacks.json").string()), std::string::npos) << e2;
  EXPECT_NE(e2.find("no longer a work folder (moved or deleted?)"), std::string::npos) << e2;
  EXPECT_TRUE(one_line(e2)) << e2;
}

// Old work folders (version 1: the tables themselves on disk) and new ones (version 2: the rasters,
// tables built on reading) of the same frames give the same forest, the same labels and posteriors,
// and the same context channels, bit for bit.
TEST_F(AddContext, OldAndNewWorkFoldersTrainAndLabelTheSame) {
  const fs::path old_work = eval_test::make_work("context_v1", 6, {"floor", "wall"}, cv::Size(64, 48), 1);
  EXPECT_EQ(stacks::load_stack_manifest(old_work).version, 1);
  EXPECT_EQ(stacks::load_stack_manifest(work).version, 2);
  // Every byte of the forest files but the timings.
  const auto untimed = [](const forest::Forest& f) {
    Json j = forest::forest_to_json(f);
    j["stats"].erase("seconds");
    for (Json& t : j["stats"]["trees"]) t.erase("seconds");
    return j.dump();
  };
  EXPECT_EQ(untimed(eval_test::train(old_work, 6, 3)), untimed(forest));
  const auto a = stacks::open_stacks({old_work}, {}, false, false, {});
  const auto b = stacks::open_stacks({work}, {}, false, false, {});
  const forest::Classifier classifier(forest);
  const std::size_t pixels = 64 * 48;
  for (std::size_t i = 0; i < a.dataset.frames.size(); ++i) {
    std::vector<std::uint8_t> la(pixels), lb(pixels);
    std::vector<float> da(pixels * 2), db(pixels * 2);
    classifier.classify_frame(a.dataset.frames[i], la, da);
    classifier.classify_frame(b.dataset.frames[i], lb, db);
    EXPECT_EQ(la, lb) << i;
    EXPECT_EQ(0, std::memcmp(da.data(), db.data(), da.size() * sizeof(float))) << i;
  }
  eval::add_context(forest, forest_file, {old_work}, {dir / "from_old"}, eval::ContextOptions{{}, {}, 3});
  run(forest, dir / "from_new", 3);
  for (int f = 0; f < 6; ++f) EXPECT_EQ(sat_bytes(dir / "from_old", f), sat_bytes(dir / "from_new", f)) << f;
  fs::remove_all(old_work);
}

TEST_F(AddContext, RefusesWhatDoesNotFit) {
  EXPECT_NE(test::error_of([&] { run(forest, dir / "o", 7); }).find("--folds"), std::string::npos);  // 7 folds of 6 labelled frames
  eval::ContextOptions o;
  o.keep = {"fH", "fCtx:wall"};
  EXPECT_NE(test::error_of([&] { eval::add_context(forest, forest_file, {work}, {dir / "o"}, o); }).find("context channel"), std::string::npos);
  o.keep = {"fNope"};
  EXPECT_NE(test::error_of([&] { eval::add_context(forest, forest_file, {work}, {dir / "o"}, o); }).find("fNope"), std::string::npos);
  const fs::path other = eval_test::make_work("context_other", 2, {"floor", "wall", "sky"});
  EXPECT_NE(test::error_of([&] { eval::add_context(forest, forest_file, {other}, {dir / "o"}, {}); }).find("classes"), std::string::npos);
  fs::remove_all(other);
}

TEST_F(AddContext, ToolWritesFoldersASecondForestTrainsOn) {
  const fs::path out = dir / "ctx";
  const auto bad = test::run(test::tool("add-context") + " " + forest_file.string() + " " + work.string() +
                             " --folds 1 -o " + out.string());
  EXPECT_EQ(bad.status, 2) << bad.out;
  EXPECT_NE(bad.out.find("--folds"), std::string::npos) << bad.out;
  EXPECT_FALSE(fs::exists(out));
  const auto ok = test::run(test::tool("add-context") + " " + forest_file.string() + " " + work.string() +
                            " --folds 2 -q -o " + out.string());
  ASSERT_EQ(ok.status, 0) << ok.out;
  const Json report = read_json(out / "context.json");
  EXPECT_EQ(report["frames_per_fold"], Json({3, 3}));
  const fs::path ctx = out / work.filename();
  const auto set = stacks::open_stacks({ctx}, {}, true, true, {});
  forest::TrainParams p;
  p.K = 200;
  p.M = 2;
  const forest::Forest second = forest::train_forest(set.dataset, p);
  EXPECT_EQ(second.features, (std::vector<std::string>{"fH", "fD", "fCtx:floor", "fCtx:wall"}));
}

}  // namespace
