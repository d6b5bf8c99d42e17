#include "smseg/experiments/runner.hpp"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <algorithm>
#include <cstring>
#include <fcntl.h>
#include <iostream>
#include <map>
#include <set>
#include <sys/file.h>
#include <unistd.h>

#include "smseg/eval/sweep.hpp"
#include "smseg/stacks/extract.hpp"
#include "smseg/common/options.hpp"
#include "smseg/stacks/front_ends.hpp"
#include "smseg/forest/train.hpp"
#include "smseg/common/io.hpp"
#include "smseg/common/output.hpp"
#include "smseg/common/progress.hpp"

namespace smseg::experiments {

using nlohmann::json;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// An exclusive advisory lock on a file, held while in scope.
class FileLock {
 public:
  explicit FileLock(const fs::path& path) {
    fs::create_directories(path.parent_path());
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw Error(path.string(), "", std::string("cannot be opened as a lock: ") + std::strerror(errno));
    while (::flock(fd_, LOCK_EX) != 0) {
      if (errno == EINTR) continue;
      const int e = errno;
      ::close(fd_);
      throw Error(path.string(), "", std::string("cannot be locked: ") + std::strerror(e));
    }
  }
  ~FileLock() {
    ::flock(fd_, LOCK_UN);
    ::close(fd_);
  }
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  int fd_ = -1;
};

json synth_json(const synth::SynthOptions& o) {
  return synth::synth_options_table().to_json(o, options::kFile);
}

stacks::ExtractOptions extract_options(const FrontEnd& fe, bool progress) {
  stacks::ExtractOptions o;
  stacks::extract_options_table().read(o, JsonView(fe.options, "experiment config"), options::kConfig);
  o.front_end.stereo.method = frontend::parse_stereo_method(fe.stereo, "stereo");
  o.stereo_tracker = fe.tracker;  // a config's tracker is the stereo front end's (the SfM keeps "auto")
  o.resolve();
  o.motion = fe.motion;
  o.features.causal = fe.causal;
  o.progress = progress;
  o.validate();
  return o;
}

std::string safe_name(const std::string& s) {
  std::string out;
  for (char c : s) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
  return out.empty() ? "seq" : out;
}

json num(double v) { return std::isnan(v) ? json(nullptr) : json(v); }

}  // namespace

fs::path default_cache(const fs::path& out) {
  const fs::path abs = fs::absolute(out).lexically_normal();
  const fs::path parent = abs.has_filename() ? abs.parent_path() : abs.parent_path().parent_path();
  return parent / "cache";
}

fs::path prepare_sequence(const std::string& name, const SequenceSource& source, const fs::path& cache, bool progress) {
  switch (source.kind) {
    case SequenceSource::Kind::Path:
      return source.path;
    case SequenceSource::Kind::Work:
      throw Error("", name, "is a prepared work folder, not a sequence");
    case SequenceSource::Kind::Synthetic:
      break;
  }
  const json key = synth_json(source.synth);
  const fs::path dir = cache / "sequences" / (safe_name(source.synth.scene) + "-" + json_hash(key));
  if (fs::exists(dir / sequence::kManifestName)) return dir;
  // No manifest: none yet, or a run was killed while making it (the manifest is written last). Its
  // images and temporaries go; the sequence is made again, the same bytes for the same options.
  fs::remove_all(dir);
  if (progress) std::cerr << "run-experiment: generating sequence \"" << name << "\" (" << key.dump() << ") in " << dir.string() << "\n";
  synth::SynthOptions o = source.synth;
  o.progress = progress;
  synth::make_sequence(o, dir);  // writes sequence.json last
  return dir;
}

fs::path prepare_work(const std::string& name, const SequenceSource& source, const FrontEnd& fe, const fs::path& cache,
                      bool progress) {
  if (source.kind == SequenceSource::Kind::Work) {
    stacks::load_stack_manifest(source.path);  // validates it
    return source.path;
  }
  FileLock lock(cache / "lock");
  const fs::path seq_dir = prepare_sequence(name, source, cache, progress);
  const sequence::Sequence seq = sequence::load_sequence(seq_dir);
  const stacks::ExtractOptions eo = extract_options(fe, progress);
  json key = stacks::run_options_key(fe.motion, eo);
  key["sequence"] = fs::weakly_canonical(seq_dir).string();
  key["features"] = stacks::feature_options_json(eo.features);
  const fs::path work = cache / "work" / (safe_name(seq.name) + "-" + json_hash(key));
  const fs::path done = work / "complete.json";
  if (fs::exists(done)) {
    const json rec = read_json(done);
    if (rec.value("key", json()) == key) return work;
  }
  if (progress)
    std::cerr << "run-experiment: extracting \"" << name << "\" (stereo " << fe.stereo << ", motion " << fe.motion
              << (fe.causal ? ", causal" : "") << ") into " << work.string() << "\n";
  const stacks::ExtractReport r = stacks::extract_features(seq, work, eo);
  write_json_atomic(done, {{"format", "smseg-experiment-cache"},
                           {"version", 1},
                           {"key", key},
                           {"front_end_seconds", r.front_end_seconds},
                           {"valid_points_per_frame", r.summary.valid_points_per_frame_mean}});
  return work;
}

std::set<std::string> read_done_points(const fs::path& jsonl) {
  std::set<std::string> done;
  std::map<std::string, int> line_of_point;
  int line = 0;
  for (const auto& rec : eval::read_jsonl(jsonl)) {
    ++line;
    const std::string where = "line " + std::to_string(line);
    const auto format = rec.find("format");
    if (format == rec.end() || *format != kRecordFormat || !rec.contains("point"))
      throw Error(jsonl.string(), where, "is not a run-experiment record");
    const std::string point = rec["point"].dump();
    const auto [first, inserted] = line_of_point.emplace(point, line);
    if (!inserted)
      throw Error(jsonl.string(), where,
                  "records the same point as line " + std::to_string(first->second) +
                      " (a run writes each point once: remove the copy)");
    done.insert(point);
  }
  return done;
}

namespace {

// The config this folder belongs to (OUT/config.json). Only what decides the results must match; titles,
// descriptions and figures may change (the snapshot then takes them, for export-notebooks).
void check_snapshot(const Experiment& ex, const fs::path& out, bool look_only) {
  const fs::path snapshot = out / "config.json";
  const auto results_part = [](json c) {
    for (const char* k : {"title", "description", "figures"}) c.erase(k);
    return c;
  };
  const json record = {{"format", kRunFormat},         {"version", 1},         {"name", ex.name},
                       {"config_file", ex.file.string()}, {"quick", ex.quick}, {"config", ex.config}};
  if (fs::exists(snapshot)) {
    const json old = read_json(snapshot);
    if (!old.is_object() || old.value("format", "") != kRunFormat)
      throw Error(snapshot.string(), "format", "is not a run-experiment results folder's config.json");
    if (results_part(old.value("config", json())) != results_part(ex.config) || old.value("quick", !ex.quick) != ex.quick)
      throw Error(snapshot.string(), "config",
                  "this results folder was made with another config (or with/without --quick); write to another -o");
    if (old != record && !look_only) write_json_atomic(snapshot, record);
  } else if (!look_only) {
    write_json_atomic(snapshot, record);
  }
}

// The points to run now: not yet in `jsonl`, among options.points, at most options.max_points. Counts
// the done and left ones into the report.
std::vector<const Point*> plan_points(const Experiment& ex, const RunOptions& options, const fs::path& jsonl,
                                      RunReport& report) {
  const std::set<std::string> done = read_done_points(jsonl);
  std::vector<const Point*> todo;
  report.total = static_cast<int>(ex.points.size());
  for (const auto& p : ex.points) {
    if (done.count(p.json.dump())) {
      ++report.done_before;
      continue;
    }
    report.left.push_back(p.index);
    if (!options.points || std::count(options.points->begin(), options.points->end(), p.index)) todo.push_back(&p);
  }
  if (report.done_before != static_cast<int>(done.size()))
    throw Error(jsonl.string(), "point", "holds points that are not in this config");
  if (options.max_points > 0 && static_cast<int>(todo.size()) > options.max_points) todo.resize(std::size_t(options.max_points));
  return todo;
}

// The work folder of every (sequence, front end), prepared once.
class WorkFolders {
 public:
  WorkFolders(const Experiment& ex, const fs::path& cache, bool progress) : ex_(ex), cache_(cache), progress_(progress) {}
  const fs::path& of(const std::string& name, const FrontEnd& fe) {
    const std::string key = name + "|" + fe.to_json().dump();
    auto it = works_.find(key);
    if (it == works_.end())
      it = works_.emplace(key, prepare_work(name, ex_.sequences.at(name), fe, cache_, progress_)).first;
    return it->second;
  }
  std::vector<fs::path> of(const std::vector<std::string>& names, const FrontEnd& fe) {
    std::vector<fs::path> works;
    for (const auto& n : names) works.push_back(of(n, fe));
    return works;
  }

 private:
  const Experiment& ex_;
  fs::path cache_;
  bool progress_;
  std::map<std::string, fs::path> works_;  // key: name + front end
};

std::vector<std::string> path_strings(const std::vector<fs::path>& paths) {
  std::vector<std::string> strings;
  for (const auto& w : paths) strings.push_back(w.string());
  return strings;
}

// The forest of the last training, kept while consecutive points share their training.
struct TrainedForest {
  std::string key;  // the training key it was made for
  forest::Forest forest;
  double pilot_seconds = 0;
  std::size_t train_frames = 0;
};

// Trains the point's forest unless `trained` is already it (--windows learned: after a pilot forest).
void train_for_point(const Point& p, const std::vector<fs::path>& train_works, const RunOptions& options,
                     TrainedForest& trained) {
  json tkey = p.training_key();
  tkey["works"] = path_strings(train_works);
  if (tkey.dump() == trained.key) return;
  trained.key.clear();
  stacks::StackSet set = stacks::open_stacks(train_works, p.train_frames, true, true, p.features);
  stacks::lighten_frames(set, p.train_params.lightness);
  forest::TrainParams tp = p.train_params;
  tp.memory_mb = options.memory_mb;
  tp.progress = false;
  trained.pilot_seconds = 0;
  if (tp.windows.mode == forest::WindowSampling::Learned) {
    forest::TrainParams pilot = tp;
    pilot.windows.mode = forest::WindowSampling::Uniform;
    pilot.seed = tp.seed + 1;
    const forest::Forest pf = forest::train_forest(set.dataset, pilot);
    trained.pilot_seconds = pf.stats.seconds;
    tp.windows.learned = forest::learned_windows({pf});
  }
  trained.forest = forest::train_forest(set.dataset, tp);
  trained.key = tkey.dump();
  trained.train_frames = set.dataset.frames.size();
}

// The record's figures of the trees used: count, mean nodes, leaves and depth, nodes per tree and per
// feature, the windows chosen.
json tree_figures(const forest::Forest& used) {
  json tree_nodes = json::array();
  double nodes = 0, leaves = 0, depth = 0;
  for (const auto& t : used.stats.trees) {
    tree_nodes.push_back(t.nodes);
    nodes += t.nodes;
    leaves += t.leaves;
    depth += t.depth;
  }
  const double n_trees = std::max<double>(1, double(used.stats.trees.size()));
  json per_feature = json::object();
  for (int a = 0; a < used.num_attributes(); ++a)
    per_feature[used.attribute_name(a)] =
        a < static_cast<int>(used.stats.nodes_per_feature.size()) ? used.stats.nodes_per_feature[std::size_t(a)] : 0;
  return {{"trees", used.trees.size()},
          {"nodes_per_tree", nodes / n_trees},
          {"leaves_per_tree", leaves / n_trees},
          {"depth_per_tree", depth / n_trees},
          {"tree_nodes", tree_nodes},
          {"nodes_per_feature", per_feature},
          {"windows", forest::histograms_to_json(used.stats.windows)}};
}

// Evaluates the point with the trained forest; its experiment.jsonl record.
json evaluate_point(const Experiment& ex, const Point& p, const std::vector<fs::path>& test_works,
                    const TrainedForest& trained) {
  const forest::Forest& forest = trained.forest;
  eval::EvalOptions eo = p.eval;
  eo.progress = false;
  eo.pictures.clear();
  const auto t_eval = std::chrono::steady_clock::now();
  const eval::EvalResult r = eval::evaluate(forest, test_works, eo);
  const double eval_seconds = seconds_since(t_eval);
  const json full = r.to_json(forest, eo, path_strings(test_works));

  forest::Forest used = eo.trees > 0 ? eval::first_trees(forest, eo.trees, "trees") : forest;
  used.compute_stats();
  json per_frame = json::array();
  for (const auto& f : r.frames) per_frame.push_back(num(f.confusion.global_accuracy()));
  const json& spread = full["accuracy_spread"];

  json rec = {{"format", kRecordFormat},
              {"version", 1},
              {"experiment", ex.name},
              {"index", p.index},
              {"point", p.json},
              {"swept", p.swept},
              {"label", p.label},
              {"global_accuracy", full["global_accuracy"]},
              {"class_average_accuracy", full["class_average_accuracy"]},
              {"mean_iou", full["mean_iou"]},
              {"boundary_tolerant_accuracy", full["boundary_tolerant_accuracy"]},
              {"accuracy_spread", spread},
              {"accuracy_variance", spread.is_object() ? json(std::pow(spread["std"].get<double>(), 2)) : json(nullptr)},
              {"per_frame_accuracy", per_frame},
              {"per_class", full["per_class"]},
              {"classes", forest.classes},
              {"confusion", full["confusion"]["counts"]},
              {"test_frames", r.frames.size()},
              {"seconds_per_frame", r.seconds_per_frame},
              {"superpixel_seconds_per_frame", r.superpixel_seconds_per_frame},
              {"eval_seconds", eval_seconds},
              {"train_seconds", forest.stats.seconds},
              {"pilot_seconds", trained.pilot_seconds},
              {"train_frames", trained.train_frames}};
  rec.update(tree_figures(used));
  return rec;
}

}  // namespace

RunReport run_experiment(const Experiment& ex, const RunOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  if (options.out.empty()) throw Error("", "--out", "name the results folder");
  const fs::path cache = options.cache.empty() ? default_cache(options.out) : options.cache;
  if (!options.look_only) {
    fs::create_directories(options.out);
    remove_stale_temporaries(options.out);  // a killed run's config.json or cache-marker temporaries
  }
  check_snapshot(ex, options.out, options.look_only);

  const fs::path jsonl = options.out / "experiment.jsonl";
  RunReport report;
  const std::vector<const Point*> todo = plan_points(ex, options, jsonl, report);
  if (todo.empty() || options.look_only) {
    report.seconds = seconds_since(t_start);
    return report;
  }

  // Data: every (sequence, front end) the remaining points need.
  WorkFolders works(ex, cache, options.progress);
  for (const Point* p : todo) {
    works.of(p->train, p->train_front_end);
    works.of(p->test, p->test_front_end);
  }

  Progress progress("run-experiment " + ex.name, static_cast<long>(todo.size()), options.progress);
  TrainedForest trained;
  for (const Point* p : todo) {
    const std::vector<fs::path> train_works = works.of(p->train, p->train_front_end);
    const std::vector<fs::path> test_works = works.of(p->test, p->test_front_end);
    train_for_point(*p, train_works, options, trained);
    const json rec = evaluate_point(ex, *p, test_works, trained);
    eval::append_jsonl(jsonl, rec);
    ++report.run;
    if (options.on_point) options.on_point(*p, rec);
    progress.tick();
  }
  progress.finish();
  report.seconds = seconds_since(t_start);
  return report;
}

}  // namespace smseg::experiments
