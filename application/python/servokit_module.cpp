// The Python module `servokit` (issue #17): servokit's C++ API (servokit/servokit.h) in Python
// words, with pybind11. Only the public API is used; this file adds the conversions (numbers
// and "5 deg" strings to parameter values, numpy arrays, pandas DataFrames or numpy structured
// arrays) and the exceptions. The GIL is released while the toolkit computes.
//
//   import servokit
//   model = servokit.load("models/mass_on_car.yaml", alpha="5 deg", d=0)
//   model.analyze().zero_dynamics.eigenvalues          # array([0.+18.14j, 0.-18.14j])
//   points, eigenvalues = model.sweep({"alpha": numpy.radians([5, 10]), "d": [0, 1]})
//   result = model.solve(y0=0.5, yf=2.5, t0=0, tf=6, t_end=10)   # result.table, result.summary
#include <pybind11/complex.h>
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "servokit/servokit.h"

namespace py = pybind11;
namespace sk = servokit::api;

namespace {

// ---- conversions ------------------------------------------------------------------------------

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

sk::ParameterValues ToParameterValues(const py::kwargs& parameters) {
  sk::ParameterValues values;
  for (const auto& [key, value] : parameters) {
    const std::string name = key.cast<std::string>();
    values.emplace_back(name, ParameterText(name, value));
  }
  return values;
}

// One value per output: None (unset), a number or a sequence of numbers.
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

py::array_t<std::complex<double>> ComplexArray(const std::vector<std::complex<double>>& values) {
  return py::array_t<std::complex<double>>(py::ssize_t(values.size()), values.data());
}

// ---- tables -----------------------------------------------------------------------------------

// One column of a table: numbers, integers (possibly missing: an empty CSV field) or text.
struct Column {
  enum class Type { kFloat, kInteger, kText };
  std::string name;
  Type type = Type::kFloat;
  bool nullable = false;  // integers only: pandas' Int64 with <NA>, -1 in a structured array
  std::vector<double> numbers;
  std::vector<std::int64_t> integers;
  std::vector<bool> missing;
  std::vector<std::string> texts;

  static Column Of(std::string name, Type type) {
    Column column;
    column.name = std::move(name);
    column.type = type;
    return column;
  }
  static Column Float(std::string name) { return Of(std::move(name), Type::kFloat); }
  static Column Integer(std::string name, bool nullable) {
    Column column = Of(std::move(name), Type::kInteger);
    column.nullable = nullable;
    return column;
  }
  static Column Text(std::string name) { return Of(std::move(name), Type::kText); }
  void AddInteger(std::optional<std::int64_t> value) {
    integers.push_back(value.value_or(-1));
    missing.push_back(!value.has_value());
  }
  std::size_t size() const {
    return type == Type::kFloat ? numbers.size()
                                : (type == Type::kInteger ? integers.size() : texts.size());
  }
};

// "auto": pandas when it can be imported, numpy structured arrays otherwise.
bool UsePandas(const std::string& table) {
  if (table == "pandas") return true;
  if (table == "numpy") return false;
  if (table != "auto") {
    throw servokit::UsageError("table = \"" + table + "\": expected auto, pandas or numpy");
  }
  try {
    py::module_::import("pandas");
    return true;
  } catch (const py::error_already_set& error) {
    if (!error.matches(PyExc_ImportError)) throw;
    return false;
  }
}

py::object PandasColumn(const Column& column) {
  switch (column.type) {
    case Column::Type::kFloat:
      return py::array_t<double>(py::ssize_t(column.numbers.size()), column.numbers.data());
    case Column::Type::kInteger: {
      py::array_t<std::int64_t> values(py::ssize_t(column.integers.size()), column.integers.data());
      if (!column.nullable) return values;
      py::array_t<bool> mask(py::ssize_t(column.missing.size()));
      for (std::size_t i = 0; i < column.missing.size(); ++i) {
        mask.mutable_data()[i] = column.missing[i];
      }
      return py::module_::import("pandas").attr("arrays").attr("IntegerArray")(values, mask);
    }
    case Column::Type::kText:
      return py::module_::import("numpy").attr("array")(py::cast(column.texts), "object");
  }
  return py::none();
}

py::object MakeTable(const std::vector<Column>& columns, const std::string& table) {
  if (UsePandas(table)) {
    // Built by position, then named: a parameter may share its name with a column (`k`).
    py::dict data;
    py::list names;
    for (std::size_t i = 0; i < columns.size(); ++i) {
      data[py::int_(i)] = PandasColumn(columns[i]);
      names.append(columns[i].name);
    }
    py::object frame = py::module_::import("pandas").attr("DataFrame")(data);
    frame.attr("columns") = names;
    return frame;
  }
  const py::module_ numpy = py::module_::import("numpy");
  py::list fields;
  py::set seen;
  for (const Column& column : columns) {
    if (seen.contains(py::str(column.name))) {
      throw servokit::UsageError("table = \"numpy\": two columns are named " + column.name +
                                 " (a parameter and a column of the table); use pandas");
    }
    seen.add(py::str(column.name));
    std::string type = "f8";
    if (column.type == Column::Type::kInteger) type = "i8";
    if (column.type == Column::Type::kText) {
      std::size_t width = 1;
      for (const std::string& text : column.texts) width = std::max(width, text.size());
      type = "U" + std::to_string(width);
    }
    fields.append(py::make_tuple(column.name, type));
  }
  const std::size_t rows = columns.empty() ? 0 : columns.front().size();
  py::object array = numpy.attr("zeros")(rows, numpy.attr("dtype")(fields));
  for (const Column& column : columns) {
    py::object values;
    if (column.type == Column::Type::kFloat) {
      values = py::array_t<double>(py::ssize_t(rows), column.numbers.data());
    } else if (column.type == Column::Type::kInteger) {
      values = py::array_t<std::int64_t>(py::ssize_t(rows), column.integers.data());
    } else {
      values = py::cast(column.texts);
    }
    array[py::str(column.name)] = values;
  }
  return array;
}

// ---- analysis ---------------------------------------------------------------------------------

sk::AnalyzeOptions ToAnalyzeOptions(const py::object& y0,
                                    const py::object& q0,
                                    double rank_tolerance,
                                    double imaginary_axis_tolerance) {
  sk::AnalyzeOptions options;
  options.y0 = ToOptionalVector(y0);
  options.q_guess = ToOptionalVector(q0);
  options.rank_tolerance = rank_tolerance;
  options.imaginary_axis_tolerance = imaginary_axis_tolerance;
  return options;
}

py::object JsonLoads(const std::string& text) {
  return py::module_::import("json").attr("loads")(text);
}

// ---- sweeps -----------------------------------------------------------------------------------

std::vector<sk::SweepAxis> ToSweepAxes(const py::dict& grid) {
  std::vector<sk::SweepAxis> axes;
  for (const auto& [key, values] : grid) {
    sk::SweepAxis axis;
    axis.parameter = key.cast<std::string>();
    const std::optional<Eigen::VectorXd> vector =
        ToOptionalVector(py::reinterpret_borrow<py::object>(values));
    if (vector) axis.values.assign(vector->data(), vector->data() + vector->size());
    axes.push_back(std::move(axis));
  }
  return axes;
}

std::optional<std::int64_t> Determined(const sk::SweepPoint& point, int value) {
  if (!point.solved || point.internal_dynamics_order < 0) return std::nullopt;
  return value;
}

// points.csv and eigenvalues.csv of `servokit sweep`, as two tables.
py::tuple SweepTables(const sk::Model& model,
                      const std::vector<sk::SweepAxis>& axes,
                      const std::vector<sk::SweepPoint>& points,
                      const std::string& table) {
  const bool joined_degrees = model.num_outputs() != 1;  // "1;2", as the CSV writes it
  std::vector<Column> point_columns, eigenvalue_columns;
  const sk::SweepColumns names = sk::SweepTableColumns(model, axes);  // "alpha_deg" in degrees
  for (std::size_t axis = 0; axis < axes.size(); ++axis) {
    point_columns.push_back(Column::Float(names.points[axis]));
    eigenvalue_columns.push_back(Column::Float(names.eigenvalues[axis]));
  }
  Column realization = Column::Text("realization"), P_rank = Column::Integer("P_rank", true),
         relative_degree = joined_degrees ? Column::Text("relative_degree")
                                          : Column::Integer("relative_degree", true),
         differentiation_index = Column::Integer("differentiation_index", true),
         internal_order = Column::Integer("internal_dynamics_order", true),
         stability = Column::Text("stability"), max_real_part = Column::Float("max_real_part"),
         error = Column::Text("error");
  Column k = Column::Integer(names.eigenvalues[axes.size()], false), re = Column::Float("re"),
         im = Column::Float("im"), frequency = Column::Float("frequency_hz"),
         damping = Column::Float("damping_ratio");
  for (const sk::SweepPoint& point : points) {
    for (std::size_t axis = 0; axis < axes.size(); ++axis) {
      point_columns[axis].numbers.push_back(point.parameter_display_values[axis]);
    }
    realization.texts.push_back(point.realization);
    P_rank.AddInteger(point.solved ? std::optional<std::int64_t>(point.P_rank) : std::nullopt);
    const bool determined = point.solved && point.internal_dynamics_order >= 0;
    if (joined_degrees) {
      std::string joined;
      for (std::size_t i = 0; determined && i < point.relative_degree.size(); ++i) {
        joined += (i > 0 ? ";" : "") + std::to_string(point.relative_degree[i]);
      }
      relative_degree.texts.push_back(joined);
    } else {
      relative_degree.AddInteger(determined && !point.relative_degree.empty()
                                     ? std::optional<std::int64_t>(point.relative_degree[0])
                                     : std::nullopt);
    }
    differentiation_index.AddInteger(Determined(point, point.differentiation_index));
    internal_order.AddInteger(Determined(point, point.internal_dynamics_order));
    stability.texts.push_back(point.stability);
    max_real_part.numbers.push_back(point.max_real_part);
    error.texts.push_back(point.error);
    for (std::size_t i = 0; i < point.eigenvalues.size(); ++i) {
      for (std::size_t axis = 0; axis < axes.size(); ++axis) {
        eigenvalue_columns[axis].numbers.push_back(point.parameter_display_values[axis]);
      }
      k.AddInteger(std::int64_t(i));
      re.numbers.push_back(point.eigenvalues[i].real());
      im.numbers.push_back(point.eigenvalues[i].imag());
      frequency.numbers.push_back(point.eigenvalue_modes[i].frequency_hz);
      damping.numbers.push_back(point.eigenvalue_modes[i].damping_ratio);
    }
  }
  for (Column* column : {&realization, &P_rank, &relative_degree, &differentiation_index,
                         &internal_order, &stability, &max_real_part, &error}) {
    point_columns.push_back(std::move(*column));
  }
  for (Column* column : {&k, &re, &im, &frequency, &damping}) {
    eigenvalue_columns.push_back(std::move(*column));
  }
  return py::make_tuple(MakeTable(point_columns, table), MakeTable(eigenvalue_columns, table));
}

// ---- solves -----------------------------------------------------------------------------------

// The result of Model.solve: the feedforward as a table (the columns of `servokit solve --out`)
// and its summary (the object `servokit solve` prints).
struct Solution {
  sk::Feedforward feedforward;
  py::object table;
};

py::object SolveTable(const sk::Model& model,
                      const sk::Feedforward& feedforward,
                      const std::string& table) {
  std::vector<Column> columns;
  Column t = Column::Float("t");
  t.numbers = feedforward.t;
  columns.push_back(std::move(t));
  const auto add = [&](const Eigen::MatrixXd& values, const std::vector<std::string>& names,
                       const std::string& suffix) {
    for (std::size_t j = 0; j < names.size(); ++j) {
      Column column = Column::Float(names[j] + suffix);
      for (Eigen::Index i = 0; i < values.rows(); ++i) {
        column.numbers.push_back(values(i, Eigen::Index(j)));
      }
      columns.push_back(std::move(column));
    }
  };
  add(feedforward.q, model.coordinate_names(), "");
  add(feedforward.q_dot, model.coordinate_names(), "_dot");
  add(feedforward.u, model.input_names(), "");
  add(feedforward.y_d, model.output_names(), "_d");
  return MakeTable(columns, table);
}

std::optional<double> ToOptionalDouble(const py::object& value) {
  if (value.is_none()) return std::nullopt;
  return value.cast<double>();
}

// samples=(t, y): the times and, per time, one value (a 1-D y) or a row of values per output.
void SetSamples(const py::object& samples, sk::OutputTrajectory& trajectory) {
  const auto bad = [&](const std::string& problem) {
    return servokit::UsageError("solve(samples=...): " + problem);
  };
  if (!py::isinstance<py::sequence>(samples) || py::len(samples) != 2) {
    throw bad("expected a pair (t, y): the sample times and y_d at them");
  }
  using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
  const py::sequence pair = samples;
  const Array times = Array::ensure(pair[0]);
  const Array values = Array::ensure(pair[1]);
  if (!times || times.ndim() != 1) throw bad("t must be a 1-D array of numbers");
  if (!values || values.ndim() < 1 || values.ndim() > 2 || values.shape(0) != times.size()) {
    throw bad("y must have one value, or one row of values (one per output), per time: " +
              std::to_string(times.size()) + " times");
  }
  trajectory.sample_times.assign(times.data(), times.data() + times.size());
  const py::ssize_t columns = values.ndim() == 2 ? values.shape(1) : 1;
  trajectory.sample_values.resize(values.shape(0), columns);
  for (py::ssize_t i = 0; i < values.shape(0); ++i) {
    for (py::ssize_t j = 0; j < columns; ++j) {
      trajectory.sample_values(i, j) = values.data()[i * columns + j];
    }
  }
}

// function=f or [f0, f1, ...]: y_d from Python. f(t, order) gives d^order y_d / dt^order at t;
// f_i(t) gives the i-th derivative. Each gives a number, or one number per output. It is called
// from inside the solve, which runs without the GIL: the call takes the GIL, and an exception
// it raises cannot pass through the integrators, so it is kept, the solve is stopped (NaN), and
// the exception is raised when the solve returns.
class PythonTrajectory {
 public:
  PythonTrajectory(py::object function, Eigen::Index outputs) : state_(std::make_shared<State>()) {
    state_->function = std::move(function);
    state_->outputs = outputs;
    state_->sequence = !PyCallable_Check(state_->function.ptr());
    if (state_->sequence) {
      if (!py::isinstance<py::sequence>(state_->function) || py::len(state_->function) == 0) {
        throw servokit::UsageError(
            "solve(function=...): expected a callable f(t, order) or a sequence of callables "
            "[y_d, y_d', y_d'', ...]");
      }
      for (const py::handle entry : py::sequence(state_->function)) {
        if (!PyCallable_Check(entry.ptr())) {
          throw servokit::UsageError("solve(function=[...]): every entry must be callable");
        }
      }
    }
  }

  // The API's OutputTrajectory::function. Copies share the state, so that no copy touches a
  // Python reference count without the GIL.
  void operator()(double t, int highest, Eigen::MatrixXd& derivatives) const {
    py::gil_scoped_acquire gil;
    State& state = *state_;
    derivatives.resize(state.outputs, highest + 1);
    if (state.failed()) {
      derivatives.setConstant(std::nan(""));
      return;
    }
    try {
      for (int order = 0; order <= highest; ++order) {
        derivatives.col(order) = Call(state, t, order);
      }
    } catch (py::error_already_set& raised) {
      state.python_error = std::move(raised);
    } catch (const servokit::UsageError& problem) {
      state.usage_error = problem.what();
    }
    if (state.failed()) derivatives.setConstant(std::nan(""));
  }

  /// Raises what the function raised, or a UsageError for what it gave wrong.
  void RaiseIfFailed() const {
    if (state_->python_error) {
      py::error_already_set raised = std::move(*state_->python_error);
      state_->python_error.reset();
      throw raised;
    }
    if (!state_->usage_error.empty()) throw servokit::UsageError(state_->usage_error);
  }

 private:
  struct State {
    py::object function;
    Eigen::Index outputs = 1;
    bool sequence = false;
    std::optional<py::error_already_set> python_error;
    std::string usage_error;
    bool failed() const { return python_error.has_value() || !usage_error.empty(); }
  };

  static Eigen::VectorXd Call(const State& state, double t, int order) {
    py::object value;
    if (state.sequence) {
      const py::sequence functions = state.function;
      if (py::len(functions) <= std::size_t(order)) {
        throw servokit::UsageError("solve(function=[...]): the solve reads y_d up to order " +
                                   std::to_string(order) + ", but " +
                                   std::to_string(py::len(functions)) +
                                   " functions were given (y_d and its derivatives, in order)");
      }
      value = functions[std::size_t(order)](t);
    } else {
      value = state.function(t, order);
    }
    const std::optional<Eigen::VectorXd> values = ToOptionalVector(value);
    if (!values || values->size() != state.outputs || !values->allFinite()) {
      throw servokit::UsageError(
          "solve(function=...): at t = " + py::repr(py::float_(t)).cast<std::string>() +
          ", order " + std::to_string(order) + " gave " + py::repr(value).cast<std::string>() +
          ": expected " + std::to_string(state.outputs) + " finite number(s), one per output");
    }
    return *values;
  }

  std::shared_ptr<State> state_;
};

}  // namespace

PYBIND11_MODULE(servokit, module) {
  module.doc() =
      "servokit: servo-constraint problems of underactuated multibody systems (Seifried and "
      "Blajer 2013). load() a model file, then analyze, sweep, threshold and solve.";
  module.attr("__version__") = SERVOKIT_VERSION;
  // numpy's C API, looked up now, on the importing thread. pybind11 before 2.12 (Debian 12 has
  // 2.10) looks it up on first use, in a function-local static whose initializer imports numpy:
  // that import lets the GIL go, and a second thread entering the module then waits for the
  // static's guard while it holds the GIL, forever (pybind/pybind11#4877). 8 threads making the
  // process's first solve at once hung every time when nothing had imported numpy yet.
  static_cast<void>(py::dtype::of<double>());

  // Errors: servokit.Error and one subclass per kind, with the command line's one-line message.
  static py::exception<servokit::Error> error(module, "Error");
  static py::exception<servokit::UsageError> usage_error(module, "UsageError", error.ptr());
  static py::exception<servokit::ModelError> model_error(module, "ModelError", error.ptr());
  static py::exception<servokit::NoSolution> no_solution(module, "NoSolution", error.ptr());
  py::register_exception_translator([](std::exception_ptr pointer) {
    try {
      if (pointer) std::rethrow_exception(pointer);
    } catch (const servokit::Error& caught) {
      switch (caught.kind()) {
        case servokit::ErrorKind::kUsage:
          usage_error(caught.what());
          return;
        case servokit::ErrorKind::kModel:
          model_error(caught.what());
          return;
        case servokit::ErrorKind::kNoSolution:
          no_solution(caught.what());
          return;
        case servokit::ErrorKind::kOther:
          error(caught.what());
          return;
      }
    }
  });

  py::class_<sk::OscillatoryMode>(module, "OscillatoryMode",
                                  "A lightly damped or undamped mode of the zero dynamics.")
      .def_readonly("frequency_hz", &sk::OscillatoryMode::frequency_hz)
      .def_readonly("damping_ratio", &sk::OscillatoryMode::damping_ratio)
      .def("__repr__", [](const sk::OscillatoryMode& mode) {
        return "OscillatoryMode(frequency_hz=" +
               py::repr(py::float_(mode.frequency_hz)).cast<std::string>() +
               ", damping_ratio=" + py::repr(py::float_(mode.damping_ratio)).cast<std::string>() +
               ")";
      });

  py::class_<sk::ZeroDynamics>(module, "ZeroDynamics",
                               "The zero dynamics at the operating point (paper Eq. 48).")
      .def_property_readonly(
          "eigenvalues",
          [](const sk::ZeroDynamics& zero) { return ComplexArray(zero.eigenvalues); },
          "Eigenvalues (1/s) as a complex numpy array.")
      .def_readonly("stability", &sk::ZeroDynamics::stability,
                    "asymptotically-stable, unstable, critical, none or undetermined (large linear "
                    "models: the precision does not decide an eigenvalue's side)")
      .def_readonly("minimum_phase", &sk::ZeroDynamics::minimum_phase)
      .def_readonly("modes", &sk::ZeroDynamics::modes);

  py::class_<sk::Analysis>(module, "Analysis",
                           "The classification of a model at its operating point; to_dict() is "
                           "`servokit analyze --format json`.")
      .def_readonly("q", &sk::Analysis::q)
      .def_readonly("u", &sk::Analysis::u)
      .def_readonly("y", &sk::Analysis::y)
      .def_readonly("P", &sk::Analysis::P, "H M^-1 B (paper Eq. 10); empty for a linear model")
      .def_readonly("P_rank", &sk::Analysis::P_rank)
      .def_readonly("realization", &sk::Analysis::realization)
      .def_readonly("relative_degree", &sk::Analysis::relative_degree)
      .def_readonly("differentiation_index", &sk::Analysis::differentiation_index)
      .def_readonly("projected_index", &sk::Analysis::projected_index)
      .def_readonly("internal_dynamics_order", &sk::Analysis::internal_dynamics_order)
      .def_readonly("flat", &sk::Analysis::flat)
      .def_readonly("zero_dynamics", &sk::Analysis::zero_dynamics)
      .def_property_readonly(
          "eigenvalues",
          [](const sk::Analysis& analysis) {
            return ComplexArray(analysis.zero_dynamics.eigenvalues);
          },
          "zero_dynamics.eigenvalues")
      .def_property_readonly(
          "stability",
          [](const sk::Analysis& analysis) { return analysis.zero_dynamics.stability; },
          "zero_dynamics.stability")
      .def_readonly("recommended_solver", &sk::Analysis::recommended_solver)
      .def_readonly("text", &sk::Analysis::text, "`servokit analyze` (text)")
      .def_readonly("json", &sk::Analysis::json, "`servokit analyze --format json`")
      .def_readonly("markdown", &sk::Analysis::markdown, "`servokit analyze --format md`")
      .def("to_dict", [](const sk::Analysis& analysis) { return JsonLoads(analysis.json); })
      .def("__repr__", [](const sk::Analysis& analysis) {
        return "<servokit.Analysis " + analysis.realization + ", zero dynamics " +
               analysis.zero_dynamics.stability + ">";
      });

  py::class_<Solution>(module, "Solution",
                       "A solve: the feedforward as a table (t, coordinates, their _dot, inputs, "
                       "y1_d, ...) and its summary (the object `servokit solve` prints).")
      .def_readonly("table", &Solution::table)
      .def_property_readonly(
          "summary", [](const Solution& solution) { return JsonLoads(solution.feedforward.json); })
      .def_property_readonly("method",
                             [](const Solution& solution) { return solution.feedforward.method; })
      .def_property_readonly("status",
                             [](const Solution& solution) { return solution.feedforward.status; })
      .def_property_readonly("message",
                             [](const Solution& solution) { return solution.feedforward.message; })
      .def_property_readonly("usable",
                             [](const Solution& solution) { return solution.feedforward.usable; })
      .def_property_readonly("warnings",
                             [](const Solution& solution) { return solution.feedforward.warnings; })
      .def_property_readonly("notes",
                             [](const Solution& solution) { return solution.feedforward.notes; })
      .def_property_readonly("t", [](const Solution& solution) { return solution.feedforward.t; })
      .def_property_readonly("q", [](const Solution& solution) { return solution.feedforward.q; })
      .def_property_readonly("q_dot",
                             [](const Solution& solution) { return solution.feedforward.q_dot; })
      .def_property_readonly("u", [](const Solution& solution) { return solution.feedforward.u; })
      .def_property_readonly("y_d",
                             [](const Solution& solution) { return solution.feedforward.y_d; })
      .def("__repr__", [](const Solution& solution) {
        return "<servokit.Solution " + solution.feedforward.method + ", " +
               solution.feedforward.status + ", " + std::to_string(solution.feedforward.t.size()) +
               " samples>";
      });

  const sk::AnalyzeOptions analyze_defaults;
  const sk::SolveOptions solve_defaults;

  py::class_<sk::Model>(module, "Model", "A loaded model file (servokit.load).")
      .def_property_readonly("name", &sk::Model::name)
      .def_property_readonly("source", &sk::Model::source)
      .def_property_readonly("kind",
                             [](const sk::Model& model) {
                               return model.kind() == sk::ModelKind::kLinear ? "linear"
                                                                             : "multibody";
                             })
      .def_property_readonly(
          "parameters",
          [](const sk::Model& model) {
            py::dict parameters;
            for (std::size_t i = 0; i < model.parameter_names().size(); ++i) {
              parameters[py::str(model.parameter_names()[i])] = model.parameters()(Eigen::Index(i));
            }
            return parameters;
          },
          "Parameter values in SI units, after overrides.")
      .def_property_readonly("coordinates", &sk::Model::coordinate_names)
      .def_property_readonly("inputs", &sk::Model::input_names)
      .def_property_readonly("outputs", &sk::Model::output_names)
      .def_property_readonly("dof", &sk::Model::dof)
      .def(
          "analyze",
          [](const sk::Model& model, const py::object& y0, const py::object& q0,
             double rank_tolerance, double imaginary_axis_tolerance, bool nonlinear_structure,
             const std::string& eigen_solver, int eigenvalues, double shift,
             const std::string& which) {
            sk::AnalyzeOptions options =
                ToAnalyzeOptions(y0, q0, rank_tolerance, imaginary_axis_tolerance);
            options.nonlinear_structure = nonlinear_structure;
            options.eigen_solver = eigen_solver;
            options.eigenvalues = eigenvalues;
            options.shift = shift;
            options.which = which;
            py::gil_scoped_release release;
            return sk::Analyze(model, options);
          },
          py::arg("y0") = py::none(), py::arg("q0") = py::none(), py::kw_only(),
          py::arg("rank_tolerance") = analyze_defaults.rank_tolerance,
          py::arg("imaginary_axis_tolerance") = analyze_defaults.imaginary_axis_tolerance,
          py::arg("nonlinear_structure") = analyze_defaults.nonlinear_structure,
          py::arg("eigen_solver") = analyze_defaults.eigen_solver,
          py::arg("eigenvalues") = analyze_defaults.eigenvalues,
          py::arg("shift") = analyze_defaults.shift, py::arg("which") = analyze_defaults.which,
          "Classifies the model at its operating point: the output y0 there (one value per "
          "output; default h(q = 0)) and Newton's start q0 (default 0).")
      .def(
          "sweep",
          [](const sk::Model& model, const py::dict& grid, int threads, double rank_tolerance,
             double imaginary_axis_tolerance, const std::string& table) {
            const std::vector<sk::SweepAxis> axes = ToSweepAxes(grid);
            sk::SweepOptions options;
            options.analysis =
                ToAnalyzeOptions(py::none(), py::none(), rank_tolerance, imaginary_axis_tolerance);
            options.threads = threads;
            // Ctrl-C: Python only notes the signal while the GIL is released; after each block
            // the sweep asks, and stops there, and the KeyboardInterrupt is raised here.
            bool interrupted = false;
            options.stop_requested = [&interrupted] {
              py::gil_scoped_acquire acquire;
              interrupted = PyErr_CheckSignals() != 0;
              return interrupted;
            };
            UsePandas(table);  // a bad `table` before the work
            std::vector<sk::SweepPoint> points;
            {
              py::gil_scoped_release release;
              points = sk::Sweep(model, axes, options);
            }
            if (interrupted) throw py::error_already_set();
            return SweepTables(model, axes, points, table);
          },
          py::arg("grid"), py::kw_only(), py::arg("threads") = 0,
          py::arg("rank_tolerance") = analyze_defaults.rank_tolerance,
          py::arg("imaginary_axis_tolerance") = analyze_defaults.imaginary_axis_tolerance,
          py::arg("table") = "auto",
          "Classifies every point of the full grid {parameter: values (SI)}, the first "
          "parameter varying slowest, on `threads` threads (0: all cores, or OMP_NUM_THREADS; "
          "at most 1024, a UsageError above). Returns (points, eigenvalues): the tables "
          "`servokit sweep` writes as points.csv and eigenvalues.csv, as pandas DataFrames "
          "(table='auto' when "
          "pandas is importable, or 'pandas') or numpy structured arrays (table='numpy'; a "
          "missing integer is -1 there).")
      .def(
          "threshold",
          [](const sk::Model& model, const std::string& parameter, double low, double high,
             const std::string& event, double rank_tolerance, double imaginary_axis_tolerance) {
            sk::ThresholdQuery query;
            query.parameter = parameter;
            query.low = low;
            query.high = high;
            query.event = event;
            query.analysis =
                ToAnalyzeOptions(py::none(), py::none(), rank_tolerance, imaginary_axis_tolerance);
            std::vector<sk::Threshold> thresholds;
            {
              py::gil_scoped_release release;
              thresholds = sk::LocateThresholds(model, query);
            }
            py::list result;
            for (const sk::Threshold& threshold : thresholds) {
              py::dict entry;
              entry["value"] = threshold.value;
              entry["from"] = threshold.from;
              entry["to"] = threshold.to;
              entry["via"] = threshold.via.empty() ? py::object(py::none())
                                                   : py::object(py::str(threshold.via));
              if (threshold.value_deg) entry["value_deg"] = *threshold.value_deg;
              result.append(entry);
            }
            return result;
          },
          py::arg("parameter"), py::arg("low"), py::arg("high"), py::kw_only(),
          py::arg("event") = "stability",
          py::arg("rank_tolerance") = analyze_defaults.rank_tolerance,
          py::arg("imaginary_axis_tolerance") = analyze_defaults.imaginary_axis_tolerance,
          "Every threshold of `event` (stability, oscillation, realization or structure) in [low, "
          "high] "
          "(SI), ascending: a list of {value, from, to, via}.")
      .def(
          "solve",
          [](const sk::Model& model, const py::object& y0, const py::object& yf, double t0,
             const py::object& tf, const py::object& waypoints, const py::object& samples,
             const py::object& sample_tolerance, const py::object& function,
             const py::object& breakpoints, int continuous_derivatives, double t_end,
             const std::string& method, const py::object& sample_time, bool verify, bool force,
             const py::object& t_start, const py::object& step, const py::object& rtol,
             const py::object& atol, const py::object& pre_actuation,
             const py::object& post_actuation, const py::object& out,
             const std::string& file_format, const std::string& table) {
            sk::OutputTrajectory trajectory;
            const int kinds =
                int(!waypoints.is_none()) + int(!samples.is_none()) + int(!function.is_none());
            if (kinds > 1) {
              throw servokit::UsageError(
                  "solve: give one of waypoints, samples and function (or y0, yf and tf)");
            }
            if (kinds == 1 && (!y0.is_none() || !yf.is_none() || !tf.is_none())) {
              throw servokit::UsageError(
                  "solve: y0, yf and tf belong to a rest-to-rest trajectory; waypoints, samples "
                  "and function give their own");
            }
            if (samples.is_none() && !sample_tolerance.is_none()) {
              throw servokit::UsageError("solve: sample_tolerance belongs to samples");
            }
            if (function.is_none() && (!breakpoints.is_none() || continuous_derivatives != 0)) {
              throw servokit::UsageError(
                  "solve: breakpoints and continuous_derivatives belong to function");
            }
            std::optional<PythonTrajectory> python_trajectory;
            if (!waypoints.is_none()) {
              trajectory.waypoint_file =
                  py::str(py::module_::import("os").attr("fspath")(waypoints));
            } else if (!samples.is_none()) {
              SetSamples(samples, trajectory);
              if (!sample_tolerance.is_none()) {
                trajectory.sample_tolerance = sample_tolerance.cast<double>();
              }
            } else if (!function.is_none()) {
              python_trajectory.emplace(function, Eigen::Index(model.num_outputs()));
              trajectory.function = *python_trajectory;
              trajectory.function_outputs = int(model.num_outputs());
              trajectory.function_continuous_derivatives = continuous_derivatives;
              trajectory.function_breakpoints = breakpoints.is_none()
                                                    ? std::vector<double>{t0}
                                                    : breakpoints.cast<std::vector<double>>();
            } else {
              if (y0.is_none() || yf.is_none() || tf.is_none()) {
                throw servokit::UsageError(
                    "solve: a rest-to-rest trajectory needs y0, yf and tf (or give waypoints)");
              }
              trajectory.y0 = *ToOptionalVector(y0);
              trajectory.yf = *ToOptionalVector(yf);
              trajectory.t0 = t0;
              trajectory.tf = tf.cast<double>();
            }
            sk::SolveOptions options;
            options.method = method;
            options.t_end = t_end;
            options.sample_time = ToOptionalDouble(sample_time);
            options.verify = verify;
            options.force = force;
            options.t_start = ToOptionalDouble(t_start);
            options.step = ToOptionalDouble(step);
            options.rtol = ToOptionalDouble(rtol);
            options.atol = ToOptionalDouble(atol);
            options.pre_actuation = ToOptionalDouble(pre_actuation);
            options.post_actuation = ToOptionalDouble(post_actuation);
            if (!out.is_none()) {
              options.out_file = py::str(py::module_::import("os").attr("fspath")(out));
            }
            options.file_format = file_format;
            UsePandas(table);
            Solution solution;
            try {
              py::gil_scoped_release release;
              solution.feedforward = sk::Solve(model, trajectory, options);
            } catch (...) {
              // A Python function that failed stopped the solve: its error is the reason.
              if (python_trajectory) python_trajectory->RaiseIfFailed();
              throw;
            }
            if (python_trajectory) python_trajectory->RaiseIfFailed();
            solution.table = SolveTable(model, solution.feedforward, table);
            return solution;
          },
          py::kw_only(), py::arg("y0") = py::none(), py::arg("yf") = py::none(),
          py::arg("t0") = 0.0, py::arg("tf") = py::none(), py::arg("waypoints") = py::none(),
          py::arg("samples") = py::none(), py::arg("sample_tolerance") = py::none(),
          py::arg("function") = py::none(), py::arg("breakpoints") = py::none(),
          py::arg("continuous_derivatives") = 0, py::arg("t_end"),
          py::arg("method") = solve_defaults.method, py::arg("sample_time") = py::none(),
          py::arg("verify") = solve_defaults.verify, py::arg("force") = solve_defaults.force,
          py::arg("t_start") = py::none(), py::arg("step") = py::none(),
          py::arg("rtol") = py::none(), py::arg("atol") = py::none(),
          py::arg("pre_actuation") = py::none(), py::arg("post_actuation") = py::none(),
          py::arg("out") = py::none(), py::arg("format") = solve_defaults.file_format,
          py::arg("table") = "auto",
          "Solves for the feedforward up to t_end. The desired output is one of: rest-to-rest "
          "(paper Eq. 65) from y0 at t0 to yf at tf; `waypoints`, a YAML file; `samples=(t, "
          "y)`, joined by a spline of degree 2k+1 (k = max(4, the order the inverse reads)) at "
          "rest before t[0] and after t[-1], within `sample_tolerance` (default 1e-10, root mean "
          "square, relative to each output's range; 0 interpolates) of the samples on as few "
          "knots as that allows; or `function`, a callable "
          "f(t, order) giving d^order y_d/dt^order, or a list [y_d, y_d', ...] of callables "
          "f(t), with `breakpoints` (default [t0]: the solve starts at the first) and "
          "`continuous_derivatives` (0: as many as the inverse reads). `out` also writes the "
          "file of `servokit solve --out`, in `format` (csv, mat or modelica; empty: mat for a "
          "name ending in .mat, else csv). Returns a Solution (table, summary).")
      .def("__repr__", [](const sk::Model& model) {
        return "<servokit.Model " + model.name() + " from " + model.source() + ">";
      });

  module.def(
      "load",
      [](const py::object& source, const py::kwargs& parameters) {
        const sk::ParameterValues overrides = ToParameterValues(parameters);
        const std::string text = py::str(py::module_::import("os").attr("fspath")(source));
        // YAML text: a string with a newline, or one that starts with the model's name.
        const bool is_yaml = py::isinstance<py::str>(source) &&
                             (text.find('\n') != std::string::npos || text.rfind("name:", 0) == 0);
        py::gil_scoped_release release;
        return is_yaml ? sk::Model::FromString(text, "<string>", overrides)
                       : sk::Model::FromFile(text, overrides);
      },
      py::arg("source"),
      "Loads a model: a file path, or YAML text (a string with a newline or starting with "
      "'name:'). Keyword arguments replace parameter values: numbers in SI units or strings "
      "such as '5 deg'.");

  py::module_ generate = module.def_submodule("generate", "Large linear models.");
  const sk::ChainModel chain_defaults;
  const sk::BeamModel beam_defaults;
  generate.def(
      "chain",
      [](long masses, double mass, double stiffness, double damping, long input_mass,
         long output_mass, const std::string& output_weights, const py::object& out,
         const std::string& name) {
        const sk::ChainModel chain{masses,     mass,        stiffness,     damping,
                                   input_mass, output_mass, output_weights};
        const std::string directory = py::str(py::module_::import("os").attr("fspath")(out));
        py::gil_scoped_release release;
        return sk::Generate(chain, directory, name);
      },
      py::kw_only(), py::arg("masses") = chain_defaults.masses,
      py::arg("mass") = chain_defaults.mass, py::arg("stiffness") = chain_defaults.stiffness,
      py::arg("damping") = chain_defaults.damping,
      py::arg("input_mass") = chain_defaults.input_mass,
      py::arg("output_mass") = chain_defaults.output_mass,
      py::arg("output_weights") = chain_defaults.output_weights, py::arg("out"),
      py::arg("name") = "",
      "Writes a chain of masses, springs and dampers (YAML and Matrix Market files) into "
      "`out`; returns the model file's path (`servokit generate chain`). output_weights: "
      "'mass' (y = position of output_mass), 'linear' (sum of (i/N) q_i) or 'uniform' (mean "
      "position).");
  generate.def(
      "beam",
      [](long elements, double length, double hub_inertia, double mass_per_length,
         double bending_stiffness, double damping_factor, const py::object& out,
         const std::string& name) {
        const sk::BeamModel beam{elements,          length,        hub_inertia, mass_per_length,
                                 bending_stiffness, damping_factor};
        const std::string directory = py::str(py::module_::import("os").attr("fspath")(out));
        py::gil_scoped_release release;
        return sk::Generate(beam, directory, name);
      },
      py::kw_only(), py::arg("elements") = beam_defaults.elements,
      py::arg("length") = beam_defaults.length, py::arg("hub_inertia") = beam_defaults.hub_inertia,
      py::arg("mass_per_length") = beam_defaults.mass_per_length,
      py::arg("bending_stiffness") = beam_defaults.bending_stiffness,
      py::arg("damping_factor") = beam_defaults.damping_factor, py::arg("out"),
      py::arg("name") = "",
      "Writes a hub-driven Euler-Bernoulli beam in finite elements into `out`; returns the "
      "model file's path (`servokit generate beam`).");
  // `import servokit.generate` and `from servokit.generate import chain` work too.
  py::module_::import("sys").attr("modules")["servokit.generate"] = generate;
}
