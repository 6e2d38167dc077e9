#include "application/python/conversions.h"

namespace servokit::python {
namespace {

// A parameter value as the model file writes it: a number (SI) in shortest round-trip form, so
// that it reads back to the same double, or a string such as "5 deg".
std::string ParameterText(const std::string& name, const py::handle& value) {
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance<py::bool_>(value) ||
      !(py::isinstance<py::int_>(value) || py::isinstance<py::float_>(value) ||
        py::hasattr(value, "__float__"))) {
    throw servokit::UsageError("parameter " + name + " = " + py::repr(value).cast<std::string>() +
                               ": expected a number (SI units) or a string such as \"5 deg\"");
  }
  return py::repr(py::reinterpret_borrow<py::object>(value).cast<py::float_>()).cast<std::string>();
}

}  // namespace

sk::ParameterValues ToParameterValues(const py::kwargs& parameters) {
  sk::ParameterValues values;
  for (const auto& [key, value] : parameters) {
    const std::string name = key.cast<std::string>();
    values.emplace_back(name, ParameterText(name, value));
  }
  return values;
}

std::optional<Eigen::VectorXd> ToOptionalVector(const py::object& values) {
  if (values.is_none()) return std::nullopt;
  if (py::isinstance<py::str>(values)) {
    throw servokit::UsageError(py::repr(values).cast<std::string>() +
                               ": expected a number or a sequence of numbers");
  }
  if (!py::isinstance<py::sequence>(values) && !py::hasattr(values, "__array__")) {
    return Eigen::VectorXd::Constant(1, values.cast<double>());
  }
  const auto array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(values);
  if (!array || array.ndim() > 1) {
    throw servokit::UsageError(py::repr(values).cast<std::string>() +
                               ": expected a number or a sequence of numbers");
  }
  Eigen::VectorXd vector(array.size());
  for (py::ssize_t i = 0; i < array.size(); ++i) vector(i) = array.data()[i];
  return vector;
}

std::optional<double> ToOptionalDouble(const py::object& value) {
  if (value.is_none()) return std::nullopt;
  return value.cast<double>();
}

std::string ToPath(const py::object& path) {
  return py::str(py::module_::import("os").attr("fspath")(path));
}

py::array_t<std::complex<double>> ComplexArray(const std::vector<std::complex<double>>& values) {
  return py::array_t<std::complex<double>>(py::ssize_t(values.size()), values.data());
}

py::array_t<double> DoubleArray(const std::vector<double>& values) {
  return py::array_t<double>(py::ssize_t(values.size()), values.data());
}

}  // namespace servokit::python
