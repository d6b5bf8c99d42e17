// Windows, texton tests, corpus values, and the window sampling laws.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "forest_test_util.hpp"
#include "smseg/common/error.hpp"

using namespace forest_test;

TEST(Windows, BoundsFollowTheImageSize) {
  const WindowBounds b = WindowBounds::for_image(320, 240);
  EXPECT_EQ(b.max_dx, 20);
  EXPECT_EQ(b.max_dy, 15);
  EXPECT_EQ(b.max_w, 40);
  EXPECT_EQ(b.max_h, 30);
  const WindowBounds tiny = WindowBounds::for_image(5, 3);
  EXPECT_EQ(tiny.max_dx, 0);
  EXPECT_EQ(tiny.max_w, 1);
  EXPECT_TRUE(b.contains({-20, 15, 40, 1}));
  EXPECT_FALSE(b.contains({-21, 0, 1, 1}));
  EXPECT_FALSE(b.contains({0, 0, 0, 1}));
}

TEST(Windows, ClippedSumsEqualBruteForceEverywhere) {
  const int W = 37, H = 23;
  std::vector<double> img(static_cast<std::size_t>(W) * H);
  Rng rng(5);
  for (auto& v : img) v = static_cast<double>(rng.uniform_int(-50, 50));  // integers: exact sums
  std::vector<double> sat(static_cast<std::size_t>(W + 1) * (H + 1));
  summed_area_table(img.data(), W, H, sat.data());
  int checked = 0, outside = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int k = 0; k < 12; ++k) {
        // Windows well beyond the usual bounds, so that many are partly or wholly outside.
        const Window win{rng.uniform_int(-12, 12), rng.uniform_int(-12, 12), rng.uniform_int(1, 15), rng.uniform_int(1, 15)};
        const double fast = window_sum(sat.data(), W, H, x, y, rel_rect(win));
        const double ref = brute_window_sum(img, W, H, x, y, win);
        ASSERT_EQ(fast, ref) << "x=" << x << " y=" << y << " dx=" << win.dx << " dy=" << win.dy << " w=" << win.w << " h=" << win.h;
        ++checked;
        const RelRect r = rel_rect(win);
        if (x + r.x1 <= 0 || x + r.x0 >= W || y + r.y1 <= 0 || y + r.y0 >= H) {
          EXPECT_EQ(fast, 0.0);
          ++outside;
        }
      }
  EXPECT_GT(outside, 100);
  EXPECT_EQ(checked, W * H * 12);
}

TEST(Windows, OneByOneWindowIsThePixelAtTheOffset) {
  const int W = 9, H = 7;
  std::vector<double> img(static_cast<std::size_t>(W) * H);
  for (std::size_t i = 0; i < img.size(); ++i) img[i] = static_cast<double>(i);
  std::vector<double> sat(static_cast<std::size_t>(W + 1) * (H + 1));
  summed_area_table(img.data(), W, H, sat.data());
  EXPECT_EQ(window_sum(sat.data(), W, H, 4, 3, rel_rect({2, -1, 1, 1})), img[2 * W + 6]);
  // A 3x3 window centred on the offset pixel.
  double s = 0;
  for (int y = 1; y <= 3; ++y)
    for (int x = 5; x <= 7; ++x) s += img[static_cast<std::size_t>(y) * W + x];
  EXPECT_EQ(window_sum(sat.data(), W, H, 4, 3, rel_rect({2, -1, 3, 3})), s);
}

TEST(Textons, TestsFollowTheirDefinitions) {
  const int W = 4, H = 3;
  std::vector<std::uint8_t> g(static_cast<std::size_t>(W) * H);
  for (std::size_t i = 0; i < g.size(); ++i) g[i] = static_cast<std::uint8_t>(10 * i + 5);
  // pt = g(1,1) = 55, ps = g(3,2) = 115.
  EXPECT_EQ(texton_value(g.data(), W, H, 1, 1, 2, 1, 0), 115.0f);
  EXPECT_EQ(texton_value(g.data(), W, H, 1, 1, 2, 1, 1), 170.0f);
  EXPECT_EQ(texton_value(g.data(), W, H, 1, 1, 2, 1, 2), -60.0f);
  EXPECT_EQ(texton_value(g.data(), W, H, 1, 1, 2, 1, 3), 60.0f);
  // Outside the image the sample pixel reads 0.
  EXPECT_EQ(texton_value(g.data(), W, H, 1, 1, 5, 0, 0), 0.0f);
  EXPECT_EQ(texton_value(g.data(), W, H, 1, 1, 5, 0, 3), 55.0f);
}

TEST(Corpus, ValuesEqualBruteForceAndTestsAreLabelledNonVoid) {
  SyntheticOptions o;
  o.width = 48;
  o.height = 40;
  o.frames = 4;
  o.features = 3;
  o.integer_features = true;
  o.void_border = 3;
  const SyntheticData s = make_synthetic(o);
  TrainParams p;
  p.K = 60;
  p.M = 3;
  p.textons = true;
  p.windows.mode = WindowSampling::Thesis;
  // Kt = 200 (50 tests a frame) reads the frames' tables through their interleaved copy, Kt = 8 (2 a
  // frame) reads them as they are (fill_rows makes the copy when the tests read more values than it
  // copies: 50 x 420 x 4 against 49 x 41 x 3 cells here).
  for (const int kt : {200, 8}) {
    p.Kt = kt;
    const Corpus c = build_corpus(s.data, p, 2);
    ASSERT_EQ(c.tests.size(), static_cast<std::size_t>(kt));
    ASSERT_EQ(c.candidates.size(), 60u * (3 + 4));
    const WindowBounds b = WindowBounds::for_image(48, 40);
    for (const Candidate& cand : c.candidates) EXPECT_TRUE(b.contains(cand.win));
    for (std::size_t t = 0; t < c.tests.size(); ++t) {
      const TestPoint& tp = c.tests[t];
      EXPECT_EQ(tp.label, s.labels[static_cast<std::size_t>(tp.frame)][static_cast<std::size_t>(tp.y) * 48 + tp.x]);
      EXPECT_NE(tp.label, kVoidLabel);
      for (std::size_t k = 0; k < c.candidates.size(); k += 7)
        ASSERT_EQ(c.values[k * c.tests.size() + t], brute_value(s, tp.frame, c.candidates[k].feature, c.candidates[k].win, tp.x, tp.y))
            << "Kt " << kt;
    }
  }
  p.Kt = 200;
  const Corpus c = build_corpus(s.data, p, 2);
  // Same seed and tree: same corpus; another tree: another corpus.
  const Corpus again = build_corpus(s.data, p, 2);
  EXPECT_EQ(again.values, c.values);
  const Corpus other = build_corpus(s.data, p, 1);
  EXPECT_NE(other.values, c.values);
}

TEST(Corpus, CsvExportIsTheExactCorpus) {
  SyntheticOptions o;
  o.width = 40;
  o.height = 30;
  o.frames = 2;
  o.features = 2;
  const SyntheticData s = make_synthetic(o);
  TrainParams p;
  p.K = 10;
  p.Kt = 25;
  p.M = 2;
  const fs::path dir = temp_dir("csv");
  export_corpus_csv(s.data, p, 1, dir / "corpus.csv");
  const Corpus c = build_corpus(s.data, p, 1);
  std::ifstream in(dir / "corpus.csv");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line.rfind("label,", 0), 0u);
  EXPECT_EQ(std::count(line.begin(), line.end(), ','), static_cast<long>(c.candidates.size()));
  EXPECT_NE(line.find(candidate_name(c.candidates[3], s.data.features)), std::string::npos);
  std::size_t row = 0;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string cell;
    std::getline(ss, cell, ',');
    ASSERT_LT(row, c.tests.size());
    EXPECT_EQ(std::stoi(cell), c.tests[row].label);
    for (std::size_t k = 0; k < c.candidates.size(); ++k) {
      ASSERT_TRUE(std::getline(ss, cell, ','));
      EXPECT_EQ(std::strtof(cell.c_str(), nullptr), c.values[k * c.tests.size() + row]);
    }
    ++row;
  }
  EXPECT_EQ(row, c.tests.size());
  fs::remove_all(dir);
}

TEST(WindowSampling, UniformCoversTheBounds) {
  const WindowBounds b = WindowBounds::for_image(320, 240);
  const WindowSampler sampler(WindowParams{}, b);
  Rng rng(3);
  std::map<int, int> dx, w;
  for (int i = 0; i < 20000; ++i) {
    const Window win = sampler.draw(rng);
    ASSERT_TRUE(b.contains(win));
    ++dx[win.dx];
    ++w[win.w];
  }
  EXPECT_EQ(dx.size(), 41u);
  EXPECT_EQ(w.size(), 40u);
  EXPECT_EQ(dx.begin()->first, -20);
  EXPECT_EQ(w.rbegin()->first, 40);
}

TEST(WindowSampling, ThesisBiasFavoursLargeDyAndLargeSizes) {
  const WindowBounds b = WindowBounds::for_image(320, 240);
  WindowParams uniform, thesis;
  thesis.mode = WindowSampling::Thesis;
  const WindowSampler su(uniform, b), st(thesis, b);
  Rng r1(11), r2(11);
  double du = 0, dt = 0, wu = 0, wt = 0, hu = 0, ht = 0, xu = 0, xt = 0;
  const int N = 200000;
  for (int i = 0; i < N; ++i) {
    const Window a = su.draw(r1), c = st.draw(r2);
    ASSERT_TRUE(b.contains(c));
    du += std::abs(a.dy), dt += std::abs(c.dy);
    wu += a.w, wt += c.w;
    hu += a.h, ht += c.h;
    xu += std::abs(a.dx), xt += std::abs(c.dx);
  }
  // 10% of dy from a law with E|dy| ~ 2/3 max instead of 1/2: +~1.6% of max on average.
  EXPECT_GT(dt / N, du / N + 0.15);
  EXPECT_GT(wt / N, wu / N + 1.0);  // 25% from a rising law: +~1/6 * 25% * max
  EXPECT_GT(ht / N, hu / N + 0.8);
  EXPECT_NEAR(xt / N, xu / N, 0.15);  // dx unbiased
}

TEST(WindowSampling, LearnedFollowsItsHistogramsAndRescales) {
  const WindowBounds b = WindowBounds::for_image(320, 240);
  WindowParams p;
  p.mode = WindowSampling::Learned;
  p.learned = WindowHistograms::zeros(b);
  for (int i = 0; i < 100000; ++i) p.learned.add(Window{7, -3, 12, 30});
  const WindowSampler s(p, b);
  Rng rng(1);
  int hits = 0;
  for (int i = 0; i < 10000; ++i) {
    const Window w = s.draw(rng);
    hits += w == Window{7, -3, 12, 30};
  }
  EXPECT_GT(hits, 9500);
  // The same histograms used for a half-size image: values scale by 1/2.
  const WindowSampler half(p, WindowBounds::for_image(160, 120));
  int scaled = 0;
  for (int i = 0; i < 1000; ++i) {
    const Window w = half.draw(rng);
    scaled += w.dx == 4 && w.w == 6 && w.h == 15;  // round(7/2) = 4 (away from zero), 12/2, 30/2
  }
  EXPECT_GT(scaled, 950);
  // Empty or malformed histograms are refused.
  WindowParams bad;
  bad.mode = WindowSampling::Learned;
  EXPECT_THROW(WindowSampler(bad, b), smseg::Error);
}

TEST(WindowSampling, LearnedWindowsComeFromTheForestsSplits) {
  SyntheticOptions o;
  o.width = 64;
  o.height = 48;
  o.frames = 3;
  o.signal = 0.3;
  const SyntheticData s = make_synthetic(o);
  TrainParams p;
  p.K = 80;
  p.M = 3;
  const Forest a = train_forest(s.data, p);
  p.seed = 2;
  const Forest b = train_forest(s.data, p);
  const WindowHistograms h = learned_windows({a, b});
  std::int64_t splits = 0;
  for (const Forest* f : {&a, &b})
    for (const Tree& t : f->trees)
      for (const Node& n : t.nodes) splits += !n.is_leaf();
  EXPECT_EQ(h.total(), static_cast<double>(splits));
  // A forest trained from it carries the histograms in its parameters and trains fine.
  p.windows.mode = WindowSampling::Learned;
  p.windows.learned = h;
  const Forest c = train_forest(s.data, p);
  EXPECT_EQ(c.params.windows.learned.dx, h.dx);
  // Forests sized for different images cannot be mixed.
  o.width = 128;
  const SyntheticData big = make_synthetic(o);
  p.windows = WindowParams{};
  const Forest d = train_forest(big.data, p);
  EXPECT_THROW(learned_windows({a, d}), smseg::Error);
}
