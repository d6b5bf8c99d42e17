// Feature extraction and evaluation from Python, with the tools' option names (extract-features,
// eval-forest) as keyword arguments; both return what the tools print or write, as dicts.
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <pybind11/stl.h>
#include <tbb/global_control.h>

#include "bindings.hpp"
#include "smseg/common/error.hpp"
#include "smseg/common/io.hpp"
#include "smseg/common/option_names.hpp"
#include "smseg/common/options.hpp"
#include "smseg/eval/evaluate.hpp"
#include "smseg/stacks/extract.hpp"

namespace smseg::python {

namespace {

/// Error naming the first keyword that is not one of `known`.
void check_keywords(const py::dict& options, const std::set<std::string>& known, const std::string& function) {
  for (const auto& item : options) {
    const auto key = py::str(item.first).cast<std::string>();
    if (!known.count(key)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw Error("", key, "is not an option of " + function + " (options: " + list + ")");
    }
  }
}

template <class T>
void take(const py::dict& options, const char* key, T& out) {
  if (options.contains(key)) out = options[key].cast<T>();
}

/// extract-features' options from keywords (their declarations, extract_options_table), and the few
/// that only the call has.
features::ExtractOptions extract_options(const py::dict& keywords) {
  const nlohmann::json j = keywords_json(keywords);
  const JsonView v(j, "", "");
  const auto& table = features::extract_options_table();
  table.check_known(v, options::kPython, {"frames", "progress", "n_jobs", "verbose"});
  features::ExtractOptions opt;
  table.read(opt, v, options::kPython);
  if (v.has("frames")) opt.frames = features::FrameRange::parse(v.str("frames"), "frames");
  if (v.has("progress")) opt.progress = v.boolean("progress");
  validate_options(table.option_names(options::kPython), [&] {
    opt.resolve();
    opt.validate();
  });
  return opt;
}

py::dict extract(const std::string& sequence_dir, const std::string& out_dir, const py::dict& options) {
  const features::ExtractOptions opt = extract_options(options);
  int n_jobs = 0;
  bool verbose = false;
  take(options, "n_jobs", n_jobs);
  take(options, "verbose", verbose);
  features::set_solver_verbose(verbose);
  std::unique_ptr<tbb::global_control> limit;
  if (n_jobs > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, n_jobs);
  const features::Sequence seq = features::load_sequence(sequence_dir);
  features::ExtractReport r;
  {
    py::gil_scoped_release unlocked;
    r = features::extract_features(seq, out_dir, opt);
  }
  py::dict d;
  d["work"] = out_dir;
  d["frames_written"] = r.frames_written;
  d["frames_skipped"] = r.frames_skipped;
  d["front_end_seconds"] = r.front_end_seconds;
  d["features_seconds_per_frame"] = r.features_seconds_per_frame;
  d["valid_points_per_frame_mean"] = r.summary.valid_points_per_frame_mean;
  d["tracks_kept"] = r.summary.filters.kept_tracks;
  return d;
}

eval::EvalOptions eval_options(const py::dict& o) {
  eval::EvalOptions opt;
  std::string frames = ":", vote = "sum", smooth = "none", superpixels;
  take(o, "test_frames", frames);
  take(o, "grid", opt.grid);
  take(o, "votes", opt.votes);
  take(o, "vote", vote);
  take(o, "trees", opt.trees);
  take(o, "tolerance", opt.tolerance);
  take(o, "seed", opt.seed);
  take(o, "smooth", smooth);
  take(o, "lambda_", opt.smooth.lambda);
  take(o, "progress", opt.progress);
  if (o.contains("superpixels")) superpixels = py::str(o["superpixels"]).cast<std::string>();
  opt.frames = features::FrameRange::parse(frames, "test_frames");
  if (!superpixels.empty()) opt.superpixels = eval::superpixels_from_string(superpixels, "superpixels");
  opt.vote = eval::vote_rule_from_string(vote, "vote");
  opt.smooth.method = eval::smooth_method_from_string(smooth, "smooth");
  return opt;
}

py::object evaluate(const std::string& forest_file, const std::vector<std::string>& works, const py::dict& options) {
  check_keywords(options, {"test_frames", "grid", "superpixels", "votes", "vote", "trees", "tolerance", "seed", "smooth",
                           "lambda_", "out", "pictures", "progress", "n_jobs"},
                 "evaluate");
  eval::EvalOptions opt = eval_options(options);
  std::string out;
  bool pictures = false;
  int n_jobs = 0;
  take(options, "out", out);
  take(options, "pictures", pictures);
  take(options, "n_jobs", n_jobs);
  if (pictures && out.empty()) throw Error("", "pictures", "needs out (the pictures go to out/frames)");
  if (pictures) opt.pictures = fs::path(out) / "frames";
  opt.validate();
  std::unique_ptr<tbb::global_control> limit;
  if (n_jobs > 0) {
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, n_jobs);
    cv::setNumThreads(n_jobs);
  }
  const forest::Forest f = forest::load_forest(forest_file);
  if (opt.trees > static_cast<int>(f.trees.size()))
    throw Error(forest_file, "trees", std::to_string(opt.trees) + " trees asked, the forest has " + std::to_string(f.trees.size()));
  nlohmann::json results;
  {
    py::gil_scoped_release unlocked;
    const eval::EvalResult r = eval::evaluate(f, std::vector<fs::path>(works.begin(), works.end()), opt);
    results = r.to_json(f, opt, works);
  }
  if (!out.empty()) write_json_atomic(fs::path(out) / "results.json", results);
  return to_python(results);
}

}  // namespace

void bind_pipeline(py::module_& m) {
  m.def("extract_features", &extract, py::arg("sequence_dir"), py::arg("out_dir"), py::arg("options"));
  m.def("evaluate", &evaluate, py::arg("forest"), py::arg("works"), py::arg("options"));
}

}  // namespace smseg::python
