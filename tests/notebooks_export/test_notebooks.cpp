// export-notebooks on a quick result set: a notebook per experiment that Debian's jupyter-nbconvert
// executes, PNG figures, and an index linking them; bad input answered in one line.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <string>
#include <utility>
#include <vector>
#include <fstream>

#include "run_tool.hpp"
#include "smseg/common/io.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

using smseg::test::Outcome;
using smseg::test::run;
using smseg::test::tool;

bool is_png(const fs::path& p) {
  if (!fs::exists(p)) return false;
  const std::string s = smseg::read_file(p);
  return s.size() > 1000 && s.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0;
}

class Notebooks : public ::testing::Test {
 protected:
  static fs::path dir;
  static void SetUpTestSuite() {
    dir = fs::temp_directory_path() / ("smseg_notebooks_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  static void TearDownTestSuite() { fs::remove_all(dir); }
};
fs::path Notebooks::dir;

}  // namespace

TEST_F(Notebooks, QuickResultsBecomeNotebooksThatExecute) {
  // Quick results of experiments that use every kind of figure (lines, dict metrics, confusion,
  // surface, window histograms, series).
  const fs::path configs = fs::path(SMSEG_SOURCE_DIR) / "experiments" / "thesis";
  for (const char* name : {"k-sweep", "grid", "windows"}) {
    const Outcome r = run(tool("run-experiment") + " -q --quick --cache " + (dir / "cache").string() + " " +
                          (configs / (std::string(name) + ".json")).string() + " -o " + (dir / "results" / name).string());
    ASSERT_EQ(r.status, 0) << name << ": " << r.out;
  }
  const fs::path nb = dir / "notebooks";
  Outcome r = run(tool("export-notebooks") + " " + (dir / "results").string() + " -o " + nb.string());
  ASSERT_EQ(r.status, 0) << r.out;
  for (const char* name : {"k-sweep", "grid", "windows"}) {
    const fs::path ipynb = nb / (std::string(name) + ".ipynb");
    const json j = smseg::read_json(ipynb);
    EXPECT_EQ(j["nbformat"], 4);
    const json cfg = smseg::read_json(configs / (std::string(name) + ".json"));
    for (const auto& fig : cfg["figures"]) {
      const fs::path png = nb / name / ("fig-" + fig["id"].get<std::string>() + ".png");
      EXPECT_TRUE(is_png(png)) << png;
    }
    // Debian's nbconvert runs it; every figure cell leaves a picture in its output.
    const fs::path executed = dir / (std::string(name) + ".executed.ipynb");
    r = run("jupyter nbconvert --to notebook --execute --ExecutePreprocessor.timeout=300 " + ipynb.string() +
            " --output " + executed.string());
    ASSERT_EQ(r.status, 0) << r.out;
    const json done = smseg::read_json(executed);
    int pictures = 0;
    bool printed_points = false;
    for (const auto& cell : done["cells"]) {
      if (cell["cell_type"] != "code") continue;
      for (const auto& o : cell["outputs"]) {
        EXPECT_NE(o["output_type"], "error") << o.dump().substr(0, 2000);
        if (o.contains("data") && o["data"].contains("image/png")) ++pictures;
        if (o["output_type"] == "stream" && o["text"].dump().find("points") != std::string::npos) printed_points = true;
      }
    }
    EXPECT_EQ(pictures, static_cast<int>(cfg["figures"].size())) << name;
    EXPECT_TRUE(printed_points) << name;
  }
  const std::string index = smseg::read_file(nb / "index.html");
  for (const char* link : {"k-sweep.ipynb", "grid.ipynb", "windows.ipynb", "k-sweep/fig-4.4a.png", "grid/fig-4.16.png"})
    EXPECT_NE(index.find(link), std::string::npos) << link;
  EXPECT_TRUE(fs::exists(nb / "index.md"));
}

TEST_F(Notebooks, BadInputIsOneLine) {
  fs::create_directories(dir / "empty");
  Outcome r = run(tool("export-notebooks") + " " + (dir / "empty").string() + " -o " + (dir / "nb-empty").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  EXPECT_NE(r.out.find("no run-experiment results"), std::string::npos) << r.out;
  // A results folder whose config.json is not one.
  fs::create_directories(dir / "broken" / "x");
  smseg::write_file_atomic(dir / "broken" / "x" / "config.json", "{\"format\": \"smseg-forest\", \"version\": 1}\n");
  r = run(tool("export-notebooks") + " " + (dir / "broken").string() + " -o " + (dir / "nb-broken").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  EXPECT_NE(r.out.find("config.json"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("smseg-experiment-run"), std::string::npos) << r.out;
}

// An interpreter that runs but draws nothing is not a success, and a failure is said as it is: no
// blanket "needs python3-matplotlib" when the interpreter is not even there.
TEST_F(Notebooks, FiguresNotDrawnAreAFailureSaidAsItIs) {
  const fs::path config = dir / "tiny.json";
  smseg::write_json_atomic(config, json::parse(R"({
    "format": "smseg-experiment", "version": 1, "name": "tiny",
    "sequences": {"s": {"synthetic": {"frames": 12, "label_every": 2, "width": 64, "height": 48}}},
    "fixed": {"train": "s", "train_frames": "0:6", "test_frames": "6:", "M": 2},
    "sweep": {"K": [20, 40]},
    "figures": [{"id": "k", "title": "K", "x": "K", "y": "train_seconds", "xlabel": "K", "ylabel": "s"}]})"));
  Outcome r = run(tool("run-experiment") + " -q --cache " + (dir / "cache").string() + " " + config.string() + " -o " +
                  (dir / "tiny-results").string());
  ASSERT_EQ(r.status, 0) << r.out;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"/bin/true", "exited 0 without drawing tiny/fig-k.png"},
      {"/bin/false", "failed (exit 1)"},
      {(dir / "no-such-python").string(), "could not be run"}};
  for (const auto& [python, said] : cases) {
    r = run(tool("export-notebooks") + " -q " + (dir / "tiny-results").string() + " --python " + python + " -o " +
            (dir / "nb-tiny").string());
    EXPECT_EQ(r.status, 1) << python << ": " << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
    EXPECT_NE(r.out.find(said), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("python3-matplotlib"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(dir / "nb-tiny")) << python;
  }
}
