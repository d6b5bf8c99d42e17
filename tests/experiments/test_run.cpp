// run-experiment on a tiny synthetic corridor: records carry their meaning, points sharing training
// parameters share one forest, and an interrupted run resumes with no point lost or repeated.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <csignal>
#include <fstream>
#include <set>
#include <thread>

#include "jsonl.hpp"
#include "temp_dir.hpp"
#include "smseg/eval/sweep.hpp"
#include "smseg/experiments/runner.hpp"
#include "smseg/common/io.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
namespace ex = smseg::experiments;

namespace {

json tiny_config(int k2 = 40) {
  json j = json::parse(R"({
    "format": "smseg-experiment", "version": 1, "name": "tiny",
    "sequences": {"c": {"synthetic": {"scene": "corridor", "seed": 2, "frames": 40, "width": 160, "height": 120}}},
    "fixed": {"train": "c", "train_frames": "0:21", "test_frames": "30:", "M": 2, "votes": 4},
    "sweep": {"K": [20, 40], "grid": [0, 10]}
  })");
  j["sweep"]["K"][1] = k2;
  return j;
}

class Run : public ::testing::Test {
 protected:
  static fs::path dir;
  static void SetUpTestSuite() {
    dir = fs::temp_directory_path() / ("smseg_exp_run_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  static void TearDownTestSuite() { fs::remove_all(dir); }
  static fs::path write_config(const json& j, const std::string& name) {
    const fs::path p = dir / name;
    smseg::write_json_atomic(p, j);
    return p;
  }
  static ex::RunOptions options(const std::string& out) {
    ex::RunOptions o;
    o.out = dir / "results" / out;
    o.cache = dir / "cache";
    o.progress = false;
    return o;
  }
};
fs::path Run::dir;

using smseg::test::read_jsonl;

}  // namespace

TEST_F(Run, RecordsMeanWhatTheySayAndPointsShareTheirForest) {
  const ex::Experiment e = ex::load_experiment(write_config(tiny_config(), "tiny.json"), false);
  const auto o = options("meaning");
  const ex::RunReport r = ex::run_experiment(e, o);
  EXPECT_EQ(r.total, 4);
  EXPECT_EQ(r.run, 4);
  const auto recs = read_jsonl(o.out / "experiment.jsonl");
  ASSERT_EQ(recs.size(), 4u);
  for (std::size_t i = 0; i < recs.size(); ++i) {
    const json& rec = recs[i];
    EXPECT_EQ(rec["format"], "smseg-experiment-point");
    EXPECT_EQ(rec["index"], static_cast<int>(i));
    EXPECT_EQ(rec["point"], e.points[i].json);
    EXPECT_EQ(rec["test_frames"], 1);   // labelled frame 30
    EXPECT_EQ(rec["train_frames"], 3);  // labelled frames 0, 10, 20
    const double g = rec["global_accuracy"].get<double>();
    EXPECT_GE(g, 0.0);
    EXPECT_LE(g, 1.0);
    // Global accuracy is the confusion's diagonal share.
    double diag = 0, total = 0;
    for (std::size_t t = 0; t < rec["confusion"].size(); ++t)
      for (std::size_t p = 0; p < rec["confusion"][t].size(); ++p) {
        total += rec["confusion"][t][p].get<double>();
        if (t == p) diag += rec["confusion"][t][p].get<double>();
      }
    EXPECT_NEAR(g, diag / total, 1e-12);
    EXPECT_EQ(rec["per_frame_accuracy"].size(), 1u);
    EXPECT_DOUBLE_EQ(rec["accuracy_variance"].get<double>(), 0.0);  // one test frame
    // Splits per tree, counted per feature and as chosen windows, agree with the tree sizes.
    const double splits = rec["nodes_per_tree"].get<double>() - rec["leaves_per_tree"].get<double>();
    double per_feature = 0;
    for (const auto& [name, n] : rec["nodes_per_feature"].items()) per_feature += n.get<double>();
    EXPECT_NEAR(per_feature, splits * 2, 1e-9);
    double windows = 0;
    for (const auto& n : rec["windows"]["w"]) windows += n.get<double>();
    EXPECT_NEAR(windows, per_feature, 1e-9);
    EXPECT_EQ(rec["nodes_per_feature"].size(), 6u);
    EXPECT_GT(rec["nodes_per_tree"].get<double>(), 1.0);
    EXPECT_GT(rec["train_seconds"].get<double>(), 0.0);
  }
  // K = 20 with grid 0 and 10: one forest, so the same trees and training time.
  EXPECT_EQ(recs[0]["tree_nodes"], recs[1]["tree_nodes"]);
  EXPECT_EQ(recs[0]["train_seconds"], recs[1]["train_seconds"]);
  EXPECT_EQ(recs[0]["point"]["grid"], 0);
  EXPECT_EQ(recs[1]["point"]["grid"], 10);
  // More tests per tree (K = 40) grow larger trees.
  EXPECT_GT(recs[2]["nodes_per_tree"].get<double>(), recs[0]["nodes_per_tree"].get<double>());
  // The data went to the cache, once.
  int works = 0;
  for (const auto& w : fs::directory_iterator(dir / "cache" / "work")) works += fs::exists(w.path() / "complete.json");
  EXPECT_EQ(works, 1);
}

TEST_F(Run, ResumesWithNoPointLostOrRepeated) {
  const ex::Experiment e = ex::load_experiment(write_config(tiny_config(), "tiny.json"), false);
  auto o = options("resume");
  const fs::path jsonl = o.out / "experiment.jsonl";
  o.max_points = 1;
  EXPECT_EQ(ex::run_experiment(e, o).run, 1);
  o.max_points = 2;
  const ex::RunReport second = ex::run_experiment(e, o);
  EXPECT_EQ(second.done_before, 1);
  EXPECT_EQ(second.run, 2);
  auto recs = read_jsonl(jsonl);
  ASSERT_EQ(recs.size(), 3u);
  const json before = recs[1];

  // A kill in the middle of point 1's write: its line is gone and half of a line is left at the end.
  std::string text;
  for (std::size_t i = 0; i < recs.size(); ++i)
    if (i != 1) text += recs[i].dump() + "\n";
  text += R"({"format": "smseg-experiment-point", "index": 3, "poi)";
  smseg::write_file_atomic(jsonl, text);

  o.max_points = 0;
  const ex::RunReport third = ex::run_experiment(e, o);
  EXPECT_EQ(third.done_before, 2);
  EXPECT_EQ(third.run, 2);  // point 1 again, and point 3
  recs = read_jsonl(jsonl);
  ASSERT_EQ(recs.size(), 4u);
  std::set<int> indices;
  for (const auto& r : recs) indices.insert(r["index"].get<int>());
  EXPECT_EQ(indices, (std::set<int>{0, 1, 2, 3}));
  // Same seed, same point, same result.
  for (const auto& r : recs)
    if (r["index"] == 1) {
      EXPECT_EQ(r["confusion"], before["confusion"]);
      EXPECT_EQ(r["tree_nodes"], before["tree_nodes"]);
    }
  // Nothing left to do.
  const ex::RunReport fourth = ex::run_experiment(e, o);
  EXPECT_EQ(fourth.run, 0);
  EXPECT_EQ(fourth.done_before, 4);
  EXPECT_EQ(read_jsonl(jsonl).size(), 4u);

  // A new title or new figures change no result: accepted, and the folder's config.json takes them.
  json retitled = tiny_config();
  retitled["title"] = "New title";
  retitled["figures"] = json::array({{{"id", "a"}, {"x", "K"}}});
  const ex::Experiment re = ex::load_experiment(write_config(retitled, "retitled.json"), false);
  EXPECT_EQ(ex::run_experiment(re, o).run, 0);
  EXPECT_EQ(smseg::read_json(o.out / "config.json")["config"]["title"], "New title");

  // Another config into the same folder is refused, naming the folder's config.json.
  const ex::Experiment other = ex::load_experiment(write_config(tiny_config(60), "other.json"), false);
  try {
    ex::run_experiment(other, o);
    ADD_FAILURE() << "another config was mixed into the results";
  } catch (const smseg::Error& err) {
    EXPECT_EQ(err.file(), (o.out / "config.json").string());
    EXPECT_EQ(err.field(), "config");
  }
  EXPECT_EQ(read_jsonl(jsonl).size(), 4u);
}

TEST_F(Run, ToolKilledMidRunResumes) {
  const fs::path cfg = write_config(tiny_config(), "tiny.json");
  const fs::path out = dir / "results" / "killed", jsonl = out / "experiment.jsonl";
  const std::string tool = (fs::path(SMSEG_BIN_DIR) / "run-experiment").string();
  const std::string args = " -q --cache " + (dir / "cache").string() + " " + cfg.string() + " -o " + out.string();
  // Start it, wait for the first record, then kill -9 it.
  const fs::path pidfile = dir / "pid";
  ASSERT_EQ(std::system((tool + args + " > /dev/null 2>&1 & echo $! > " + pidfile.string()).c_str()), 0);
  const pid_t pid = std::stoi(smseg::read_file(pidfile));
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(120)) {
    if (fs::exists(jsonl) && fs::file_size(jsonl) > 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ::kill(pid, SIGKILL);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const std::size_t at_kill = fs::exists(jsonl) ? read_jsonl(jsonl).size() : 0;
  EXPECT_GE(at_kill, 1u);
  // The rerun finishes the rest.
  ASSERT_EQ(std::system((tool + args + " > /dev/null 2>&1").c_str()), 0);
  const auto recs = read_jsonl(jsonl);
  ASSERT_EQ(recs.size(), 4u);
  std::set<int> indices;
  for (const auto& r : recs) indices.insert(r["index"].get<int>());
  EXPECT_EQ(indices.size(), 4u);
}

TEST_F(Run, PreparedSequencesAndWorkFoldersPlugIn) {
  // The synthetic run first, then the same data named as a sequence folder and as a work folder (the
  // way a CamVid import plugs in): the same stacks give the same forest and the same scores.
  const ex::Experiment e = ex::load_experiment(write_config(tiny_config(), "tiny.json"), false);
  auto o = options("plug-synthetic");
  o.max_points = 1;
  ex::run_experiment(e, o);
  const json want = read_jsonl(o.out / "experiment.jsonl").at(0);
  fs::path seq, work;
  for (const auto& d : fs::directory_iterator(dir / "cache" / "sequences")) seq = d.path();
  for (const auto& d : fs::directory_iterator(dir / "cache" / "work")) work = d.path();
  ASSERT_FALSE(seq.empty());
  ASSERT_FALSE(work.empty());
  for (const char* kind : {"path", "work"}) {
    json j = tiny_config();
    j["sequences"]["c"] = {{kind, (std::string(kind) == "path" ? seq : work).string()}};
    const ex::Experiment p = ex::load_experiment(write_config(j, std::string(kind) + ".json"), false);
    auto po = options(std::string("plug-") + kind);
    po.cache = dir / (std::string("cache-") + kind);
    po.max_points = 1;
    ex::run_experiment(p, po);
    const json got = read_jsonl(po.out / "experiment.jsonl").at(0);
    EXPECT_EQ(got["confusion"], want["confusion"]) << kind;
    EXPECT_EQ(got["tree_nodes"], want["tree_nodes"]) << kind;
    // A prepared work folder keeps its own front end: the point does not claim one.
    if (std::string(kind) == "work") EXPECT_TRUE(got["point"]["train_stereo"].is_null());
    else EXPECT_EQ(got["point"]["train_stereo"], "sparse");  // the stereo front end's default
  }
}

TEST_F(Run, SameRecordsWhateverTheThreadCount) {
  const fs::path cfg = write_config(tiny_config(), "tiny.json");
  const std::string tool = (fs::path(SMSEG_BIN_DIR) / "run-experiment").string();
  for (const char* threads : {"1", "2"})
    ASSERT_EQ(std::system((tool + " -q --threads " + threads + " --cache " + (dir / "cache").string() + " " +
                           cfg.string() + " -o " + (dir / "results" / (std::string("threads") + threads)).string())
                              .c_str()),
              0);
  const auto a = read_jsonl(dir / "results" / "threads1" / "experiment.jsonl");
  const auto b = read_jsonl(dir / "results" / "threads2" / "experiment.jsonl");
  ASSERT_EQ(a.size(), 4u);
  ASSERT_EQ(b.size(), 4u);
  for (std::size_t i = 0; i < a.size(); ++i)
    for (const char* key : {"point", "confusion", "tree_nodes", "nodes_per_feature", "windows", "per_frame_accuracy"})
      EXPECT_EQ(a[i][key], b[i][key]) << i << " " << key;
}

TEST_F(Run, ToolAnswersBadInputInOneLine) {
  const std::string tool = (fs::path(SMSEG_BIN_DIR) / "run-experiment").string();
  json bad = tiny_config();
  bad["fixed"]["M"] = -1;
  const fs::path cfg = write_config(bad, "bad.json");
  const std::string cmd = tool + " " + cfg.string() + " -o " + (dir / "results" / "bad").string() + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string outtext;
  std::array<char, 1024> buf;
  while (std::fgets(buf.data(), buf.size(), p)) outtext += buf.data();
  const int st = ::pclose(p);
  EXPECT_EQ(WEXITSTATUS(st), 1);
  EXPECT_EQ(std::count(outtext.begin(), outtext.end(), '\n'), 1) << outtext;
  EXPECT_NE(outtext.find("bad.json"), std::string::npos) << outtext;
  EXPECT_NE(outtext.find("fixed.M"), std::string::npos) << outtext;
  EXPECT_FALSE(fs::exists(dir / "results" / "bad"));  // nothing written
}

// issue 19, defect 3: a point recorded twice in experiment.jsonl used to be accepted (the set of done
// points hid the copy); now the resume reader names the file, the line and the first record.
TEST(ResumeRecords, PointRecordedTwiceIsRefused) {
  const fs::path dir = smseg::test::temp_dir("jsonl-dup");
  const fs::path jsonl = dir / "experiment.jsonl";
  const std::string a = R"({"format": "smseg-experiment-point", "point": {"M": 1}, "index": 0})";
  const std::string b = R"({"format": "smseg-experiment-point", "point": {"M": 2}, "index": 1})";
  { std::ofstream(jsonl) << a << "\n" << b << "\n"; }
  EXPECT_EQ(smseg::experiments::read_done_points(jsonl).size(), 2u);
  { std::ofstream(jsonl) << a << "\n" << b << "\n" << a << "\n"; }
  try {
    smseg::experiments::read_done_points(jsonl);
    ADD_FAILURE() << "a duplicated point was accepted";
  } catch (const smseg::Error& e) {
    EXPECT_EQ(std::string(e.what()), jsonl.string() + ": line 3: records the same point as line 1 (a run writes each "
                                                      "point once: remove the copy)");
  }
  // A "format" that is not a string threw nlohmann's type_error out of the old reader (seen in review).
  { std::ofstream(jsonl) << R"({"format": 7, "point": {"M": 1}})" << "\n"; }
  EXPECT_THROW(smseg::experiments::read_done_points(jsonl), smseg::Error);
  EXPECT_TRUE(smseg::experiments::read_done_points(dir / "absent.jsonl").empty());
  fs::remove_all(dir);
}
