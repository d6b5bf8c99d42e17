// The forest: trained on work folders exactly as train-forest trains it (the same open_stacks and
// train_forest calls, so the same forest file for the same inputs and seed), applied to a frame's
// arrays; and the same trainer on tabular data (tabular.hpp, as forest-peers runs it). Both models pickle
// as their forest file's text.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/stl.h>
#include <tbb/global_control.h>

#include "bindings.hpp"
#include "smseg/common/error.hpp"
#include "smseg/common/io.hpp"
#include "smseg/forest/classify.hpp"
#include "smseg/forest/tabular.hpp"
#include "smseg/forest/train.hpp"
#include "smseg/stacks/stack.hpp"

namespace smseg::python {

namespace {

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using ByteArray = py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>;

/// Worker threads for the duration of one call (0: all cores).
std::unique_ptr<tbb::global_control> limit_threads(int n_jobs) {
  if (n_jobs < 0) throw Error("", "n_jobs", "must be >= 0 (0: all cores)");
  if (n_jobs == 0) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, n_jobs);
}

/// A forest with its flattened classifier, made on first use.
struct WindowForest {
  forest::Forest forest;
  std::unique_ptr<forest::Classifier> classifier;

  const forest::Classifier& classify_with() {
    if (!classifier) classifier = std::make_unique<forest::Classifier>(forest);
    return *classifier;
  }
};

struct WindowTrainArgs {
  std::vector<std::string> works;
  std::string frames = "0:", windows = "uniform", criterion = "wehenkel-pavella", balance = "none";
  std::vector<std::string> learned_from, features;
  bool progress = false;
  int n_jobs = 0;
};

/// train-forest's steps, in its order (train/train_forest.cpp), from the estimator's parameters.
std::shared_ptr<WindowForest> fit_window_forest(const WindowTrainArgs& a, forest::TrainParams p) {
  const auto limit = limit_threads(a.n_jobs);
  p.windows.mode = forest::window_sampling_from_string(a.windows, "windows");
  p.balance = forest::balance_from_string(a.balance, "balance");
  p.score = forest::score_from_string(a.criterion, "criterion");
  if (p.windows.mode == forest::WindowSampling::Learned) {
    if (a.learned_from.empty()) throw Error("", "learned_from", "windows='learned' needs the forests to learn from");
    std::vector<forest::Forest> earlier;
    for (const auto& f : a.learned_from) earlier.push_back(forest::load_forest(f));
    p.windows.learned = forest::learned_windows(earlier);
  } else if (!a.learned_from.empty()) {
    throw Error("", "learned_from", "only with windows='learned'");
  }
  p.progress = a.progress;
  p.validate("ExtraTreesWindowClassifier");
  if (a.works.empty()) throw Error("", "stacks", "no work folder given");
  const auto range = stacks::FrameRange::parse(a.frames, "frames");
  stacks::StackSet set = stacks::open_stacks(std::vector<fs::path>(a.works.begin(), a.works.end()), range, true,
                                             true, a.features);
  stacks::lighten_frames(set, p.lightness);
  auto model = std::make_shared<WindowForest>();
  py::gil_scoped_release unlocked;
  model->forest = forest::train_forest(set.dataset, p);
  return model;
}

/// The frame's arrays as the forest's FrameData, checked against the forest: sat (F, H+1, W+1)
/// float64 C-contiguous, gray (H, W) uint8 when the forest uses textons.
forest::FrameData frame_view(const forest::Forest& f, const DoubleArray& sat, const std::optional<ByteArray>& gray) {
  const auto F = static_cast<py::ssize_t>(f.features.size());
  if (sat.ndim() != 3 || sat.shape(0) != F || sat.shape(1) != f.height + 1 || sat.shape(2) != f.width + 1)
    throw Error("stack", "sat", "expected shape (" + std::to_string(F) + ", " + std::to_string(f.height + 1) + ", " +
                                    std::to_string(f.width + 1) + ") (features, height+1, width+1) for this forest");
  forest::FrameData frame;
  frame.width = f.width;
  frame.height = f.height;
  for (py::ssize_t i = 0; i < F; ++i) frame.sats.push_back(sat.data(i, 0, 0));
  if (gray) {
    if (gray->ndim() != 2 || gray->shape(0) != f.height || gray->shape(1) != f.width)
      throw Error("stack", "gray", "expected shape (" + std::to_string(f.height) + ", " + std::to_string(f.width) + ")");
    frame.gray = gray->data();
  }
  return frame;
}

/// Labels (H, W) uint8 and summed leaf distributions (H, W, C) float32 of one frame.
py::tuple classify(WindowForest& model, const DoubleArray& sat, const std::optional<ByteArray>& gray) {
  const forest::Forest& f = model.forest;
  forest::FrameData frame = frame_view(f, sat, gray);
  std::optional<stacks::FrameStack> lightened;  // owns the mapped tables while `frame` is used
  if (f.params.lightness > 0) lightened.emplace(stacks::lighten_frame(frame, f.features, f.params.lightness, 0, "stack"));
  const forest::Classifier& c = model.classify_with();
  c.check_frame(frame);
  const auto pixels = static_cast<std::size_t>(f.width) * static_cast<std::size_t>(f.height);
  std::vector<std::uint8_t> labels(pixels);
  std::vector<float> dists(pixels * static_cast<std::size_t>(c.num_classes()));
  {
    py::gil_scoped_release unlocked;
    c.classify_frame(frame, labels, dists);
  }
  return py::make_tuple(array_from_vector(std::move(labels), {f.height, f.width}),
                        array_from_vector(std::move(dists), {f.height, f.width, c.num_classes()}));
}

/// Trees grown on rows of attribute values (tabular.hpp), held as a forest file holds them.
struct TabularForest {
  forest::Forest forest;
  std::size_t columns() const { return forest.features.size(); }
  int num_classes() const { return static_cast<int>(forest.classes.size()); }
};

std::shared_ptr<TabularForest> fit_tabular(const FloatArray& X, const ByteArray& y, int num_classes, int n_estimators, int n_min, std::uint64_t seed,
                                           const std::string& criterion, int n_jobs) {
  if (X.ndim() != 2) throw Error("X", "shape", "expected a 2-D array (samples, features)");
  if (y.ndim() != 1 || y.shape(0) != X.shape(0))
    throw Error("y", "shape", "expected one label per row of X (" + std::to_string(X.shape(0)) + ")");
  if (n_estimators < 1) throw Error("", "n_estimators", "must be >= 1");
  if (n_min < 1) throw Error("", "n_min", "must be >= 1");
  const forest::Score s = forest::score_from_string(criterion, "criterion");
  const auto limit = limit_threads(n_jobs);
  const auto columns = static_cast<std::size_t>(X.shape(1));
  std::vector<forest::Tree> trees;
  {
    py::gil_scoped_release unlocked;  // X and y stay alive (the caller holds them); the rows are read in place
    trees = forest::grow_tabular_forest({X.data(), static_cast<std::size_t>(X.size())}, columns,
                                        {y.data(), static_cast<std::size_t>(y.size())}, num_classes, n_estimators,
                                        n_min, seed, s, "X");
  }
  auto model = std::make_shared<TabularForest>();
  model->forest = forest::tabular_forest(std::move(trees), columns, num_classes, n_min, seed, s);
  return model;
}

/// Mean normalised leaf distributions per row: (rows, classes), rows summing to 1.
py::array_t<double> tabular_proba(const TabularForest& model, const FloatArray& X) {
  if (X.ndim() != 2 || static_cast<std::size_t>(X.shape(1)) != model.columns())
    throw Error("X", "shape", "expected a 2-D array with " + std::to_string(model.columns()) + " columns (as in fit)");
  const auto rows = static_cast<std::size_t>(X.shape(0));
  const auto C = static_cast<std::size_t>(model.num_classes());
  std::vector<double> out(rows * C), acc;
  const double trees = static_cast<double>(model.forest.trees.size());
  for (std::size_t r = 0; r < rows; ++r) {
    forest::tabular_posterior(model.forest.trees, X.data() + r * model.columns(), model.num_classes(), acc);
    for (std::size_t k = 0; k < C; ++k) out[r * C + k] = acc[k] / trees;
  }
  return array_from_vector(std::move(out), {static_cast<py::ssize_t>(rows), static_cast<py::ssize_t>(C)});
}

/// pickle support for a class holding a forest: its state is the forest file's text (format
/// "smseg-forest", versioned), read back with every check a forest file gets, so a pickle written by
/// another version of smseg loads or is refused in one line ("pickle: version: unsupported ...").
template <class Model>
auto pickle_as_forest_file() {
  return py::pickle([](const Model& m) { return py::make_tuple(forest::forest_to_json(m.forest).dump()); },
                    [](const py::tuple& state) {
                      if (state.size() != 1 || !py::isinstance<py::str>(state[0]))
                        throw Error("pickle", "state", "expected the forest file's text");
                      const std::string text = state[0].cast<std::string>();
                      auto model = std::make_shared<Model>();
                      model->forest = forest::forest_from_json(parse_json(text, "pickle"), "pickle");
                      return model;
                    });
}

}  // namespace

void bind_forest(py::module_& m) {
  py::class_<WindowForest, std::shared_ptr<WindowForest>>(m, "WindowForest")
      .def_static("load", [](const fs::path& path) {
        auto model = std::make_shared<WindowForest>();
        model->forest = forest::load_forest(path);
        return model;
      }, py::arg("path"))
      .def("save", [](const WindowForest& w, const fs::path& path) { forest::save_forest(w.forest, path); },
           py::arg("path"))
      .def("classify", &classify, py::arg("sat"), py::arg("gray") = py::none())
      .def_property_readonly("classes", [](const WindowForest& w) { return w.forest.classes; })
      .def_property_readonly("features", [](const WindowForest& w) { return w.forest.features; })
      .def_property_readonly("width", [](const WindowForest& w) { return w.forest.width; })
      .def_property_readonly("height", [](const WindowForest& w) { return w.forest.height; })
      .def_property_readonly("textons", [](const WindowForest& w) { return w.forest.textons; })
      .def_property_readonly("n_trees", [](const WindowForest& w) { return w.forest.trees.size(); })
      .def("to_json", [](const WindowForest& w) { return to_python(forest::forest_to_json(w.forest)); })
      .def(pickle_as_forest_file<WindowForest>());

  m.def("fit_window_forest", [](std::vector<std::string> works, std::string frames, int K, int Ks, int Kt, int M,
                                int n_min, std::uint64_t seed, std::string windows, std::vector<std::string> learned_from,
                                std::string balance, std::string criterion, bool textons, std::vector<std::string> features,
                                double lightness, int leaf_tests, int n_jobs, bool progress) {
    forest::TrainParams p;
    p.K = K, p.Ks = Ks, p.Kt = Kt, p.M = M, p.n_min = n_min, p.seed = seed, p.textons = textons;
    p.lightness = lightness, p.leaf_tests = leaf_tests;
    return fit_window_forest({std::move(works), std::move(frames), std::move(windows), std::move(criterion),
                              std::move(balance), std::move(learned_from), std::move(features), progress, n_jobs}, p);
  }, py::arg("works"), py::arg("frames"), py::arg("K"), py::arg("Ks"), py::arg("Kt"), py::arg("M"), py::arg("n_min"),
     py::arg("seed"), py::arg("windows"), py::arg("learned_from"), py::arg("balance"), py::arg("criterion"),
     py::arg("textons"), py::arg("features"), py::arg("lightness"), py::arg("leaf_tests"), py::arg("n_jobs"),
     py::arg("progress"));

  py::class_<TabularForest, std::shared_ptr<TabularForest>>(m, "TabularForest")
      .def("predict_proba", &tabular_proba, py::arg("X"))
      .def_property_readonly("n_trees", [](const TabularForest& t) { return t.forest.trees.size(); })
      .def_property_readonly("n_nodes", [](const TabularForest& t) {
        std::size_t n = 0;
        for (const auto& tree : t.forest.trees) n += tree.nodes.size();
        return n;
      })
      .def_property_readonly("n_features", &TabularForest::columns)
      .def_property_readonly("n_classes", &TabularForest::num_classes)
      .def_property_readonly("feature_importances", [](const TabularForest& t) {
        auto imp = forest::impurity_importances(t.forest.trees, t.forest.num_attributes());
        return array_from_vector(std::move(imp), {static_cast<py::ssize_t>(t.columns())});
      })
      .def("to_json", [](const TabularForest& t) { return to_python(forest::forest_to_json(t.forest)); })
      .def(pickle_as_forest_file<TabularForest>());
  m.def("fit_tabular", &fit_tabular, py::arg("X"), py::arg("y"), py::arg("num_classes"), py::arg("n_estimators"),
        py::arg("n_min"), py::arg("seed"), py::arg("criterion"), py::arg("n_jobs"));
}

}  // namespace smseg::python
