#pragma once
// The Python module's tables: the columns `servokit sweep` and `servokit solve --out` write, as
// pandas DataFrames or numpy structured arrays.
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "servokit/servokit.h"

namespace servokit::python {

namespace py = pybind11;
namespace sk = servokit::api;

/// table="auto": pandas when it can be imported, numpy structured arrays otherwise; "pandas" or
/// "numpy" as named. Any other word is a UsageError (checked before the work).
bool UsePandas(const std::string& table);

/// points.csv and eigenvalues.csv of `servokit sweep`, as two tables.
py::tuple SweepTables(const sk::Model& model,
                      const std::vector<sk::SweepAxis>& axes,
                      const std::vector<sk::SweepPoint>& points,
                      const std::string& table);

/// The columns of `servokit solve --out`: t, each coordinate, each <coordinate>_dot, each input,
/// y1_d, ...
py::object SolveTable(const sk::Model& model,
                      const sk::Feedforward& feedforward,
                      const std::string& table);

}  // namespace servokit::python
