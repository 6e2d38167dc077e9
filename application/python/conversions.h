#pragma once
// The Python module's conversions between Python values and the API's (servokit/servokit.h):
// parameter values, vectors, optional numbers, paths, and the toolkit's words (an enum of
// base/vocabulary.h as the string the docs, the files and the command line use for it).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <complex>
#include <optional>
#include <string>
#include <vector>

#include "servokit/servokit.h"

namespace servokit::python {

namespace py = pybind11;
namespace sk = servokit::api;

/// Keyword arguments of servokit.load as parameter overrides: numbers (SI) or "5 deg" strings.
sk::ParameterValues ToParameterValues(const py::kwargs& parameters);

/// One value per output: None (unset), a number or a sequence of numbers.
std::optional<Eigen::VectorXd> ToOptionalVector(const py::object& values);

/// None (unset) or a number.
std::optional<double> ToOptionalDouble(const py::object& value);

/// os.fspath(path): a str or a path-like object as a path.
std::string ToPath(const py::object& path);

/// A complex numpy array (a copy).
py::array_t<std::complex<double>> ComplexArray(const std::vector<std::complex<double>>& values);

/// A numpy array of doubles (a copy).
py::array_t<double> DoubleArray(const std::vector<double>& values);

/// The word of a toolkit enum ("radau", "converged", "non-ideal-orthogonal").
template <typename Enum>
std::string Word(Enum value) {
  return std::string(sk::ToString(value));
}

/// The enum a word names; a word that names none is a UsageError "<option> = <word>: <rule>",
/// the message the library's option check gives (e.g. "SolveOptions::method = ode45: expected
/// auto, algebraic, ...").
template <typename Enum>
Enum FromWord(std::optional<Enum> (*from_string)(std::string_view),
              const std::string& word,
              const std::string& option,
              const std::string& rule) {
  const std::optional<Enum> value = from_string(word);
  if (!value) throw servokit::UsageError(option + " = " + word + ": " + rule);
  return *value;
}

}  // namespace servokit::python
