// The work of eval-stereo, forest-peers and eval-stereo-path as library calls: corpus CSVs and their
// errors, seeds, fits and scores, the stereo table and result files, the path report.
#include <gtest/gtest.h>

#include <fstream>

#include "error_text.hpp"
#include "smseg/experiments/eval_stereo.hpp"
#include "smseg/experiments/eval_stereo_path.hpp"
#include "smseg/experiments/forest_peers.hpp"
#include "smseg/sfm/sfm_summary.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
namespace ex = smseg::experiments;

using smseg::test::error_of;

namespace {

fs::path write_csv(const fs::path& dir, const std::string& name, const std::string& text) {
  const fs::path p = dir / name;
  std::ofstream(p) << text;
  return p;
}

/// Two classes split by the first column: label = (a > 0).
std::string separable_csv(int rows) {
  std::string s = "label,a,b\n";
  for (int i = 0; i < rows; ++i) {
    const double a = (i % 2 ? 1.0 : -1.0) * (1 + i % 5), b = (i * 37 % 11) - 5;
    s += std::to_string(i % 2) + "," + std::to_string(a) + "," + std::to_string(b) + "\n";
  }
  return s;
}

}  // namespace

TEST(ForestPeersWork, ReadsACorpusAndNamesTheFileAndRowOfABadOne) {
  const fs::path d = smseg::test::temp_dir("peers_csv");
  const ex::CorpusTable t = ex::read_corpus_table(write_csv(d, "ok.csv", "label,a,b\r\n1,0.5,2\n0,-1,3e2\n\n"));
  EXPECT_EQ(t.header, "label,a,b");
  EXPECT_EQ(t.columns, 2u);
  EXPECT_EQ(t.rows(), 2u);
  EXPECT_EQ(t.labels, (std::vector<std::uint8_t>{1, 0}));
  EXPECT_EQ(t.values, (std::vector<float>{0.5f, 2.0f, -1.0f, 300.0f}));
  const fs::path header = write_csv(d, "header.csv", "a,b\n1,2\n");
  EXPECT_EQ(error_of([&] { ex::read_corpus_table(header); }),
            header.string() + ": header: expected 'label,<candidate names>' (train-forest --export-corpus)");
  const fs::path label = write_csv(d, "label.csv", "label,a\n0,1\n255,1\n");
  EXPECT_EQ(error_of([&] { ex::read_corpus_table(label); }), label.string() + ": row 2: label is not a class index 0..254");
  const fs::path few = write_csv(d, "few.csv", "label,a,b\n0,1\n");
  EXPECT_EQ(error_of([&] { ex::read_corpus_table(few); }), few.string() + ": row 1: has 1 values, expected 2");
  const fs::path empty = write_csv(d, "empty.csv", "label,a\n");
  EXPECT_EQ(error_of([&] { ex::read_corpus_table(empty); }), empty.string() + ": no rows");
  fs::remove_all(d);
}

TEST(ForestPeersWork, SeedsMediansAndClassCounts) {
  EXPECT_EQ(ex::parse_seeds("1,2,50"), (std::vector<std::uint64_t>{1, 2, 50}));
  EXPECT_EQ(error_of([] { ex::parse_seeds("1,x"); }), "--seeds: 'x' is not a non-negative integer");
  EXPECT_EQ(error_of([] { ex::parse_seeds(""); }), "--seeds: no seed given");
  EXPECT_EQ(ex::median({3, 1, 2}), 2);
  EXPECT_EQ(ex::median({4, 1, 2, 3}), 2.5);
  ex::CorpusTable a, b;
  a.labels = {0, 3};
  b.labels = {1};
  EXPECT_EQ(ex::peer_classes(a, b, 0), 4);
  EXPECT_EQ(ex::peer_classes(a, b, 6), 6);
  EXPECT_EQ(error_of([&] { ex::peer_classes(a, b, 3); }), "--classes: is 3 but a label is 3");
}

TEST(ForestPeersWork, FitsAndScoresASeparableTableAndReportsIt) {
  const fs::path d = smseg::test::temp_dir("peers_fit");
  const ex::CorpusTable train = ex::read_corpus_table(write_csv(d, "train.csv", separable_csv(60)));
  const ex::CorpusTable held = ex::read_corpus_table(write_csv(d, "held.csv", separable_csv(20)));
  ex::PeerSettings s;
  s.train_csv = "train.csv";
  s.heldout_csv = "held.csv";
  s.trees = 3;
  s.n_min = 1;
  s.repeat = 2;
  s.classes = ex::peer_classes(train, held, 0);
  const ex::PeerRun run = ex::fit_and_score(train, held, s, 7);
  EXPECT_EQ(run.seed, 7u);
  EXPECT_EQ(run.accuracy, 1.0);
  EXPECT_EQ(run.class_average, 1.0);
  EXPECT_EQ(run.seconds_all.size(), 2u);
  EXPECT_GE(run.nodes, 3u);
  EXPECT_EQ(ex::fit_and_score(train, held, s, 7).nodes, run.nodes);  // same seed, same trees
  EXPECT_EQ(ex::peer_run_line(run, 2).substr(0, 49), "seed 7: accuracy 1.0000 (class-average 1.0000), f");
  EXPECT_EQ(ex::peers_summary_line({run, run}).substr(0, 39), "mean accuracy 1.0000 over 2 seeds, medi");
  const smseg::Json j = ex::peers_json(s, train, held, {run});
  EXPECT_EQ(j["tool"], "smseg forest-peers (grow_trees, wehenkel-pavella)");
  EXPECT_EQ(j["rows_train"], 60);
  EXPECT_EQ(j["classes"], 2);
  EXPECT_EQ(j["runs"][0]["nodes"], run.nodes);
  EXPECT_EQ(j["mean_accuracy"], 1.0);
  fs::remove_all(d);
}

TEST(EvalStereoWork, MatchersShareTheValidityOptionsAndGivenIsRefused) {
  smseg::frontend::StereoOptions bm, sgbm;
  sgbm.method = smseg::frontend::StereoMethod::SGBM;
  bm.uniqueness_ratio = 7;
  const auto m = ex::stereo_matchers({"sgbm", "bm"}, bm, sgbm);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].method, smseg::frontend::StereoMethod::SGBM);
  EXPECT_EQ(m[0].uniqueness_ratio, 7);
  EXPECT_EQ(m[1].method, smseg::frontend::StereoMethod::BM);
  EXPECT_EQ(error_of([&] { ex::stereo_matchers({"given"}, bm, sgbm); }),
            "--methods: 'given' has nothing to evaluate here");
  EXPECT_EQ(error_of([&] { ex::evaluate_stereo("/nonexistent-smseg", m, 2); }),
            "/nonexistent-smseg/images: no such folder (is --data right?)");
}

TEST(EvalStereoWork, TableAndResultsOfGivenScores) {
  ex::StereoEvaluation e;
  e.data = "mb";
  e.matchers.resize(1);
  e.scenes = {"A", "B"};
  for (double share : {0.5, 0.75}) {
    ex::StereoEvalRow r;
    r.scene = share < 0.6 ? "A" : "B";
    r.method = "bm";
    r.score.valid_share = share;
    r.score.bad_rate = share / 10;
    r.seconds = 1;
    e.rows.push_back(r);
  }
  EXPECT_EQ(ex::stereo_eval_markdown(e),
            "| scene | bm valid % | bm bad-2 % |\n|---|---:|---:|\n| A | 50.0 | 5.0 |\n| B | 75.0 | 7.5 |\n"
            "| **mean** | 62.5 | 6.2 |\n");
  const smseg::Json j = ex::stereo_eval_json(e);
  EXPECT_EQ(j["format"], "smseg-stereo-eval");
  EXPECT_EQ(j["methods"][0]["mean_valid_share"], 0.625);
  EXPECT_EQ(j["methods"][0]["mean_seconds"], 1.0);
  EXPECT_EQ(j["scenes"].size(), 2u);
  EXPECT_EQ(j["scenes"][1]["scene"], "B");
}

TEST(EvalStereoPathWork, ReportsTheMeasuresAndTheSfmLineOnlyForSfm) {
  ex::StereoPathEvaluation e;
  e.estimate.resize(3);
  e.truth.resize(3);
  e.rigid.path_length = 2;
  e.rigid.rmse = 0.1;
  e.end_drift = 0.2;
  const std::string report = ex::stereo_path_report(e);
  EXPECT_EQ(report.substr(0, 46), "frames 3, ground-truth path length 2.00 m\nATE ");
  EXPECT_NE(report.find("end-point drift (start-aligned): 0.200 m = 10.00 %\n"), std::string::npos);
  EXPECT_EQ(report.find("sfm:"), std::string::npos);
  e.summary.own = std::make_shared<smseg::sfm::SfmSummary>();
  EXPECT_NE(ex::stereo_path_report(e).find("sfm: focal"), std::string::npos);
  const smseg::Json j = ex::stereo_path_json(e);
  EXPECT_EQ(j["format"], "smseg-stereo-path-eval");
  EXPECT_EQ(j["end_drift_m"], 0.2);
  EXPECT_TRUE(j.contains("sfm"));
  EXPECT_EQ(ex::stereo_path_plot(e, 50).size(), cv::Size(50, 50));
}
