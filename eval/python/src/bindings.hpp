#pragma once
// Shared by the binding sources: what each registers, and numpy arrays over C++ memory without copies.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>  // str and os.PathLike arguments as paths
#include <pybind11/pybind11.h>

#include "smseg/common/error.hpp"

namespace smseg::python {

namespace py = pybind11;

void bind_data(py::module_& m);      // data.cpp: stacks, sequences
void bind_forest(py::module_& m);    // forest.cpp: the window forest and the tabular trainer
void bind_pipeline(py::module_& m);  // pipeline.cpp: feature extraction, evaluation
void bind_options(py::module_& m);   // options.cpp: the declared options of every surface

/// A read-only numpy array over memory that `owner` keeps alive (a memory map, a model).
template <class T>
py::array_t<T> view_array(std::vector<py::ssize_t> shape, const T* data, py::handle owner) {
  py::array_t<T> a(std::move(shape), data, owner);
  a.attr("setflags")(py::arg("write") = false);
  return a;
}

/// A numpy array that takes the vector's buffer over (no copy).
template <class T>
py::array_t<T> array_from_vector(std::vector<T>&& values, std::vector<py::ssize_t> shape) {
  auto* heap = new std::vector<T>(std::move(values));
  py::capsule owner(heap, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(std::move(shape), heap->data(), owner);
}

/// Our JSON as Python objects (dicts, lists, numbers; NaN as float('nan')).
inline py::object to_python(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

/// Keyword arguments as one JSON object, what the options tables read (options.hpp). numpy scalars
/// count as numbers and paths as strings; a value JSON cannot hold (NaN, infinity, an object) is an
/// Error naming its keyword.
inline nlohmann::json keywords_json(const py::dict& keywords) {
  const py::object dumps = py::module_::import("json").attr("dumps");
  const py::cpp_function plain([](const py::object& o) -> py::object {
    if (py::hasattr(o, "__fspath__")) return o.attr("__fspath__")();
    if (py::hasattr(o, "item")) return o.attr("item")();
    throw py::type_error("not a number, string, bool or list");
  });
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [k, v] : keywords) {
    const std::string key = py::str(k);
    try {
      j[key] = nlohmann::json::parse(dumps(v, py::arg("allow_nan") = false, py::arg("default") = plain).cast<std::string>());
    } catch (const py::error_already_set&) {
      throw Error("", key, "must be a finite number, a string, a bool or a list of them, got " +
                               py::repr(v).cast<std::string>());
    }
  }
  return j;
}

}  // namespace smseg::python
