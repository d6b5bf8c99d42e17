// A forest trained in parts (tree ranges) and merged: the "smseg-forest-part" format (see parts.hpp).
#include <algorithm>
#include <charconv>
#include <new>

#include "smseg/common/error.hpp"
#include "smseg/forest/parts.hpp"
#include "smseg/common/io.hpp"

namespace smseg::forest {

namespace {
constexpr const char* kPartFormat = "smseg-forest-part";
constexpr int kPartVersion = 1;

/// A whole non-negative decimal number, or -1.
int parse_index(const std::string& s) {
  int v = -1;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return (s.empty() || r.ec != std::errc() || r.ptr != s.data() + s.size() || v < 0) ? -1 : v;
}

/// "tree 4 is" / "trees 4..6 are": trees first..last (inclusive).
std::string trees_are(int first, int last) {
  return first == last ? "tree " + std::to_string(first) + " is"
                       : "trees " + std::to_string(first) + ".." + std::to_string(last) + " are";
}

/// The forest JSON fields that decide the trees (everything but the trees and their statistics):
/// parts may be merged only when these agree.
constexpr const char* kTrainingFields[] = {"image", "classes", "features", "textons", "params"};

/// The first field in which two parts' training differs ("params.seed"), or "".
std::string first_difference(const nlohmann::json& a, const nlohmann::json& b) {
  for (const char* key : kTrainingFields) {
    const auto& x = a.at(key);
    const auto& y = b.at(key);
    if (x == y) continue;
    if (x.is_object() && y.is_object())
      for (const auto& [k, v] : x.items())
        if (!y.contains(k) || y.at(k) != v) return std::string(key) + "." + k;
    return key;
  }
  return {};
}

/// Error unless part records what first records of its training data (frames, work folders): trees
/// of other data in one forest would pass every other check.
void check_same_training_data(const ForestPart& first, const ForestPart& part) {
  const nlohmann::json& a = first.training_data;
  const nlohmann::json& b = part.training_data;
  if (a == b) return;
  const auto say = [&](const std::string& field, const std::string& why) {
    throw Error(part.file.string(), field, why + " (trees of other data cannot be merged into one forest)");
  };
  if (a.is_null() || b.is_null())
    say("training_data", std::string(a.is_null() ? "recorded here, not in " : "not recorded here, but in ") +
                             first.file.string());
  if (a.is_object() && b.is_object())
    for (const auto& [key, value] : a.items())
      if (!b.contains(key) || b.at(key) != value)
        say("training_data." + key, "differs from " + first.file.string() + "'s: the parts were trained on other data");
  say("training_data", "differs from " + first.file.string() + "'s: the parts were trained on other data");
}
}  // namespace

void TreeRange::validate(int M, const std::string& field, const std::string& file) const {
  if (begin < 0 || end <= begin || end > M)
    throw Error(file, field,
                "is " + to_string() + ", expected A:B with 0 <= A < B <= " + std::to_string(M) + " (the forest's M)");
}

TreeRange TreeRange::parse(const std::string& text, const std::string& option, int M) {
  const auto colon = text.find(':');
  if (colon == std::string::npos)
    throw Error("", option, "is \"" + text + "\", expected a range of tree indices A:B (the tree count is -M)");
  TreeRange r;
  r.begin = parse_index(text.substr(0, colon));
  const std::string end = text.substr(colon + 1);
  r.end = end.empty() ? M : parse_index(end);
  if (r.begin < 0 || r.end < 0)
    throw Error("", option, "is \"" + text + "\", expected A:B with whole numbers A < B (A: = up to M)");
  r.validate(M, option);
  return r;
}

std::string TreeRange::to_string() const { return std::to_string(begin) + ":" + std::to_string(end); }

std::vector<TreeRange> split_trees(int M, int parts, const std::string& option) {
  if (parts < 1 || parts > M)
    throw Error("", option,
                "is " + std::to_string(parts) + ", expected 1.." + std::to_string(M) + " (at least one tree per part)");
  std::vector<TreeRange> ranges;
  int begin = 0;
  for (int i = 0; i < parts; ++i) {
    const int size = M / parts + (i < M % parts ? 1 : 0);
    ranges.push_back({begin, begin + size});
    begin += size;
  }
  return ranges;
}

void save_forest_part(const Forest& part, TreeRange range, const std::filesystem::path& path,
                      const nlohmann::json& training_data) {
  range.validate(part.params.M, "trees", path.string());
  if (static_cast<int>(part.trees.size()) != range.size())
    throw Error(path.string(), "trees",
                "range " + range.to_string() + " but the part holds " + std::to_string(part.trees.size()) + " trees");
  nlohmann::json j = {{"format", kPartFormat},
                      {"version", kPartVersion},
                      {"trees", {{"begin", range.begin}, {"end", range.end}}},
                      {"forest", forest_to_json(part)}};
  if (!training_data.is_null()) j["training_data"] = training_data;
  write_json_atomic(path, j, -1);
}

ForestPart load_forest_part(const std::filesystem::path& path) {
  const nlohmann::json json = read_json(path, kMaxLargeFileBytes);
  const JsonView j(json, path);
  check_format(j, kPartFormat, {kPartVersion});
  ForestPart part;
  part.file = path;
  try {
    part.forest = forest_from_json(j.at("forest").json(), path);
  } catch (const std::bad_alloc&) {  // the parsed file and the forest side by side did not fit
    throw Error(path.string(), "", "out of memory building the forest it holds");
  }
  const JsonView trees = j.at("trees");
  part.range.begin = static_cast<int>(std::clamp<std::int64_t>(trees.integer("begin"), -1, 1 << 30));
  part.range.end = static_cast<int>(std::clamp<std::int64_t>(trees.integer("end"), -1, 1 << 30));
  part.range.validate(part.forest.params.M, "trees", path.string());
  if (static_cast<int>(part.forest.trees.size()) != part.range.size())
    trees.fail("is " + part.range.to_string() + " but forest.trees holds " + std::to_string(part.forest.trees.size()) +
               " trees");
  if (const auto data = j.maybe("training_data")) part.training_data = data->json();
  return part;
}

Forest merge_forest_parts(const std::vector<ForestPart>& parts) {
  if (parts.empty()) throw Error("", "parts", "no forest part to merge");
  std::vector<const ForestPart*> order;
  for (const auto& p : parts) order.push_back(&p);
  std::stable_sort(order.begin(), order.end(),
                   [](const ForestPart* a, const ForestPart* b) { return a->range.begin < b->range.begin; });
  const ForestPart& first = *order.front();
  const nlohmann::json reference = forest_to_json(first.forest);
  Forest whole = first.forest;
  whole.trees.clear();
  std::vector<double> tree_seconds;
  whole.stats.seconds = 0.0;
  int next = 0;  // the first tree not yet covered
  const ForestPart* previous = nullptr;
  for (const ForestPart* p : order) {
    const std::string diff = first_difference(reference, forest_to_json(p->forest));
    if (!diff.empty())
      throw Error(p->file.string(), diff,
                  "differs from " + first.file.string() + "'s: the parts come from different trainings");
    check_same_training_data(first, *p);
    if (p->range.begin < next)
      throw Error(p->file.string(), "trees",
                  p->range.to_string() + " overlaps " + previous->file.string() + "'s " + previous->range.to_string());
    if (p->range.begin > next)
      throw Error(p->file.string(), "trees",
                  trees_are(next, p->range.begin - 1) + " in no part (this part starts at tree " +
                      std::to_string(p->range.begin) + ")");
    for (std::size_t t = 0; t < p->forest.trees.size(); ++t) {
      whole.trees.push_back(p->forest.trees[t]);
      tree_seconds.push_back(p->forest.stats.trees[t].seconds);
    }
    whole.stats.seconds += p->forest.stats.seconds;
    next = p->range.end;
    previous = p;
  }
  if (next != whole.params.M)
    throw Error(previous->file.string(), "trees",
                trees_are(next, whole.params.M - 1) + " in no part (M = " + std::to_string(whole.params.M) +
                    ", the last part ends before)");
  whole.compute_stats();
  for (std::size_t t = 0; t < tree_seconds.size(); ++t) whole.stats.trees[t].seconds = tree_seconds[t];
  return whole;
}

Forest merge_forest_parts(const std::vector<std::filesystem::path>& files) {
  std::vector<ForestPart> parts;
  for (const auto& f : files) parts.push_back(load_forest_part(f));
  return merge_forest_parts(parts);
}

}  // namespace smseg::forest
