// Aggregated voting (thesis 4.5.1): per-pixel labels equal the reference walk, grid voting with every
// pixel voting by majority equals the majority of the per-pixel labels of each cell, superpixel voting
// gives one class per superpixel, fewer trees are a prefix of the forest, and the options are checked.
#include <gtest/gtest.h>

#include <opencv2/core/utility.hpp>

#include "eval_fixture.hpp"
#include "smseg/eval/evaluate.hpp"

namespace fs = std::filesystem;
using namespace smseg;

namespace {

// One forest and one frame shared by the tests of this file (trained once); the work folder goes
// with the process.
struct Fixture {
  fs::path work = eval_test::make_work("voting", 6);
  forest::Forest forest = eval_test::train(work, 5);
  stacks::StackSet set = stacks::open_stacks({work}, stacks::FrameRange{5, 6}, true, true, {});
  Fixture() = default;
  Fixture(const Fixture&) = delete;
  Fixture& operator=(const Fixture&) = delete;
  ~Fixture() {
    std::error_code ignored;
    fs::remove_all(work, ignored);
  }
};

const Fixture& fixture() {
  static const Fixture f;
  return f;
}

int majority(const std::vector<int>& votes, int classes) {
  std::vector<int> n(static_cast<std::size_t>(classes), 0);
  for (int v : votes) ++n[static_cast<std::size_t>(v)];
  return static_cast<int>(std::max_element(n.begin(), n.end()) - n.begin());  // ties: lowest class
}

}  // namespace

TEST(Voting, PerPixelLabelsEqualTheReferenceWalk) {
  const auto& fx = fixture();
  const forest::Classifier c(fx.forest);
  const forest::FrameData& frame = fx.set.dataset.frames[0];
  eval::EvalOptions opt;
  const cv::Mat labels = eval::label_frame(c, frame, opt, 5);
  std::vector<float> dist(fx.forest.classes.size());
  int differ = 0;
  for (int y = 0; y < frame.height; ++y)
    for (int x = 0; x < frame.width; ++x) differ += labels.at<std::uint8_t>(y, x) != c.posterior(frame, x, y, dist.data());
  EXPECT_EQ(differ, 0);
}

TEST(Voting, GridMajorityWithEveryPixelIsTheMajorityOfPerPixelLabels) {
  const auto& fx = fixture();
  // Few, shallow trees make the per-pixel labels disagree inside cells, so the test can tell.
  const forest::Forest f = eval::first_trees(fx.forest, 1);
  const forest::Classifier c(f);
  const forest::FrameData& frame = fx.set.dataset.frames[0];
  eval::EvalOptions pixel;
  const cv::Mat per_pixel = eval::label_frame(c, frame, pixel, 5);
  eval::EvalOptions opt;
  opt.grid = 7;  // 64x48: the last column and row of cells are partial
  opt.votes = 49;
  opt.vote = eval::VoteRule::Majority;
  const cv::Mat grid = eval::label_frame(c, frame, opt, 5);
  int mixed_cells = 0;
  for (int y0 = 0; y0 < frame.height; y0 += 7)
    for (int x0 = 0; x0 < frame.width; x0 += 7) {
      const cv::Rect r(x0, y0, std::min(7, frame.width - x0), std::min(7, frame.height - y0));
      std::vector<int> votes;
      for (int y = r.y; y < r.y + r.height; ++y)
        for (int x = r.x; x < r.x + r.width; ++x) votes.push_back(per_pixel.at<std::uint8_t>(y, x));
      if (std::count(votes.begin(), votes.end(), votes[0]) != static_cast<long>(votes.size())) ++mixed_cells;
      const int want = majority(votes, static_cast<int>(f.classes.size()));
      double lo, hi;
      cv::minMaxLoc(grid(r), &lo, &hi);
      EXPECT_EQ(lo, hi) << "cell at " << x0 << "," << y0 << " is not one class";
      EXPECT_EQ(static_cast<int>(hi), want) << "cell at " << x0 << "," << y0;
    }
  EXPECT_GT(mixed_cells, 0) << "no cell mixes classes: the test would not see a wrong majority";
}

TEST(Voting, HandMadeRegionsTakeTheMajorityOfTheirPixels) {
  const auto& fx = fixture();
  const forest::Classifier c(fx.forest);
  const forest::FrameData& frame = fx.set.dataset.frames[0];
  const cv::Mat per_pixel = eval::label_frame(c, frame, eval::EvalOptions{}, 5);
  // Three regions: a diagonal band, its complement above, and below (not rectangles).
  cv::Mat regions(frame.height, frame.width, CV_32SC1);
  for (int y = 0; y < frame.height; ++y)
    for (int x = 0; x < frame.width; ++x) regions.at<std::int32_t>(y, x) = std::abs(x - y) < 10 ? 0 : (x > y ? 1 : 2);
  eval::EvalOptions opt;
  opt.superpixels = 10;
  opt.votes = 1 << 20;
  opt.vote = eval::VoteRule::Majority;
  const cv::Mat out = eval::vote_regions(c, frame, regions, 3, opt, 5);
  int mixed = 0;
  for (int r = 0; r < 3; ++r) {
    std::vector<int> votes;
    for (int y = 0; y < frame.height; ++y)
      for (int x = 0; x < frame.width; ++x)
        if (regions.at<std::int32_t>(y, x) == r) votes.push_back(per_pixel.at<std::uint8_t>(y, x));
    mixed += std::count(votes.begin(), votes.end(), votes[0]) != static_cast<long>(votes.size());
    const int want = majority(votes, static_cast<int>(fx.forest.classes.size()));
    EXPECT_EQ(cv::countNonZero((regions == r) & (out != want)), 0) << "region " << r;
  }
  EXPECT_GT(mixed, 0) << "every region is one class already: the test would not see a wrong vote";
}

TEST(Voting, SuperpixelsGiveOneClassPerSuperpixelWhateverTheThreads) {
  const auto& fx = fixture();
  const forest::Classifier c(fx.forest);
  const forest::FrameData& frame = fx.set.dataset.frames[0];
  const cv::Mat gray(frame.height, frame.width, CV_8UC1, const_cast<std::uint8_t*>(frame.gray));
  int count = 0;
  const cv::Mat regions = eval::superpixels(gray, 10, &count);
  EXPECT_GT(count, 6);
  eval::EvalOptions opt;
  opt.superpixels = 10;
  opt.votes = 3;
  eval::LabelTimes times;
  const cv::Mat out = eval::label_frame(c, frame, opt, 5, &times);
  EXPECT_GT(times.regions, 0.0);
  for (int r = 0; r < count; ++r) {
    const cv::Mat in = regions == r;
    if (cv::countNonZero(in) == 0) continue;
    double lo, hi;
    cv::minMaxLoc(out, &lo, &hi, nullptr, nullptr, in);
    EXPECT_EQ(lo, hi) << "superpixel " << r << " has more than one class";
  }
  // Same regions and labels with one OpenCV thread (same seed, same output whatever the threads).
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const cv::Mat regions1 = eval::superpixels(gray, 10);
  const cv::Mat out1 = eval::label_frame(c, frame, opt, 5);
  cv::setNumThreads(threads);
  EXPECT_EQ(cv::countNonZero(regions1 != regions), 0) << "SLIC depends on the thread count";
  EXPECT_EQ(cv::countNonZero(out1 != out), 0);
}

TEST(Voting, FirstTreesArePrefixesOfTheForest) {
  const auto& fx = fixture();
  const forest::Forest two = eval::first_trees(fx.forest, 2);
  ASSERT_EQ(two.trees.size(), 2u);
  EXPECT_EQ(two.trees[1].nodes.size(), fx.forest.trees[1].nodes.size());
  const forest::FrameData& frame = fx.set.dataset.frames[0];
  // Summed distributions of two trees = the full forest's walk restricted to them.
  const forest::Classifier c2(two), c1a(eval::first_trees(fx.forest, 1));
  forest::Forest second = fx.forest;
  second.trees = {fx.forest.trees[1]};
  const forest::Classifier c1b(second);
  float d2[2], da[2], db[2];
  for (int y = 0; y < frame.height; y += 5)
    for (int x = 0; x < frame.width; x += 5) {
      c2.posterior(frame, x, y, d2);
      c1a.posterior(frame, x, y, da);
      c1b.posterior(frame, x, y, db);
      EXPECT_FLOAT_EQ(d2[0], da[0] + db[0]);
    }
  EXPECT_THROW(eval::first_trees(fx.forest, 0), Error);
  EXPECT_THROW(eval::first_trees(fx.forest, 6), Error);
  eval::EvalOptions opt;
  opt.frames = stacks::FrameRange{5, 6};
  opt.trees = 6;
  EXPECT_THROW(eval::evaluate(fx.forest, {fx.work}, opt), Error);
}

TEST(Voting, OptionsAreValidatedNamingTheOption) {
  const auto expect_option = [](const eval::EvalOptions& o, const std::string& option) {
    try {
      o.validate();
      FAIL() << "accepted, expected an error naming " << option;
    } catch (const Error& e) {
      EXPECT_EQ(e.field(), option) << e.what();
    }
  };
  eval::EvalOptions o;
  o.grid = 10;
  o.superpixels = 10;
  expect_option(o, "--superpixels");
  o = {};
  o.grid = 10;
  o.votes = 0;
  expect_option(o, "--votes");
  o = {};
  o.tolerance = -1;
  expect_option(o, "--tolerance");
  o = {};
  o.grid = -3;
  expect_option(o, "--grid");
  EXPECT_EQ(eval::superpixels_from_string("small", "--superpixels"), eval::kSmallSuperpixels);
  EXPECT_EQ(eval::superpixels_from_string("large", "--superpixels"), eval::kLargeSuperpixels);
  EXPECT_EQ(eval::superpixels_from_string("40", "--superpixels"), 40);
  EXPECT_THROW(eval::superpixels_from_string("huge", "--superpixels"), Error);
  EXPECT_THROW(eval::superpixels_from_string("12px", "--superpixels"), Error);
  EXPECT_THROW(eval::superpixels_from_string("2", "--superpixels"), Error);
  EXPECT_EQ(eval::vote_rule_from_string("majority", "--vote"), eval::VoteRule::Majority);
  EXPECT_THROW(eval::vote_rule_from_string("max", "--vote"), Error);
}
