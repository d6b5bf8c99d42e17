// Feature extraction and evaluation from Python, with the tools' option names (extract-features,
// eval-forest) as keyword arguments; both return what the tools print or write, as dicts.
#include <memory>
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

/// extract-features' options from keywords (their declarations, extract_options_table), and the few
/// that only the call has.
stacks::ExtractOptions extract_options(const JsonView& v) {
  const auto& table = stacks::extract_options_table();
  table.check_known(v, options::kPython, {"frames", "progress", "n_jobs", "verbose"});
  stacks::ExtractOptions opt;
  table.read(opt, v, options::kPython);
  if (v.has("frames")) opt.frames = stacks::FrameRange::parse(v.str("frames"), "frames");
  if (v.has("progress")) opt.progress = v.boolean("progress");
  validate_options(table.option_names(options::kPython), [&] {
    opt.resolve();
    opt.validate();
  });
  return opt;
}

py::dict extract(const std::string& sequence_dir, const std::string& out_dir, const py::dict& options) {
  const nlohmann::json keywords = keywords_json(options);
  const JsonView v(keywords, "", "");
  const stacks::ExtractOptions opt = extract_options(v);
  const int n_jobs = v.has("n_jobs") ? static_cast<int>(v.integer("n_jobs")) : 0;
  const bool verbose = v.has("verbose") && v.boolean("verbose");
  sfm::set_solver_verbose(verbose);
  std::unique_ptr<tbb::global_control> limit;
  if (n_jobs > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, n_jobs);
  const sequence::Sequence seq = sequence::load_sequence(sequence_dir);
  stacks::ExtractReport r;
  {
    py::gil_scoped_release unlocked;
    r = stacks::extract_features(seq, out_dir, opt);
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

/// eval-forest's options from keywords (their declarations, eval_options_table), and the few that only
/// the call has (out, pictures, n_jobs: evaluate reads them).
eval::EvalOptions eval_options(const JsonView& v) {
  const auto& table = eval::eval_options_table();
  table.check_known(v, options::kPython, {"test_frames", "out", "pictures", "progress", "n_jobs"});
  eval::EvalOptions opt;
  table.read(opt, v, options::kPython);
  if (v.has("test_frames")) opt.frames = stacks::FrameRange::parse(v.str("test_frames"), "test_frames");
  if (v.has("progress")) opt.progress = v.boolean("progress");
  validate_options(table.option_names(options::kPython), [&] { opt.validate(); });
  return opt;
}

py::object evaluate(const std::string& forest_file, const std::vector<std::string>& works, const py::dict& options) {
  const nlohmann::json keywords = keywords_json(options);
  const JsonView v(keywords, "", "");
  eval::EvalOptions opt = eval_options(v);
  const std::string out = v.has("out") ? v.str("out") : "";
  const bool pictures = v.has("pictures") && v.boolean("pictures");
  const int n_jobs = v.has("n_jobs") ? static_cast<int>(v.integer("n_jobs")) : 0;
  if (pictures && out.empty()) throw Error("", "pictures", "needs out (the pictures go to out/frames)");
  if (pictures) opt.pictures = fs::path(out) / "frames";
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
