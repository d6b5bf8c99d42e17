// The compiled part of the Python module smseg (pybind11): thin wrappers over the stages' C++ API.
// The Python side (smseg/*.py) adds the scikit-learn-like estimators and the dict conversions.
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "smseg/common/error.hpp"

PYBIND11_MODULE(_smseg, m) {
  namespace py = pybind11;
  m.doc() = "smseg's compiled part; use the package smseg";
  // Bad input is one smseg.Error (a ValueError) whose message is the one line the tools print after
  // "<tool>: error: ". Any other C++ exception becomes a Python exception too, never a crash.
  py::register_exception<smseg::Error>(m, "Error", PyExc_ValueError);
  smseg::python::bind_data(m);
  smseg::python::bind_forest(m);
  smseg::python::bind_pipeline(m);
  smseg::python::bind_options(m);
}
