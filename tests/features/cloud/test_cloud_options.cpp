// The point-cloud segmenters' options tables (smseg/cloud/cloud_options.hpp): every field declared with
// its spellings, the command line and the summaries made from the one declaration.
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include "smseg/cloud/cloud_options.hpp"

namespace {

using namespace smseg;
using options::kCommandLine;
using options::kFile;

/// The flags of a table's command-line fields, each declared with a help and a flag.
template <class S>
std::vector<std::string> checked_flags(const options::Table<S>& table) {
  std::vector<std::string> flags;
  for (const auto& f : table.fields()) {
    EXPECT_FALSE(f.help.empty()) << table.name() << " " << f.key;
    EXPECT_EQ(f.surfaces & ~cloud::kSegmentCloudSurfaces, 0u) << table.name() << " " << f.key;
    if (!f.on(kCommandLine)) continue;
    EXPECT_EQ(f.flag.rfind("--", 0), 0u) << table.name() << " " << f.key;
    flags.push_back(f.flag);
  }
  return flags;
}

/// Options written and read back give the same record: every recorded key is read.
template <class S>
void expect_round_trip(const options::Table<S>& table, const S& options = {}) {
  const Json written = table.to_json(options);
  S read{};
  table.read(read, JsonView(written, "summary.json", "params"), kFile);
  EXPECT_EQ(table.to_json(read), written) << table.name();
}

TEST(CloudOptions, EveryFlagIsDeclaredOnceAcrossTheMethods) {
  std::vector<std::string> all;
  for (const auto& flags :
       {checked_flags(cloud::centroid_mincut_params_table()), checked_flags(cloud::mrf_params_table()),
        checked_flags(cloud::plane_seed_params_table()), checked_flags(cloud::saliency_params_table()),
        checked_flags(cloud::projection_params_table()), checked_flags(cloud::table_params_table()),
        checked_flags(cloud::grabcut_sfm_params_table())})
    all.insert(all.end(), flags.begin(), flags.end());
  EXPECT_EQ(std::set<std::string>(all.begin(), all.end()).size(), all.size());
  EXPECT_GT(all.size(), 40u);
}

TEST(CloudOptions, SummariesReadBackWhatTheyRecord) {
  cloud::CentroidMinCutParams centroid;
  centroid.radius = 0.35;  // required: its default 0 is refused
  expect_round_trip(cloud::centroid_mincut_params_table(), centroid);
  expect_round_trip(cloud::mrf_params_table());
  expect_round_trip(cloud::plane_seed_params_table());
  expect_round_trip(cloud::saliency_params_table());
  expect_round_trip(cloud::projection_params_table());
  expect_round_trip(cloud::table_params_table());
  expect_round_trip(cloud::grabcut_sfm_params_table());
  const Json p = cloud::grabcut_sfm_params_table().to_json(cloud::GrabCutSfmParams{});
  ASSERT_TRUE(p.contains("table"));
  EXPECT_EQ(p["table"]["slab_share"], cloud::TableParams{}.slab_share);
  EXPECT_EQ(p["seed"], 1u);
  EXPECT_FALSE(p.contains("slab_share"));  // the table's rules nest under "table"
}

TEST(CloudOptions, TheCommandLineWritesIntoTheStructsAndRefusesBadValues) {
  CLI::App app;
  cloud::GrabCutSfmParams gc;
  cloud::SaliencyParams sal;
  cloud::grabcut_sfm_params_table().add_to(app, gc);
  cloud::table_params_table().add_to(app, gc.table);
  cloud::saliency_params_table().add_to(app, sal);
  app.parse(std::vector<std::string>{"--k=7", "--slab-share=0.02", "--saliency=spectral-residual"});
  EXPECT_EQ(gc.k, 7);
  EXPECT_DOUBLE_EQ(gc.table.slab_share, 0.02);
  EXPECT_EQ(sal.method, "spectral-residual");
  CLI::App bad;
  cloud::saliency_params_table().add_to(bad, sal);
  EXPECT_THROW(bad.parse(std::vector<std::string>{"--saliency=sift"}), CLI::ValidationError);
  const Json wrong = {{"saliency", "sift"}};
  EXPECT_THROW(cloud::saliency_params_table().read(sal, JsonView(wrong, "s.json", "params"), kFile), Error);
}

}  // namespace
