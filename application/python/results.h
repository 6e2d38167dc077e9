#pragma once
// The Python classes of the API's results: Analysis (with ZeroDynamics and OscillatoryMode),
// SolveSummary (with ActuationWindow and Verification) and Solution. Their attributes are the
// structs' fields, the toolkit's enums as their words; to_dict() builds a plain dict from the
// same fields (never from the JSON text).
#include <pybind11/pybind11.h>

#include "servokit/servokit.h"

namespace servokit::python {

namespace py = pybind11;
namespace sk = servokit::api;

/// The result of Model.solve: the feedforward as a table (the columns of `servokit solve --out`)
/// and its summary (the values `servokit solve` prints).
struct Solution {
  sk::Feedforward feedforward;
  py::object table;
};

/// OscillatoryMode, ZeroDynamics and Analysis.
void BindAnalysis(py::module_& module);

/// ActuationWindow, Verification and SolveSummary.
void BindSolveSummary(py::module_& module);

/// Solution.
void BindSolution(py::module_& module);

}  // namespace servokit::python
