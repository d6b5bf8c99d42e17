#pragma once
// The options tables (smseg/common/options.hpp) of the point-cloud segmenters: each field users set,
// declared once with its key (the summary OUT.json's params), its segment-cloud flag, help and range.
// segment-cloud's command line comes from Table::add_to, its summaries' parameters from Table::to_json.
// Offered on the command line and in the summaries only (no experiment config or Python takes them).
#include <string>
#include <utility>
#include <vector>

#include "smseg/cloud/cloud_segment.hpp"
#include "smseg/cloud/cloud_view.hpp"
#include "smseg/cloud/grabcut_sfm.hpp"
#include "smseg/common/options.hpp"

namespace smseg::cloud {

/// Where segment-cloud's fields are offered: its command line and its summaries.
constexpr unsigned kSegmentCloudSurfaces = options::kCommandLine | options::kFile;

const options::Table<CentroidMinCutParams>& centroid_mincut_params_table();  ///< --method centroid-mincut
const options::Table<MrfParams>& mrf_params_table();                ///< --method mrf: the MRF itself
const options::Table<PlaneSeedParams>& plane_seed_params_table();   ///< --seeds plane
const options::Table<SaliencyParams>& saliency_params_table();      ///< --seeds saliency: the map and regions
const options::Table<ProjectionParams>& projection_params_table();  ///< --seeds saliency: the z-buffer
/// find_table()'s rules; the summaries hold them as the object "table" of grabcut_sfm_params_table().
const options::Table<TableParams>& table_params_table();
/// --method grabcut-sfm's parameters (SupportChoice and the words that choose it are the tool's).
const options::Table<GrabCutSfmParams>& grabcut_sfm_params_table();

namespace option_fields {

/// A field declared through a one-field table of `surfaces` and then changed: the kinds below.
template <class S, class Declare>
options::Field<S> declared(const std::string& table, unsigned surfaces, Declare declare) {
  options::Table<S> one(table, surfaces);
  declare(one);
  return one.fields().front();
}

/// A text that is one of `names` (CLI11's IsMember on the command line: bad usage, exit status 2; an
/// Error naming the place in a file).
template <class S, class Access>
options::Table<S>& one_of(options::Table<S>& t, std::string key, std::string flag, std::string help, Access access,
                          std::vector<std::string> names, unsigned surfaces = kSegmentCloudSurfaces) {
  options::Field<S> f = declared<S>(t.name(), surfaces, [&](options::Table<S>& one) {
    one.text(std::move(key), std::move(flag), std::move(help), access);
  });
  f.type = "name";
  f.add_option = [add = f.add_option, names](CLI::App& app, S& s) { return add(app, s)->check(CLI::IsMember(names)); };
  f.read = [read = f.read, access, names](S& s, const JsonView& v) {
    read(s, v);
    if (std::find(names.begin(), names.end(), access(s)) != names.end()) return;
    std::string expected;
    for (const auto& n : names) expected += (expected.empty() ? "" : ", ") + n;
    v.fail("is \"" + access(s) + "\", expected " + expected);
  };
  return t.custom(std::move(f));
}

/// A number whose --help shows no default: a required one, or one whose default (0: off) lies outside
/// the range the command line takes.
template <class S, class T, class Access>
options::Table<S>& number_without_default(options::Table<S>& t, std::string key, std::string flag, std::string help,
                                          Access access, T lo, T hi, unsigned surfaces = kSegmentCloudSurfaces) {
  options::Field<S> f = declared<S>(t.name(), surfaces, [&](options::Table<S>& one) {
    one.number(std::move(key), std::move(flag), std::move(help), access, lo, hi);
  });
  f.add_option = [add = f.add_option](CLI::App& app, S& s) { return add(app, s)->default_str(""); };
  return t.custom(std::move(f));
}

}  // namespace option_fields

}  // namespace smseg::cloud
