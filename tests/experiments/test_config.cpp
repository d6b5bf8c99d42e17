// Experiment configs: expansion of sweeps into points, the --quick merge patch, and one clear error
// naming the config file and the field for each kind of bad input.
#include <gtest/gtest.h>

#include <fstream>

#include "smseg/experiments/config.hpp"

namespace fs = std::filesystem;
using smseg::experiments::Experiment;
using smseg::experiments::experiment_from_json;
using nlohmann::json;

namespace {

const fs::path kFile = "/tmp/some/config.json";

json base() {
  return json::parse(R"({
    "format": "smseg-experiment", "version": 1, "name": "t",
    "sequences": {"c": {"synthetic": {"scene": "corridor", "frames": 40}}, "l": {"synthetic": {"scene": "lab"}}},
    "fixed": {"train": "c", "M": 3},
    "sweep": {"grid": [0, 20], "K": {"from": 50, "to": 100, "step": 25}},
    "quick": {"sweep": {"K": [10]}, "fixed": {"M": 2}}
  })");
}

/// The Error of experiment_from_json(j), or fails the test.
smseg::Error error_of(const json& j, bool quick = false) {
  try {
    experiment_from_json(j, kFile, quick);
  } catch (const smseg::Error& e) {
    return e;
  }
  ADD_FAILURE() << "no error for " << j.dump();
  return smseg::Error("", "", "");
}

}  // namespace

TEST(ExperimentConfig, SweepsExpandIntoTheProductWithTrainingParametersOutside) {
  const Experiment ex = experiment_from_json(base(), kFile, false);
  ASSERT_EQ(ex.points.size(), 6u);  // K in {50, 75, 100} x grid in {0, 20}
  // K varies slowest (it changes the forest), grid fastest (evaluation only), whatever the JSON order.
  EXPECT_EQ(ex.points[0].json["K"], 50);
  EXPECT_EQ(ex.points[0].json["grid"], 0);
  EXPECT_EQ(ex.points[1].json["K"], 50);
  EXPECT_EQ(ex.points[1].json["grid"], 20);
  EXPECT_EQ(ex.points[5].json["K"], 100);
  EXPECT_EQ(ex.points[0].training_key(), ex.points[1].training_key());
  EXPECT_NE(ex.points[1].training_key(), ex.points[2].training_key());
  // Defaults are filled in: the thesis protocol.
  const auto& p = ex.points[0];
  EXPECT_EQ(p.json["test"], json::array({"c"}));
  EXPECT_EQ(p.json["train_frames"], "0:101");
  EXPECT_EQ(p.json["test_frames"], "110:");
  EXPECT_EQ(p.json["train_stereo"], "sparse");  // the stereo front end's default (frontend::stereo_default_stereo)
  EXPECT_EQ(p.json["trees"], 3);
  EXPECT_EQ(p.train_params.M, 3);
  EXPECT_EQ(p.eval.grid, 0);
  EXPECT_EQ(ex.points[1].eval.grid, 20);
  EXPECT_EQ(ex.points[1].describe(), "K=50 grid=20");
}

TEST(ExperimentConfig, QuickFormIsAMergePatch) {
  const Experiment ex = experiment_from_json(base(), kFile, true);
  ASSERT_EQ(ex.points.size(), 2u);
  EXPECT_EQ(ex.points[0].train_params.K, 10);
  EXPECT_EQ(ex.points[0].train_params.M, 2);
  EXPECT_TRUE(ex.quick);
  EXPECT_FALSE(ex.config.contains("quick"));
}

TEST(ExperimentConfig, CasesSetSeveralParametersAndSidesHaveTheirOwnFrontEnd) {
  json j = base();
  j["fixed"] = {{"M", 3}};
  j["sweep"] = json::parse(R"({"cases": [{"label": "C on L", "train": "c", "test": "l", "train_stereo": "sgbm"},
                                          {"label": "L on L", "train": "l", "test": "l", "causal": true}]})");
  const Experiment ex = experiment_from_json(j, kFile, false);
  ASSERT_EQ(ex.points.size(), 2u);
  EXPECT_EQ(ex.points[0].label, "C on L");
  EXPECT_EQ(ex.points[0].train_front_end.stereo, "sgbm");
  EXPECT_EQ(ex.points[0].test_front_end.stereo, "sparse");  // the default
  EXPECT_EQ(ex.points[0].json["test_stereo"], "sparse");
  EXPECT_TRUE(ex.points[1].train_front_end.causal);
  EXPECT_TRUE(ex.points[1].test_front_end.causal);
  EXPECT_EQ(ex.points[0].describe(), "C on L");  // a case is named by its label
  j["sweep"]["K"] = {100, 200};
  EXPECT_EQ(experiment_from_json(j, kFile, false).points[1].describe(), "C on L K=200");
}

TEST(ExperimentConfig, BadInputIsOneErrorNamingTheFileAndTheField) {
  struct Case {
    const char* patch;  // merge patch over base()
    const char* field;
    const char* reason_part;
  };
  const Case cases[] = {
      {R"({"format": "smseg-forest"})", "format", "smseg-experiment"},
      {R"({"version": 7})", "version", ""},
      {R"({"name": "Bad Name"})", "name", "a-z"},
      {R"({"colour": 1})", "colour", "unknown"},
      {R"({"fixed": {"Q": 1}})", "fixed.Q", "unknown parameter"},
      {R"({"sweep": {"Q": [1]}})", "sweep.Q", "unknown parameter"},
      {R"({"fixed": {"M": "seven"}})", "fixed.M", "whole number"},
      {R"({"fixed": {"M": 0}})", "fixed.M", ""},
      {R"({"sweep": {"K": [50, 0]}})", "sweep.K[1]", ""},
      {R"({"sweep": {"K": {"from": 5, "to": 1}}})", "sweep.K.to", "below"},
      {R"({"sweep": {"K": {"from": 5, "to": 9, "step": 0}}})", "sweep.K.step", "at least 1"},
      {R"({"sweep": {"K": []}})", "sweep.K", "no value"},
      {R"({"fixed": {"train": "nowhere"}})", "fixed.train", "no sequence named \"nowhere\""},
      {R"({"fixed": {"test_frames": "1:x"}})", "fixed.test_frames", ""},
      {R"({"fixed": {"superpixels": "small"}})", "fixed.superpixels", "grid"},
      {R"({"fixed": {"trees": 9}})", "fixed.trees", "M = 3"},
      {R"({"fixed": {"stereo": "triclops"}})", "fixed.stereo", "bm, sgbm"},
      {R"({"fixed": {"motion": "lidar"}})", "fixed.motion", "stereo, sfm"},
      {R"({"fixed": {"windows": "gaussian"}})", "fixed.windows", ""},
      {R"({"fixed": {"features": ["fH", "fZ"]}})", "fixed.features", "fZ"},
      {R"({"fixed": {"K": 400}})", "sweep.K[0]", "also set at fixed.K"},
      {R"({"sweep": {"grid": [0, 0]}})", "sweep", "same parameters"},
      {R"({"sequences": {"c": {"synthetic": {"scene": "corridor", "frames": 0}}}})", "sequences.c.synthetic.frames", ""},
      {R"({"sequences": {"c": {"video": "x"}}})", "sequences.c", "synthetic"},
      {R"({"sequences": {"c": {"synthetic": {"scene": "corridor", "fov": 3}}}})", "sequences.c.synthetic.fov", "is not an option of make_sequence"},
  };
  for (const auto& c : cases) {
    json j = base();
    j.merge_patch(json::parse(c.patch));
    const smseg::Error e = error_of(j);
    EXPECT_EQ(e.file(), kFile.string()) << c.patch;
    EXPECT_EQ(e.field(), c.field) << c.patch << ": " << e.what();
    EXPECT_NE(std::string(e.reason()).find(c.reason_part), std::string::npos) << c.patch << ": " << e.what();
  }
  // A folder the system cannot name (a component longer than NAME_MAX): one line, not a filesystem_error.
  for (const char* key : {"path", "work"}) {
    json j = base();
    j["sequences"]["c"] = {{key, "/tmp/" + std::string(300, 'x')}};  // /tmp exists, so it is looked up
    const smseg::Error e = error_of(j);
    EXPECT_EQ(e.field(), std::string("sequences.c.") + key) << e.what();
    EXPECT_NE(std::string(e.reason()).find("cannot be resolved"), std::string::npos) << e.what();
  }
  // --quick on a config without a quick form.
  json j = base();
  j.erase("quick");
  EXPECT_EQ(error_of(j, true).field(), "quick");
  // Not an object at all.
  EXPECT_EQ(error_of(json::array()).file(), kFile.string());
}

TEST(ExperimentConfig, ThesisConfigsLoadInFullAndQuickForm) {
  const fs::path dir = fs::path(SMSEG_SOURCE_DIR) / "experiments" / "thesis";
  int configs = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() != ".json") continue;
    ++configs;
    for (bool quick : {false, true}) {
      const Experiment ex = smseg::experiments::load_experiment(e.path(), quick);
      EXPECT_EQ(ex.name, e.path().stem().string());
      EXPECT_FALSE(ex.points.empty());
      EXPECT_TRUE(ex.config.contains("figures")) << e.path();
      if (quick) {
        EXPECT_LE(ex.points.size(), 24u) << e.path();
      }
      if (!quick && ex.name == "k-sweep") {
        ASSERT_EQ(ex.points.size(), 35u);  // K = 50, 75, ..., 900
        EXPECT_EQ(ex.points.front().train_params.K, 50);
        EXPECT_EQ(ex.points.back().train_params.K, 900);
      }
      if (!quick && ex.name == "m-sweep") {
        ASSERT_EQ(ex.points.size(), 42u);  // the first m of 42 trees
        EXPECT_EQ(ex.points.front().training_key(), ex.points.back().training_key());
      }
    }
  }
  EXPECT_GE(configs, 10);
}
