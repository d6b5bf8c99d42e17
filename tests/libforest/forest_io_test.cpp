// The forest file: round trip, and refusal of anything that is not a valid smseg-forest v1.
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <functional>

#include "forest_test_util.hpp"
#include "smseg/common/error.hpp"
#include "smseg/common/io.hpp"

using namespace forest_test;

namespace {

struct Fixture {
  SyntheticData s;
  Forest forest;
  fs::path dir;
  Fixture() {
    SyntheticOptions o;
    o.width = 64;
    o.height = 48;
    o.frames = 3;
    o.features = 3;
    o.signal = 0.4;
    s = make_synthetic(o);
    TrainParams p;
    p.K = 120;
    p.M = 3;
    p.textons = true;
    p.windows.mode = WindowSampling::Thesis;
    forest = train_forest(s.data, p);
    dir = temp_dir("io");
  }
  ~Fixture() { fs::remove_all(dir); }
  // Writes the forest's JSON after `edit`, then loads it.
  Forest load_edited(const std::function<void(smseg::Json&)>& edit) const {
    smseg::Json j = forest_to_json(forest);
    edit(j);
    smseg::write_json_atomic(dir / "edited.json", j);
    return load_forest(dir / "edited.json");
  }
  std::string error_of(const std::function<void(smseg::Json&)>& edit) const {
    try {
      load_edited(edit);
    } catch (const smseg::Error& e) {
      EXPECT_EQ(e.file(), (dir / "edited.json").string());
      return e.field() + ": " + e.reason();
    }
    return "(accepted)";
  }
};

}  // namespace

TEST(ForestFile, RoundTripKeepsEverythingAndPredictionsBitForBit) {
  const Fixture fx;
  save_forest(fx.forest, fx.dir / "forest.json");
  const Forest back = load_forest(fx.dir / "forest.json");
  EXPECT_EQ(forest_to_json(back).dump(), forest_to_json(fx.forest).dump());
  for (std::size_t t = 0; t < back.trees.size(); ++t)
    for (std::size_t i = 0; i < back.trees[t].nodes.size(); ++i)
      ASSERT_EQ(back.trees[t].nodes[i].threshold, fx.forest.trees[t].nodes[i].threshold);  // exact doubles
  const Classifier a(fx.forest), b(back);
  const std::size_t n = 64 * 48, C = fx.forest.classes.size();
  for (const FrameData& frame : fx.s.data.frames) {
    std::vector<std::uint8_t> la(n), lb(n);
    std::vector<float> da(n * C), db(n * C);
    a.classify_frame(frame, la, da);
    b.classify_frame(frame, lb, db);
    EXPECT_EQ(la, lb);
    EXPECT_EQ(0, std::memcmp(da.data(), db.data(), da.size() * sizeof(float)));
  }
  EXPECT_EQ(back.params.K, 120);
  EXPECT_EQ(back.params.windows.mode, WindowSampling::Thesis);
  EXPECT_TRUE(back.textons);
  EXPECT_EQ(back.stats.seconds, fx.forest.stats.seconds);
}

TEST(ForestFile, CorruptedForeignAndWrongVersionFilesAreRefused) {
  const Fixture fx;
  save_forest(fx.forest, fx.dir / "forest.json");
  const std::string text = smseg::read_file(fx.dir / "forest.json");
  smseg::write_file_atomic(fx.dir / "truncated.json", text.substr(0, text.size() / 2));
  EXPECT_THROW(load_forest(fx.dir / "truncated.json"), smseg::Error);
  EXPECT_THROW(load_forest(fx.dir / "missing.json"), smseg::Error);
  smseg::write_file_atomic(fx.dir / "array.json", "[1, 2, 3]\n");
  EXPECT_THROW(load_forest(fx.dir / "array.json"), smseg::Error);

  EXPECT_NE(fx.error_of([](smseg::Json& j) { j["format"] = "smseg-sequence"; }).find("format"), std::string::npos);
  EXPECT_NE(fx.error_of([](smseg::Json& j) { j.erase("format"); }).find("format"), std::string::npos);
  EXPECT_NE(fx.error_of([](smseg::Json& j) { j["version"] = 2; }).find("version"), std::string::npos);
}

TEST(ForestFile, InconsistentContentIsRefusedNamingTheField) {
  const Fixture fx;
  EXPECT_EQ(fx.error_of([](smseg::Json&) {}), "(accepted)");
  auto first_split = [](smseg::Json& j) -> smseg::Json& {
    for (auto& n : j["trees"][0]["nodes"])
      if (n.contains("f")) return n;
    throw std::runtime_error("no split");
  };
  auto first_leaf = [](smseg::Json& j) -> smseg::Json& {
    for (auto& n : j["trees"][0]["nodes"])
      if (n.contains("counts")) return n;
    throw std::runtime_error("no leaf");
  };
  struct Case {
    const char* what;
    std::function<void(smseg::Json&)> edit;
    const char* field;
  };
  const std::vector<Case> cases = {
      {"child out of range", [&](smseg::Json& j) { first_split(j)["left"] = 100000; }, "trees[0].nodes[0].left"},
      {"child pointing back", [&](smseg::Json& j) { first_split(j)["right"] = 0; }, "trees[0].nodes[0].right"},
      {"attribute out of range", [&](smseg::Json& j) { first_split(j)["f"] = 7; }, "trees[0].nodes[0].f"},
      {"window beyond bounds", [&](smseg::Json& j) { first_split(j)["dx"] = 50; }, "trees[0].nodes[0].dx"},
      {"threshold not a number", [&](smseg::Json& j) { first_split(j)["t"] = "low"; }, "trees[0].nodes[0].t"},
      {"leaf of the wrong size", [&](smseg::Json& j) { first_leaf(j)["counts"].push_back(1); }, "counts"},
      {"empty leaf", [&](smseg::Json& j) { for (auto& c : first_leaf(j)["counts"]) c = 0; }, "counts"},
      {"no trees", [](smseg::Json& j) { j["trees"] = smseg::Json::array(); }, "trees"},
      {"no classes", [](smseg::Json& j) { j["classes"] = smseg::Json::array(); }, "classes"},
      {"duplicate feature", [](smseg::Json& j) { j["features"][1] = j["features"][0]; }, "features"},
      {"bad K", [](smseg::Json& j) { j["params"]["K"] = 0; }, "params.K"},
      {"bad balance", [](smseg::Json& j) { j["params"]["balance"] = "maybe"; }, "params.balance"},
      {"bad score", [](smseg::Json& j) { j["params"]["score"] = "gini"; }, "params.score"},
      {"score not a string", [](smseg::Json& j) { j["params"]["score"] = 1; }, "params.score"},
      {"no image size", [](smseg::Json& j) { j.erase("image"); }, "image"},
      // issue 19, defect 3: a node with both a leaf's counts and a split used to be read as a leaf.
      {"leaf with a split field", [&](smseg::Json& j) { first_leaf(j)["left"] = 1; }, "has both \"counts\" (a leaf) and the split field \"left\""},
      {"split with counts", [&](smseg::Json& j) { first_split(j)["counts"] = first_leaf(j)["counts"]; }, "trees[0].nodes[0]: has both"},
  };
  for (const Case& c : cases) {
    const std::string err = fx.error_of(c.edit);
    EXPECT_NE(err.find(c.field), std::string::npos) << c.what << " gave: " << err;
  }
}

// issue 19, defect 1: a forest file is read up to kMaxLargeFileBytes; a larger one (here a sparse
// file, which takes no disk) gets one line naming the file and the limit, before a byte is read.
TEST(ForestFile, FilesBeyondTheSizeLimitAreRefusedAtOnce) {
  const fs::path dir = temp_dir("limit");
  const fs::path sparse = dir / "huge.json";
  { std::ofstream(sparse) << "{"; }
  fs::resize_file(sparse, smseg::kMaxLargeFileBytes + 1);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    load_forest(sparse);
    ADD_FAILURE() << "accepted";
  } catch (const smseg::Error& e) {
    EXPECT_EQ(std::string(e.what()), sparse.string() + ": is larger than the 4096 MiB this reader accepts");
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
  fs::remove_all(dir);
}

TEST(ForestFile, CompatibilityWithTheDataIsChecked) {
  const Fixture fx;
  EXPECT_NO_THROW(check_compatible(fx.forest, fx.s.data.classes, fx.s.data.features, "f.json"));
  auto classes = fx.s.data.classes;
  std::swap(classes[0], classes[1]);
  EXPECT_THROW(check_compatible(fx.forest, classes, fx.s.data.features, "f.json"), smseg::Error);
  auto features = fx.s.data.features;
  features.pop_back();
  try {
    check_compatible(fx.forest, fx.s.data.classes, features, "f.json");
    ADD_FAILURE() << "accepted";
  } catch (const smseg::Error& e) {
    EXPECT_EQ(e.file(), "f.json");
    EXPECT_EQ(e.field(), "features");
  }
}

// Parameters recorded only when on (lightness, leaf_tests): a forest without them is written as before;
// a file with one reads it back and writes it again; a value out of range is refused on reading.
TEST(ForestFile, ParametersRecordedOnlyWhenOnAreReadBackAndChecked) {
  const Fixture fx;
  struct Case {
    const char* key;
    smseg::Json on, too_low, too_high;
  };
  const Case cases[] = {{"lightness", 0.45, 0.01, 0.99}, {"leaf_tests", 1000000, -1, 100000001}};
  for (const Case& c : cases) {
    EXPECT_FALSE(forest_to_json(fx.forest)["params"].contains(c.key)) << c.key;  // off: files as before
    const Forest on = fx.load_edited([&](smseg::Json& j) { j["params"][c.key] = c.on; });
    EXPECT_EQ(params_to_json(on.params)[c.key], c.on) << c.key;
    for (const smseg::Json& bad : {c.too_low, c.too_high})
      EXPECT_THROW(fx.load_edited([&](smseg::Json& j) { j["params"][c.key] = bad; }), smseg::Error) << c.key << " " << bad;
  }
  EXPECT_EQ(fx.load_edited([](smseg::Json& j) { j["params"]["leaf_tests"] = 7; }).params.leaf_tests, 7);
  EXPECT_THROW(fx.load_edited([](smseg::Json& j) { j["params"]["leaf_tests"] = 2.5; }), smseg::Error);
}

TEST(ForestFile, SplitScoreIsSavedAndOldFilesReadAsTheDefault) {
  const Fixture fx;
  EXPECT_EQ(forest_to_json(fx.forest)["params"]["score"], "wehenkel-pavella");
  // Files written before the option have no "score": the thesis's default.
  const Forest old = fx.load_edited([](smseg::Json& j) { j["params"].erase("score"); });
  EXPECT_EQ(old.params.score, Score::WehenkelPavella);
  const Forest ig = fx.load_edited([](smseg::Json& j) { j["params"]["score"] = "information-gain"; });
  EXPECT_EQ(ig.params.score, Score::InformationGain);
  EXPECT_EQ(params_to_json(ig.params)["score"], "information-gain");
  EXPECT_EQ(score_from_string("information-gain", "x"), Score::InformationGain);
  EXPECT_THROW(score_from_string("entropy", "--score"), smseg::Error);
}
