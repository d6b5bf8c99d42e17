#include "smseg/experiments/config.hpp"

#include <algorithm>
#include <cstdio>
#include <set>
#include <utility>

#include "smseg/stacks/extract.hpp"
#include "smseg/stacks/front_ends.hpp"
#include "smseg/stacks/point_features.hpp"
#include "smseg/common/digest.hpp"
#include "smseg/common/io.hpp"
#include "smseg/common/options.hpp"

namespace smseg::experiments {

using nlohmann::json;

namespace {

// Every parameter of a point, in nesting order: sweeps over earlier parameters are outer loops, so
// that points sharing a forest (same data and training parameters) follow each other.
/// The config keys of a table's fields.
template <class S>
std::vector<std::string> config_keys(const options::Table<S>& table) {
  std::vector<std::string> keys;
  for (const auto& f : table.fields())
    if (f.on(options::kConfig)) keys.push_back(f.config_key);
  return keys;
}

const std::vector<std::string>& known_params() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n{"train", "test", "train_frames", "test_frames", "features",
                               "stereo", "train_stereo", "test_stereo", "motion", "train_motion", "test_motion",
                               "tracker", "train_tracker", "test_tracker",
                               "causal", "train_causal", "test_causal"};
    for (const auto& k : config_keys(stacks::extract_options_table()))
      for (const char* side : {"", "train_", "test_"}) n.push_back(side + k);
    for (const auto& k : config_keys(forest::train_params_table())) n.push_back(k);
    for (const auto& k : config_keys(eval::eval_options_table())) n.push_back(k);
    n.push_back("label");
    return n;
  }();
  return names;
}

int param_rank(const std::string& name) {
  const auto& k = known_params();
  return static_cast<int>(std::find(k.begin(), k.end(), name) - k.begin());
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

/// One point's raw values with where each came from, and typed accessors whose errors name that place.
class Raw {
 public:
  Raw(fs::path file) : file_(std::move(file)) {}

  void set(const std::string& key, const json& value, const std::string& where) {
    if (param_rank(key) == static_cast<int>(known_params().size()))
      throw Error(file_.string(), where, "unknown parameter \"" + key + "\" (known: " + join(known_params()) + ")");
    const auto it = values_.find(key);
    if (it != values_.end())
      throw Error(file_.string(), where, "\"" + key + "\" is also set at " + it->second.second + " (set it once)");
    values_[key] = {value, where};
  }
  bool has(const std::string& key) const { return values_.count(key) > 0; }
  std::string where(const std::string& key) const {
    const auto it = values_.find(key);
    return it == values_.end() ? "fixed." + key : it->second.second;
  }
  [[noreturn]] void fail(const std::string& key, const std::string& reason) const {
    throw Error(file_.string(), where(key), reason);
  }
  /// The value of `key` for a table's reader, its errors naming where it was set.
  JsonView view(const std::string& key) const { return JsonView(values_.at(key).first, file_, where(key)); }
  const json* get(const std::string& key) const {
    const auto it = values_.find(key);
    return it == values_.end() || it->second.first.is_null() ? nullptr : &it->second.first;
  }
  int integer(const std::string& key, int def) const {
    const json* v = get(key);
    if (!v) return def;
    if (!v->is_number_integer()) fail(key, "expected a whole number, found " + v->dump());
    const auto x = v->get<std::int64_t>();
    if (x < -1000000000 || x > 1000000000) fail(key, "out of range: " + v->dump());
    return static_cast<int>(x);
  }
  std::string str(const std::string& key, const std::string& def) const {
    const json* v = get(key);
    if (!v) return def;
    if (!v->is_string()) fail(key, "expected a string, found " + v->dump());
    return v->get<std::string>();
  }
  std::string choice(const std::string& key, const std::string& def, const std::vector<std::string>& allowed) const {
    const std::string s = str(key, def);
    if (std::find(allowed.begin(), allowed.end(), s) == allowed.end())
      fail(key, "\"" + s + "\" is not one of " + join(allowed));
    return s;
  }
  bool boolean(const std::string& key, bool def) const {
    const json* v = get(key);
    if (!v) return def;
    if (!v->is_boolean()) fail(key, "expected true or false, found " + v->dump());
    return v->get<bool>();
  }
  std::vector<std::string> names(const std::string& key) const {
    const json* v = get(key);
    if (!v) return {};
    std::vector<std::string> out;
    if (v->is_string()) {
      out.push_back(v->get<std::string>());
    } else if (v->is_array()) {
      for (const auto& e : *v) {
        if (!e.is_string()) fail(key, "expected a name or a list of names, found " + v->dump());
        out.push_back(e.get<std::string>());
      }
    } else {
      fail(key, "expected a name or a list of names, found " + v->dump());
    }
    return out;
  }

 private:
  fs::path file_;
  std::map<std::string, std::pair<json, std::string>> values_;
};

/// The values of one swept parameter: a list, or an inclusive integer range {"from", "to", "step"}.
std::vector<json> sweep_values(const JsonView& v, const std::string& key) {
  std::vector<json> out;
  if (v.json().is_array()) {
    for (const auto& e : v.json()) out.push_back(e);
  } else if (v.json().is_object()) {
    for (const auto& [k, _] : v.json().items())
      if (k != "from" && k != "to" && k != "step") v.fail("unknown member \"" + k + "\" (a range is {from, to, step})");
    const std::int64_t from = v.integer("from"), to = v.integer("to");
    const std::int64_t step = v.has("step") ? v.integer("step") : 1;
    if (step < 1) v.fail("must be at least 1", "step");
    if (to < from) v.fail("is below \"from\"", "to");
    if ((to - from) / step > 100000) v.fail("too many values", "to");
    for (std::int64_t x = from; x <= to; x += step) out.push_back(x);
  } else {
    v.fail("expected a list of values or a range {\"from\": A, \"to\": B, \"step\": S}");
  }
  if (out.empty()) v.fail("sweeps over no value");
  (void)key;
  return out;
}

SequenceSource parse_source(const JsonView& v, const fs::path& base) {
  if (!v.json().is_object()) v.fail("expected {\"synthetic\": {...}}, {\"path\": DIR} or {\"work\": DIR}");
  if (v.json().size() != 1) v.fail("give exactly one of \"synthetic\", \"path\", \"work\"");
  SequenceSource s;
  // A folder the system cannot even name (too long, a loop of links) is the config's fault: one line
  // naming the member, not a filesystem_error out of the reader.
  const auto folder = [&](const char* key) {
    const std::string given = v.str(key);
    const fs::path p = fs::path(given).is_absolute() ? fs::path(given) : base / given;
    std::error_code ec;
    fs::path out = fs::weakly_canonical(p, ec);
    if (ec) v.fail("cannot be resolved: " + ec.message(), key);
    return out;
  };
  if (v.has("path")) {
    s.kind = SequenceSource::Kind::Path;
    s.path = folder("path");
  } else if (v.has("work")) {
    s.kind = SequenceSource::Kind::Work;
    s.path = folder("work");
  } else if (v.has("synthetic")) {
    s.kind = SequenceSource::Kind::Synthetic;
    const JsonView o = v.at("synthetic");
    if (!o.json().is_object()) o.fail("expected an object of make-sequence options");
    auto& so = s.synth;
    synth::synth_options_table().check_known(o, options::kConfig);
    synth::synth_options_table().read(so, o, options::kConfig);
    try {
      so.validate();
    } catch (const Error& e) {
      o.fail(e.reason(), e.field());
    }
  } else {
    v.fail("give one of \"synthetic\", \"path\", \"work\"");
  }
  return s;
}

/// Maps an Error from a library validator (field "K", "--grid", "windows.mode" ...) onto the config.
[[noreturn]] void rethrow_as_param(const Error& e, const Raw& raw) {
  for (const auto& names : {eval::eval_options_table().option_names(options::kConfig),
                            forest::train_params_table().option_names(options::kConfig)})
    if (const auto it = names.find(e.field()); it != names.end()) raw.fail(it->second, e.reason());
  std::string field = e.field();
  if (field.rfind("--", 0) == 0) field = field.substr(2);
  const std::string head = field.substr(0, field.find('.'));
  for (const auto& k : known_params())
    if (k == head || k == field) raw.fail(k, e.reason());
  if (head == "windows" || head == "thesis_dy_share") raw.fail("windows", e.reason());
  raw.fail(head, (field.empty() ? "" : field + ": ") + e.reason());
}

/// The fields of `table` that the point sets (null values leave the default).
template <class S>
void read_fields(const options::Table<S>& table, S& s, const Raw& raw) {
  for (const auto& f : table.fields())
    if (f.on(options::kConfig) && raw.get(f.config_key)) f.read(s, raw.view(f.config_key));
}

// The training and test sequences, named in the config's "sequences".
void read_sides(const Raw& raw, const Experiment& ex, Point& p) {
  p.train = raw.names("train");
  if (p.train.empty()) raw.fail("train", "name the training sequence(s) (a name or a list from \"sequences\")");
  p.test = raw.has("test") ? raw.names("test") : p.train;
  if (p.test.empty()) raw.fail("test", "name the test sequence(s)");
  for (const auto* side : {&p.train, &p.test})
    for (const auto& n : *side)
      if (!ex.sequences.count(n)) {
        std::vector<std::string> have;
        for (const auto& [k, _] : ex.sequences) have.push_back(k);
        raw.fail(side == &p.train ? "train" : "test", "no sequence named \"" + n + "\" (the config has: " + join(have) + ")");
      }
}

// The frame ranges and the features the forest may use.
void read_frames_and_features(const Raw& raw, const Experiment& ex, Point& p) {
  try {
    p.train_frames = stacks::FrameRange::parse(raw.str("train_frames", "0:101"), "train_frames");
    p.test_frames = stacks::FrameRange::parse(raw.str("test_frames", "110:"), "test_frames");
  } catch (const Error& e) {
    rethrow_as_param(e, raw);
  }
  p.features = raw.names("features");
  for (const auto& f : p.features) {
    const auto& known = stacks::structure_feature_names();
    bool all_extracted = true;
    for (const auto& n : p.train) all_extracted &= ex.sequences.at(n).kind != SequenceSource::Kind::Work;
    if (all_extracted && std::find(known.begin(), known.end(), f) == known.end())
      raw.fail("features", "\"" + f + "\" is not a feature of the stacks (" + join(known) + ")");
  }
}

// One side's front end ("train" or "test"): train_X / test_X override X.
FrontEnd side_front_end(const Raw& raw, const std::string& side) {
  const std::vector<std::string> stereo_methods{"bm", "sgbm", "sparse"}, trackers{"klt", "descriptors"};
  std::vector<std::string> motions;  // the front ends' names (front_ends.hpp)
  for (const stacks::FrontEnd* f : stacks::front_ends()) motions.emplace_back(f->name());
  FrontEnd fe;
  const std::string s = raw.has(side + "_stereo") ? side + "_stereo" : "stereo";
  const std::string m = raw.has(side + "_motion") ? side + "_motion" : "motion";
  const std::string c = raw.has(side + "_causal") ? side + "_causal" : "causal";
  const std::string t = raw.has(side + "_tracker") ? side + "_tracker" : "tracker";
  fe.stereo = raw.choice(s, frontend::stereo_method_name(frontend::stereo_default_stereo().method), stereo_methods);
  fe.motion = raw.choice(m, "stereo", motions);
  fe.tracker = raw.choice(t, "klt", trackers);
  fe.causal = raw.boolean(c, false);
  stacks::ExtractOptions check;  // each value read once here, so that its error names where it was set
  for (const auto& k : config_keys(stacks::extract_options_table())) {
    const std::string key = raw.has(side + "_" + k) ? side + "_" + k : k;
    if (!raw.get(key)) continue;
    stacks::extract_options_table().find_on(k, options::kConfig)->read(check, raw.view(key));
    fe.options[k] = *raw.get(key);
  }
  return fe;
}

void read_train_params(const Raw& raw, Point& p) {
  auto& tp = p.train_params;
  read_fields(forest::train_params_table(), tp, raw);
  try {
    if (tp.windows.mode != forest::WindowSampling::Learned) tp.validate("config");
    else {
      forest::TrainParams check = tp;  // learned histograms come from the pilot forest at run time
      check.windows.mode = forest::WindowSampling::Uniform;
      check.validate("config");
    }
  } catch (const Error& e) {
    rethrow_as_param(e, raw);
  }
}

// The evaluation options; returns the point's "superpixels" as the config gave it ("none" unset).
json read_eval_options(const Raw& raw, Point& p) {
  const auto& tp = p.train_params;
  auto& eo = p.eval;
  eo.frames = p.test_frames;
  read_fields(eval::eval_options_table(), eo, raw);
  try {
    eo.validate();
  } catch (const Error& e) {
    rethrow_as_param(e, raw);
  }
  if (eo.trees > tp.M) raw.fail("trees", std::to_string(eo.trees) + " trees asked, the forest has M = " + std::to_string(tp.M));
  const json* superpixels = raw.get("superpixels");
  return superpixels ? *superpixels : json("none");
}

// Whether any of the named sequences is extracted by the experiment (not a prepared work folder).
bool any_extracted(const Experiment& ex, const std::vector<std::string>& names) {
  bool extracted = false;
  for (const auto& n : names) extracted |= ex.sequences.at(n).kind != SequenceSource::Kind::Work;
  return extracted;
}

// The point's identity: every parameter as run.
json point_json(const Point& p, const Experiment& ex, const json& superpixels) {
  const auto& tp = p.train_params;
  const auto& eo = p.eval;
  const auto side_json = [&](const std::vector<std::string>& names, const FrontEnd& fe, const char* key) -> json {
    if (!any_extracted(ex, names)) return nullptr;  // prepared work folders: their own front end
    const std::string k = key;
    return k == "stereo" ? json(fe.stereo) : k == "motion" ? json(fe.motion) : k == "tracker" ? json(fe.tracker) : json(fe.causal);
  };
  json j = {{"train", p.train},
            {"test", p.test},
            {"train_frames", p.train_frames.str()},
            {"test_frames", p.test_frames.str()},
            {"features", p.features},
            {"train_stereo", side_json(p.train, p.train_front_end, "stereo")},
            {"test_stereo", side_json(p.test, p.test_front_end, "stereo")},
            {"train_motion", side_json(p.train, p.train_front_end, "motion")},
            {"test_motion", side_json(p.test, p.test_front_end, "motion")},
            {"train_causal", side_json(p.train, p.train_front_end, "causal")},
            {"test_causal", side_json(p.test, p.test_front_end, "causal")},
            {"train_tracker", side_json(p.train, p.train_front_end, "tracker")},
            {"test_tracker", side_json(p.test, p.test_front_end, "tracker")},
            {"label", p.label}};
  j.update(forest::train_params_table().to_json(tp, options::kConfig));
  j.update(eval::eval_options_table().to_json(eo, options::kConfig));
  j["superpixels"] = superpixels;  // as the config spelt it ("small", 12, "none" when unset)
  j["trees"] = eo.trees > 0 ? eo.trees : tp.M;  // the trees used
  // Extraction keys only where a side sets them: points of older configs keep their identity.
  for (const auto& k : config_keys(stacks::extract_options_table())) {
    if (!p.train_front_end.options.contains(k) && !p.test_front_end.options.contains(k)) continue;
    const auto side_value = [&](const std::vector<std::string>& names, const FrontEnd& fe) -> json {
      return any_extracted(ex, names) ? fe.options.value(k, json(nullptr)) : json(nullptr);
    };
    j["train_" + k] = side_value(p.train, p.train_front_end);
    j["test_" + k] = side_value(p.test, p.test_front_end);
  }
  return j;
}

Point build_point(const Raw& raw, const Experiment& ex) {
  Point p;
  p.label = raw.str("label", "");
  read_sides(raw, ex, p);
  read_frames_and_features(raw, ex, p);
  p.train_front_end = side_front_end(raw, "train");
  p.test_front_end = side_front_end(raw, "test");
  read_train_params(raw, p);
  const json superpixels = read_eval_options(raw, p);
  p.json = point_json(p, ex, superpixels);
  return p;
}

}  // namespace

json FrontEnd::to_json() const {
  return {{"stereo", stereo}, {"motion", motion}, {"causal", causal}, {"tracker", tracker}};
}

json Point::training_key() const {
  nlohmann::json k;
  for (const char* key : {"train", "train_frames", "features", "train_stereo", "train_motion", "train_causal",
                          "train_tracker"})
    k[key] = json.at(key);
  for (const auto& key : config_keys(stacks::extract_options_table()))
    if (json.contains("train_" + key)) k["train_" + key] = json.at("train_" + key);
  for (const auto& key : config_keys(forest::train_params_table()))  // a field at its default may be left out
    if (json.contains(key)) k[key] = json.at(key);
  return k;
}

std::string Point::describe() const {
  std::string s;
  for (const auto& k : swept) {
    if (k == "label") continue;
    if (!label.empty() && std::find(case_keys.begin(), case_keys.end(), k) != case_keys.end()) continue;
    const auto text = [](const nlohmann::json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); };
    std::string v;
    if (json.contains(k)) {
      v = text(json.at(k));
    } else if (!json.contains("train_" + k)) {  // a value a point records only when not the default
      const auto* eval_field = eval::eval_options_table().find_on(k, options::kConfig);
      v = text(eval_field ? eval_field->write(eval::EvalOptions{})
                          : forest::train_params_table().find_on(k, options::kConfig)->write(forest::TrainParams{}));
    } else {  // stereo, motion, causal, tracker and extraction keys: per side
      const auto& a = json.at("train_" + k);
      const auto& b = json.at("test_" + k);
      v = a == b ? text(a) : text(a) + "/" + text(b);
    }
    s += (s.empty() ? "" : " ") + k + "=" + v;
  }
  if (!label.empty()) s = label + (s.empty() ? "" : " " + s);
  return s.empty() ? "point " + std::to_string(index) : s;
}

std::string json_hash(const json& j) { return fnv1a64_hex(j.dump()); }

namespace {

// The config as run: checked for its format, with its "quick" form merged over it when asked.
json merged_config(const json& original, const fs::path& file, bool quick) {
  {
    const JsonView top(original, file);
    if (!original.is_object()) top.fail("expected a JSON object (an experiment config)");
    check_format(top, kExperimentFormat, {kExperimentVersion});
  }
  json j = original;
  if (quick) {
    if (!j.contains("quick") || !j["quick"].is_object())
      JsonView(original, file).fail("this config has no \"quick\" form (an object merged over it)", "quick");
    j.merge_patch(original["quick"]);
  }
  j.erase("quick");
  return j;
}

// The top-level members: no unknown one; name, title, description; figures a list.
void read_header(const JsonView& v, Experiment& ex) {
  static const std::set<std::string> top_keys{"format", "version", "name", "title", "description", "sequences",
                                              "fixed", "sweep", "figures"};
  for (const auto& [k, _] : ex.config.items())
    if (!top_keys.count(k)) v.fail("unknown member \"" + k + "\"", k);
  ex.name = v.str("name");
  if (ex.name.empty() || ex.name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_-") != std::string::npos)
    v.fail("must be a non-empty name of a-z, 0-9, '-' and '_'", "name");
  ex.title = v.has("title") ? v.str("title") : ex.name;
  ex.description = v.has("description") ? v.str("description") : "";
  if (v.has("figures") && !v.at("figures").json().is_array()) v.fail("expected a list of figures", "figures");
}

// "fixed": the base values of every point.
std::vector<std::pair<std::string, json>> fixed_values(const JsonView& v) {
  std::vector<std::pair<std::string, json>> fixed;
  if (auto f = v.maybe("fixed")) {
    if (!f->json().is_object()) f->fail("expected an object of parameters");
    for (const auto& [k, val] : f->json().items()) fixed.emplace_back(k, val);
  }
  return fixed;
}

struct SweepDimension {
  std::string key;  // parameter, or "cases"
  std::vector<json> values;
};

// "sweep": its dimensions in nesting order ("cases" outermost, then the parameters' order).
std::vector<SweepDimension> sweep_dimensions(const JsonView& v) {
  std::vector<SweepDimension> dims;
  if (auto s = v.maybe("sweep")) {
    if (!s->json().is_object()) s->fail("expected an object of swept parameters");
    for (const auto& [k, _] : s->json().items()) {
      const JsonView d = s->at(k);
      if (k == "cases") {
        if (!d.json().is_array() || d.json().empty()) d.fail("expected a non-empty list of parameter objects");
        SweepDimension dim{"cases", {}};
        for (std::size_t i = 0; i < d.size(); ++i) {
          if (!d.at(i).json().is_object()) d.at(i).fail("expected an object of parameters");
          dim.values.push_back(d.at(i).json());
        }
        dims.push_back(std::move(dim));
      } else {
        if (param_rank(k) == static_cast<int>(known_params().size()))
          d.fail("unknown parameter \"" + k + "\" (known: " + join(known_params()) + ")");
        dims.push_back({k, sweep_values(d, k)});
      }
    }
  }
  std::stable_sort(dims.begin(), dims.end(), [](const SweepDimension& a, const SweepDimension& b) {
    const int ra = a.key == "cases" ? -1 : param_rank(a.key), rb = b.key == "cases" ? -1 : param_rank(b.key);
    return ra < rb;
  });
  return dims;
}

// The point at one combination `at` of the dimensions' values, over the fixed values.
Point point_at(const std::vector<std::pair<std::string, json>>& fixed, const std::vector<SweepDimension>& dims,
               const std::vector<std::size_t>& at, const Experiment& ex) {
  Raw raw(ex.file);
  for (const auto& [k, val] : fixed) raw.set(k, val, "fixed." + k);
  std::vector<std::string> swept, case_keys;
  for (std::size_t d = 0; d < dims.size(); ++d) {
    const json& val = dims[d].values[at[d]];
    const std::string idx = "[" + std::to_string(at[d]) + "]";
    if (dims[d].key == "cases") {
      for (const auto& [k, cv] : val.items()) {
        raw.set(k, cv, "sweep.cases" + idx + "." + k);
        if (std::find(swept.begin(), swept.end(), k) == swept.end()) swept.push_back(k);
        case_keys.push_back(k);
      }
    } else {
      raw.set(dims[d].key, val, "sweep." + dims[d].key + idx);
      swept.push_back(dims[d].key);
    }
  }
  Point p = build_point(raw, ex);
  p.index = static_cast<int>(ex.points.size());
  p.swept = swept;
  p.case_keys = case_keys;
  return p;
}

// The next combination, last dimension fastest; false after the last.
bool next_combination(std::vector<std::size_t>& at, const std::vector<SweepDimension>& dims) {
  for (std::size_t d = dims.size(); d-- > 0;) {
    if (++at[d] < dims[d].values.size()) return true;
    at[d] = 0;
  }
  return false;
}

}  // namespace

Experiment experiment_from_json(const json& original, const fs::path& file, bool quick) {
  Experiment ex;
  ex.file = file;
  ex.quick = quick;
  ex.config = merged_config(original, file, quick);
  const JsonView v(ex.config, file);
  read_header(v, ex);

  const fs::path base = file.has_parent_path() ? file.parent_path() : fs::path(".");
  const JsonView seqs = v.at("sequences");
  if (!seqs.json().is_object() || seqs.json().empty()) seqs.fail("expected an object naming at least one sequence");
  for (const auto& [name, _] : seqs.json().items()) ex.sequences[name] = parse_source(seqs.at(name), base);

  // The base values, then the sweep dimensions in nesting order.
  const auto fixed = fixed_values(v);
  const std::vector<SweepDimension> dims = sweep_dimensions(v);
  std::vector<std::size_t> at(dims.size(), 0);
  std::set<std::string> seen;
  do {
    Point p = point_at(fixed, dims, at, ex);
    if (!seen.insert(p.json.dump()).second)
      throw Error(file.string(), "sweep", "two points have the same parameters (" + p.describe() + ")");
    ex.points.push_back(std::move(p));
    if (ex.points.size() > 100000) v.fail("more than 100000 points", "sweep");
  } while (next_combination(at, dims));
  return ex;
}

Experiment load_experiment(const fs::path& file, bool quick) {
  return experiment_from_json(read_json(file), file, quick);
}

}  // namespace smseg::experiments
