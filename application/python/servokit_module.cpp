// The Python module `servokit` (issue #17): servokit's C++ API (servokit/servokit.h) in Python
// words, with pybind11. Only the public API is used; this folder adds the conversions (numbers
// and "5 deg" strings to parameter values, the toolkit's words to its enums, numpy arrays,
// pandas DataFrames or numpy structured arrays) and the exceptions. The GIL is released while
// the toolkit computes.
//
//   import servokit
//   model = servokit.load("models/mass_on_car.yaml", alpha="5 deg", d=0)
//   model.analyze().zero_dynamics.eigenvalues          # array([0.+18.14j, 0.-18.14j])
//   points, eigenvalues = model.sweep({"alpha": numpy.radians([5, 10]), "d": [0, 1]})
//   result = model.solve(y0=0.5, yf=2.5, t0=0, tf=6, t_end=10)   # result.table, result.summary
//
// This file binds the calls (load, Model and its methods, generate) and the errors;
// results.cpp the result classes, tables.cpp the tables, trajectories.cpp solve's desired
// output, conversions.cpp the rest.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "application/python/conversions.h"
#include "application/python/results.h"
#include "application/python/tables.h"
#include "application/python/trajectories.h"
#include "servokit/servokit.h"

namespace servokit::python {
namespace {

using ModelClass = py::class_<sk::Model>;

// ---- errors -----------------------------------------------------------------------------------

// A new exception class servokit.<name> with `bases` (a tuple), added to the module. The
// reference is kept for the life of the process: the translator raises it at any time.
PyObject* NewException(py::module_& module, const char* name, const py::tuple& bases) {
  const std::string qualified = "servokit." + std::string(name);
  PyObject* type = PyErr_NewException(qualified.c_str(), bases.ptr(), nullptr);
  if (type == nullptr) throw py::error_already_set();
  module.add_object(name, py::reinterpret_borrow<py::object>(type));
  return type;
}

// servokit.Error and one subclass per kind, with the command line's one-line message. Each is
// also the Python exception it means (issue #34), so that `except ValueError` catches a bad
// argument or model file and `except RuntimeError` a problem without a solution.
void BindErrors(py::module_& module) {
  const py::handle exception(PyExc_Exception), value_error(PyExc_ValueError),
      runtime_error(PyExc_RuntimeError);
  static PyObject* const error = NewException(module, "Error", py::make_tuple(exception));
  static PyObject* const usage_error =
      NewException(module, "UsageError", py::make_tuple(py::handle(error), value_error));
  static PyObject* const model_error =
      NewException(module, "ModelError", py::make_tuple(py::handle(error), value_error));
  static PyObject* const no_solution =
      NewException(module, "NoSolution", py::make_tuple(py::handle(error), runtime_error));
  py::register_exception_translator([](std::exception_ptr pointer) {
    try {
      if (pointer) std::rethrow_exception(pointer);
    } catch (const servokit::Error& caught) {
      PyObject* type = error;
      switch (caught.kind()) {
        case servokit::ErrorKind::kUsage:
          type = usage_error;
          break;
        case servokit::ErrorKind::kModel:
          type = model_error;
          break;
        case servokit::ErrorKind::kNoSolution:
          type = no_solution;
          break;
        case servokit::ErrorKind::kOther:
          break;
      }
      PyErr_SetString(type, caught.what());
    }
  });
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

void BindAnalyze(ModelClass& model_class) {
  const sk::AnalyzeOptions defaults;
  model_class.def(
      "linearization",
      [](const sk::Model& model, const py::object& y0, const py::object& q0) {
        const sk::AnalyzeOptions options =
            ToAnalyzeOptions(y0, q0, sk::AnalyzeOptions{}.rank_tolerance,
                             sk::AnalyzeOptions{}.imaginary_axis_tolerance);
        sk::StateSpaceModel state_space;
        {
          py::gil_scoped_release release;
          state_space = sk::LinearizeAt(model, options);
        }
        return py::make_tuple(state_space.A, state_space.B, state_space.C, state_space.D);
      },
      py::kw_only(), py::arg("y0") = py::none(), py::arg("q0") = py::none(),
      "The linearization at the operating point (y0, q0 as analyze's) as (A, B, C, D), numpy "
      "arrays of x' = A x + B u, y = C x + D u with x = (dq, dq'), SI and unscaled: what "
      "python-control's ss(A, B, C, D) and MATLAB's ss take. A closed chain's dq is in its "
      "loops' tangent coordinates.");
  model_class.def(
      "analyze",
      [](const sk::Model& model, const py::object& y0, const py::object& q0, double rank_tolerance,
         double imaginary_axis_tolerance, bool nonlinear_structure, const std::string& eigen_solver,
         int eigenvalues, double shift, const std::string& which) {
        sk::AnalyzeOptions options =
            ToAnalyzeOptions(y0, q0, rank_tolerance, imaginary_axis_tolerance);
        options.nonlinear_structure = nonlinear_structure;
        options.eigen_solver =
            FromWord(sk::LinearEigenSolverFromString, eigen_solver, "AnalyzeOptions::eigen_solver",
                     "expected auto, dense or arpack");
        options.eigenvalues = eigenvalues;
        options.shift = shift;
        options.which = FromWord(sk::EigenvalueTargetFromString, which, "AnalyzeOptions::which",
                                 "expected nearest or rightmost");
        py::gil_scoped_release release;
        return sk::Analyze(model, options);
      },
      py::arg("y0") = py::none(), py::arg("q0") = py::none(), py::kw_only(),
      py::arg("rank_tolerance") = defaults.rank_tolerance,
      py::arg("imaginary_axis_tolerance") = defaults.imaginary_axis_tolerance,
      py::arg("nonlinear_structure") = defaults.nonlinear_structure,
      py::arg("eigen_solver") = Word(defaults.eigen_solver),
      py::arg("eigenvalues") = defaults.eigenvalues, py::arg("shift") = defaults.shift,
      py::arg("which") = Word(defaults.which),
      "Classifies the model at its operating point: the output y0 there (one value per "
      "output; default h(q = 0)) and Newton's start q0 (default 0).");
}

// ---- sweeps and thresholds --------------------------------------------------------------------

// {parameter: values}: each values an array of SI values, or a text of the grid (docs/sweep.md,
// "The grid": "0deg:90deg:91", "0:2:step=0.5", "5deg,30deg"), shown in degrees when it says deg.
// A text's warnings (a MATLAB-style a:step:b, an angle without a unit) become Python warnings.
std::vector<sk::SweepAxis> ToSweepAxes(const sk::Model& model, const py::dict& grid) {
  std::vector<sk::SweepAxis> axes;
  for (const auto& [key, values] : grid) {
    const std::string parameter = key.cast<std::string>();
    if (py::isinstance<py::str>(values)) {
      std::vector<std::string> warnings;
      axes.push_back(sk::ParseSweepAxis(model, parameter + "=" + values.cast<std::string>(), "grid",
                                        &warnings));
      for (const std::string& warning : warnings) {
        py::module_::import("warnings").attr("warn")(warning);
      }
      continue;
    }
    sk::SweepAxis axis;
    axis.parameter = parameter;
    const std::optional<Eigen::VectorXd> vector =
        ToOptionalVector(py::reinterpret_borrow<py::object>(values));
    if (vector) {
      // Numbers in the unit the model declares the parameter in (degrees stay degrees).
      for (const double value : *vector) {
        axis.values.push_back(sk::InParameterUnit(model, parameter, {value, false, false}).value);
      }
    }
    axes.push_back(std::move(axis));
  }
  return axes;
}

py::object SweepModel(const sk::Model& model,
                      const py::dict& grid,
                      int threads,
                      double rank_tolerance,
                      double imaginary_axis_tolerance,
                      const std::string& table,
                      const py::object& y0,
                      const py::object& q0,
                      const py::object& out,
                      const py::object& progress) {
  const std::vector<sk::SweepAxis> axes = ToSweepAxes(model, grid);
  sk::SweepOptions options;
  options.analysis = ToAnalyzeOptions(y0, q0, rank_tolerance, imaginary_axis_tolerance);
  options.threads = threads;
  // Ctrl-C: Python only notes the signal while the GIL is released; after each block the sweep
  // asks, and stops there, and the KeyboardInterrupt is raised here.
  bool interrupted = false;
  options.stop_requested = [&interrupted] {
    py::gil_scoped_acquire acquire;
    interrupted = interrupted || PyErr_CheckSignals() != 0;
    return interrupted;
  };
  // progress(done, total) after each block; an exception it raises stops the sweep and is
  // raised here, as Ctrl-C is.
  if (!progress.is_none()) {
    options.progress = [&progress, &interrupted](std::size_t done, std::size_t total) {
      py::gil_scoped_acquire acquire;
      PyObject* result =
          PyObject_CallFunction(progress.ptr(), "nn", Py_ssize_t(done), Py_ssize_t(total));
      if (result == nullptr) {
        interrupted = true;  // the Python error stays set, raised by error_already_set below
        return;
      }
      Py_DECREF(result);
    };
  }
  if (!out.is_none()) {
    // The tables of `servokit sweep --out` (points.csv and eigenvalues.csv).
    const std::string directory = ToPath(out);
    std::size_t written = 0;
    {
      py::gil_scoped_release release;
      written = sk::SweepToFiles(model, axes, directory, options);
    }
    if (interrupted) throw py::error_already_set();
    return py::int_(written);
  }
  UsePandas(table);  // a bad `table` before the work
  std::vector<sk::SweepPoint> points;
  {
    py::gil_scoped_release release;
    points = sk::Sweep(model, axes, options);
  }
  if (interrupted) throw py::error_already_set();
  return SweepTables(model, axes, points, table);
}

void BindSweep(ModelClass& model_class) {
  const sk::AnalyzeOptions defaults;
  model_class.def("sweep", &SweepModel, py::arg("grid"), py::kw_only(), py::arg("threads") = 0,
                  py::arg("rank_tolerance") = defaults.rank_tolerance,
                  py::arg("imaginary_axis_tolerance") = defaults.imaginary_axis_tolerance,
                  py::arg("table") = "auto", py::arg("y0") = py::none(), py::arg("q0") = py::none(),
                  py::arg("out") = py::none(), py::arg("progress") = py::none(),
                  "Classifies every point of the full grid {parameter: values (SI) or a text of "
                  "`servokit sweep --vary` such as '0deg:90deg:91'}, the first parameter varying "
                  "slowest, on `threads` threads (0: all cores, or OMP_NUM_THREADS; "
                  "at most 1024, a UsageError above). Returns (points, eigenvalues): the tables "
                  "`servokit sweep` writes as points.csv and eigenvalues.csv, as pandas DataFrames "
                  "(table='auto' when "
                  "pandas is importable, or 'pandas') or numpy structured arrays (table='numpy'; a "
                  "missing integer is -1 there). y0 and q0 set every point's operating point (as "
                  "analyze's); with out=DIR the tables are written there as points.csv and "
                  "eigenvalues.csv, as `servokit sweep --out DIR` writes them, and the number of "
                  "points is returned. progress(done, total), when given, is called after each "
                  "block of points; an exception it raises stops the sweep and is raised.");
}

// An end of a threshold range: a number in the unit the model declares the parameter in, or a
// text that may name its unit ("0.5 deg", "0.1 rad"), as `servokit threshold --vary` reads it.
sk::ValueWithUnit RangeEnd(const sk::Model& model,
                           const std::string& parameter,
                           const py::object& end,
                           const char* name) {
  sk::ValueWithUnit written;
  if (py::isinstance<py::str>(end)) {
    const std::string text = end.cast<std::string>();
    const std::optional<sk::ValueWithUnit> parsed = sk::ParseQuantity(text);
    if (!parsed) {
      throw servokit::UsageError(std::string("threshold ") + name + " = '" + text +
                                 "': not a number (use e.g. 0.5, \"30 deg\" or \"0.5 rad\")");
    }
    written = *parsed;
  } else {
    written.value = end.cast<double>();
  }
  return sk::InParameterUnit(model, parameter, written);
}

py::list ThresholdsOfModel(const sk::Model& model,
                           const std::string& parameter,
                           const py::object& low_end,
                           const py::object& high_end,
                           const std::string& event,
                           double rank_tolerance,
                           double imaginary_axis_tolerance) {
  const sk::ValueWithUnit low = RangeEnd(model, parameter, low_end, "low");
  const sk::ValueWithUnit high = RangeEnd(model, parameter, high_end, "high");
  // The command line's warning of an angle whose bare values span more than a turn.
  const std::string warning = sk::AngleSpanWarning(
      model, parameter, low.degrees || high.degrees || low.unit_written || high.unit_written,
      low.value, high.value, "threshold " + parameter);
  if (!warning.empty()) py::module_::import("warnings").attr("warn")(warning);
  sk::ThresholdQuery query;
  query.parameter = parameter;
  query.low = low.value;
  query.high = high.value;
  query.show_degrees = low.degrees || high.degrees;
  query.event = FromWord(sk::ThresholdEventFromString, event, "ThresholdQuery::event",
                         "expected stability, oscillation, realization or structure");
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
    entry["via"] =
        threshold.via.empty() ? py::object(py::none()) : py::object(py::str(threshold.via));
    if (threshold.value_deg) entry["value_deg"] = *threshold.value_deg;
    result.append(entry);
  }
  return result;
}

void BindThreshold(ModelClass& model_class) {
  const sk::AnalyzeOptions defaults;
  model_class.def(
      "threshold", &ThresholdsOfModel, py::arg("parameter"), py::arg("low"), py::arg("high"),
      py::kw_only(), py::arg("event") = Word(sk::ThresholdQuery{}.event),
      py::arg("rank_tolerance") = defaults.rank_tolerance,
      py::arg("imaginary_axis_tolerance") = defaults.imaginary_axis_tolerance,
      "Every threshold of `event` (stability, oscillation, realization or structure) in [low, "
      "high], ascending: a list of {value (SI), from, to, via, and value_deg for an angle in "
      "degrees}. low and high are numbers in the unit the model declares the parameter in "
      "(degrees for 'alpha: 5 deg'), or texts naming their unit ('0.5 deg', '0.1 rad').");
}

// ---- solves -----------------------------------------------------------------------------------

// Model.solve's arguments that say how to solve (None where not given: the method's default).
struct SolveArguments {
  double t_end = 0.0;
  std::string method;
  py::object sample_time;
  bool verify = false, force = false;
  py::object t_start, step, rtol, atol, pre_actuation, post_actuation, out;
  std::string file_format, table;
  py::object q0;
};

sk::SolveOptions ToSolveOptions(const SolveArguments& arguments) {
  const SolveArguments& a = arguments;
  sk::SolveOptions options;
  options.method = FromWord(sk::SolverMethodFromString, a.method, "SolveOptions::method",
                            "expected auto, algebraic, euler, radau, bdf, normal-form, "
                            "stable-inversion or linearized");
  options.t_end = a.t_end;
  options.sample_time = ToOptionalDouble(a.sample_time);
  options.verify = a.verify;
  options.force = a.force;
  options.t_start = ToOptionalDouble(a.t_start);
  options.step = ToOptionalDouble(a.step);
  options.rtol = ToOptionalDouble(a.rtol);
  options.atol = ToOptionalDouble(a.atol);
  options.pre_actuation = ToOptionalDouble(a.pre_actuation);
  options.post_actuation = ToOptionalDouble(a.post_actuation);
  options.q_guess = ToOptionalVector(a.q0);
  if (!a.out.is_none()) options.out_file = ToPath(a.out);
  if (!a.file_format.empty()) {
    options.file_format =
        FromWord(sk::SolveFileFormatFromString, a.file_format, "SolveOptions::file_format",
                 "expected csv, mat or modelica (or empty: from out_file)");
  }
  return options;
}

Solution SolveModel(const sk::Model& model,
                    const TrajectoryArguments& trajectory_arguments,
                    const SolveArguments& solve_arguments) {
  std::optional<PythonTrajectory> python_trajectory;
  const sk::OutputTrajectory trajectory =
      ToOutputTrajectory(model, trajectory_arguments, python_trajectory);
  const sk::SolveOptions options = ToSolveOptions(solve_arguments);
  UsePandas(solve_arguments.table);
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
  solution.table = SolveTable(model, solution.feedforward, solve_arguments.table);
  return solution;
}

constexpr const char* kSolveDoc =
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
    "name ending in .mat, else csv). `q0` is Newton's start for q at the operating point the "
    "solve is classified at (default 0; a closed chain in absolute coordinates may need one). "
    "Returns a Solution (table, summary).";

void BindSolve(ModelClass& model_class) {
  const sk::SolveOptions defaults;
  model_class.def(
      "solve",
      [](const sk::Model& model, const py::object& y0, const py::object& yf, double t0,
         const py::object& tf, const py::object& waypoints, const py::object& samples,
         const py::object& sample_tolerance, const py::object& function,
         const py::object& breakpoints, int continuous_derivatives, double t_end,
         const std::string& method, const py::object& sample_time, bool verify, bool force,
         const py::object& t_start, const py::object& step, const py::object& rtol,
         const py::object& atol, const py::object& pre_actuation, const py::object& post_actuation,
         const py::object& out, const std::string& file_format, const std::string& table,
         const py::object& q0) {
        return SolveModel(model,
                          {y0, yf, t0, tf, waypoints, samples, sample_tolerance, function,
                           breakpoints, continuous_derivatives},
                          {t_end, method, sample_time, verify, force, t_start, step, rtol, atol,
                           pre_actuation, post_actuation, out, file_format, table, q0});
      },
      py::kw_only(), py::arg("y0") = py::none(), py::arg("yf") = py::none(), py::arg("t0") = 0.0,
      py::arg("tf") = py::none(), py::arg("waypoints") = py::none(),
      py::arg("samples") = py::none(), py::arg("sample_tolerance") = py::none(),
      py::arg("function") = py::none(), py::arg("breakpoints") = py::none(),
      py::arg("continuous_derivatives") = 0, py::arg("t_end"),
      py::arg("method") = Word(defaults.method), py::arg("sample_time") = py::none(),
      py::arg("verify") = defaults.verify, py::arg("force") = defaults.force,
      py::arg("t_start") = py::none(), py::arg("step") = py::none(), py::arg("rtol") = py::none(),
      py::arg("atol") = py::none(), py::arg("pre_actuation") = py::none(),
      py::arg("post_actuation") = py::none(), py::arg("out") = py::none(),
      py::arg("format") = "",  // SolveOptions::file_format unset: from the name
      py::arg("table") = "auto", py::arg("q0") = py::none(), kSolveDoc);
}

// ---- models -----------------------------------------------------------------------------------

// The model's parameter values as overrides that give them back exactly: the shortest text of
// each SI value, named "rad" for a parameter declared in degrees (a bare number would be read
// in degrees there).
sk::ParameterValues ExactParameters(const sk::Model& model) {
  sk::ParameterValues values;
  const std::vector<std::string> units = model.parameter_display_units();
  for (std::size_t i = 0; i < model.parameter_names().size(); ++i) {
    const std::string number = sk::FormatNumber(model.parameters()(Eigen::Index(i)));
    values.emplace_back(model.parameter_names()[i], units[i] == "deg" ? number + " rad" : number);
  }
  return values;
}

// The file a model can be loaded from again (with_parameters, pickling); a model made from
// YAML text has none.
const std::string& ReloadableSource(const sk::Model& model, const std::string& what) {
  if (model.source() == "<string>") {
    throw servokit::UsageError(what + " needs a model loaded from a file (this one is from text)");
  }
  return model.source();
}

void BindModel(py::module_& module) {
  ModelClass model_class(module, "Model", "A loaded model file (servokit.load).");
  model_class.def_property_readonly("name", &sk::Model::name)
      .def_property_readonly("source", &sk::Model::source)
      .def_property_readonly("kind", [](const sk::Model& model) { return Word(model.kind()); })
      .def_property_readonly(
          "parameters",
          [](const sk::Model& model) {
            py::dict parameters;
            for (std::size_t i = 0; i < model.parameter_names().size(); ++i) {
              parameters[py::str(model.parameter_names()[i])] = model.parameters()(Eigen::Index(i));
            }
            // Read-only: an assignment would change nothing (with_parameters makes a new model).
            return py::module_::import("types").attr("MappingProxyType")(parameters);
          },
          "Parameter values in SI units, after overrides (read-only; see with_parameters).")
      .def(
          "with_parameters",
          [](const sk::Model& model, const py::kwargs& parameters) {
            sk::ParameterValues overrides = ExactParameters(model);
            for (auto& value : ToParameterValues(parameters)) overrides.push_back(std::move(value));
            const std::string& source = ReloadableSource(model, "with_parameters");
            py::gil_scoped_release release;
            return sk::Model::FromFile(source, overrides);
          },
          "A new model: this one's file and parameter values with the keyword arguments "
          "replacing some (numbers in the unit each parameter is declared in, or texts such as "
          "'5 deg').")
      .def_property_readonly("coordinates", &sk::Model::coordinate_names)
      .def_property_readonly("inputs", &sk::Model::input_names)
      .def_property_readonly("outputs", &sk::Model::output_names)
      .def_property_readonly("multipliers", &sk::Model::multiplier_names,
                             "A closed chain's multipliers lambda1, ... (one per constraint).")
      .def_property_readonly("dof", &sk::Model::dof);
  BindAnalyze(model_class);
  BindSweep(model_class);
  BindThreshold(model_class);
  BindSolve(model_class);
  model_class.def("__repr__", [](const sk::Model& model) {
    return "<servokit.Model " + model.name() + " from " + model.source() + ">";
  });
  // Pickled as its file and exact parameter values, so that multiprocessing, joblib and Dask can
  // send a model to their workers, which load it again.
  model_class.def(py::pickle(
      [](const sk::Model& model) {
        py::dict parameters;
        for (const auto& [name, text] : ExactParameters(model)) parameters[py::str(name)] = text;
        return py::make_tuple(ReloadableSource(model, "pickling"), parameters);
      },
      [](const py::tuple& state) {
        if (state.size() != 2) throw servokit::UsageError("a pickled servokit.Model is (file, {})");
        sk::ParameterValues overrides;
        for (const auto& [name, text] : state[1].cast<py::dict>()) {
          overrides.emplace_back(name.cast<std::string>(), text.cast<std::string>());
        }
        return sk::Model::FromFile(state[0].cast<std::string>(), overrides);
      }));
}

void BindLoad(py::module_& module) {
  module.def(
      "load",
      [](const py::object& source, const py::kwargs& parameters) {
        const sk::ParameterValues overrides = ToParameterValues(parameters);
        const std::string text = ToPath(source);
        // YAML text: a string with a newline, or one that starts with the model's name.
        const bool is_yaml = py::isinstance<py::str>(source) &&
                             (text.find('\n') != std::string::npos || text.rfind("name:", 0) == 0);
        py::gil_scoped_release release;
        return is_yaml ? sk::Model::FromString(text, "<string>", overrides)
                       : sk::Model::FromFile(text, overrides);
      },
      py::arg("source"),
      "Loads a model: a file path, or YAML text (a string with a newline or starting with "
      "'name:'). Keyword arguments replace parameter values: numbers in the unit each parameter "
      "is declared in (degrees for one the file gives in degrees) or strings such as '5 deg' "
      "and '0.5 rad'.");
}

// ---- large linear models ----------------------------------------------------------------------

void BindChain(py::module_& generate) {
  const sk::ChainModel defaults;
  generate.def(
      "chain",
      [](long masses, double mass, double stiffness, double damping, long input_mass,
         long output_mass, const std::string& output_weights, const py::object& out,
         const std::string& name, bool closed) {
        const std::optional<sk::ChainOutputWeights> weights =
            sk::ChainOutputWeightsFromString(output_weights);
        if (!weights) {
          throw servokit::UsageError("output_weights '" + output_weights +
                                     "': expected mass, linear or uniform");
        }
        const sk::ChainModel chain{masses,     mass,        stiffness, damping,
                                   input_mass, output_mass, *weights,  closed};
        const std::string directory = ToPath(out);
        py::gil_scoped_release release;
        return sk::Generate(chain, directory, name);
      },
      py::kw_only(), py::arg("masses") = defaults.masses, py::arg("mass") = defaults.mass,
      py::arg("stiffness") = defaults.stiffness, py::arg("damping") = defaults.damping,
      py::arg("input_mass") = defaults.input_mass, py::arg("output_mass") = defaults.output_mass,
      py::arg("output_weights") = Word(defaults.output_weights), py::arg("out"),
      py::arg("name") = "", py::arg("closed") = defaults.closed,
      "Writes a chain of masses, springs and dampers (YAML and Matrix Market files) into "
      "`out`; returns the model file's path (`servokit generate chain`). output_weights: "
      "'mass' (y = position of output_mass), 'linear' (sum of (i/N) q_i) or 'uniform' (mean "
      "position). closed: mass N joined rigidly back to mass 1 (a ring, one loop constraint).");
}

void BindBeam(py::module_& generate) {
  const sk::BeamModel defaults;
  generate.def(
      "beam",
      [](long elements, double length, double hub_inertia, double mass_per_length,
         double bending_stiffness, double damping_factor, const py::object& out,
         const std::string& name) {
        const sk::BeamModel beam{elements,          length,        hub_inertia, mass_per_length,
                                 bending_stiffness, damping_factor};
        const std::string directory = ToPath(out);
        py::gil_scoped_release release;
        return sk::Generate(beam, directory, name);
      },
      py::kw_only(), py::arg("elements") = defaults.elements, py::arg("length") = defaults.length,
      py::arg("hub_inertia") = defaults.hub_inertia,
      py::arg("mass_per_length") = defaults.mass_per_length,
      py::arg("bending_stiffness") = defaults.bending_stiffness,
      py::arg("damping_factor") = defaults.damping_factor, py::arg("out"), py::arg("name") = "",
      "Writes a hub-driven Euler-Bernoulli beam in finite elements into `out`; returns the "
      "model file's path (`servokit generate beam`).");
}

void BindGenerate(py::module_& module) {
  py::module_ generate = module.def_submodule("generate", "Large linear models.");
  BindChain(generate);
  BindBeam(generate);
  // `import servokit.generate` and `from servokit.generate import chain` work too.
  py::module_::import("sys").attr("modules")["servokit.generate"] = generate;
}

}  // namespace
}  // namespace servokit::python

PYBIND11_MODULE(servokit, module) {
  namespace python = servokit::python;
  module.doc() =
      "servokit: servo-constraint problems of underactuated multibody systems (Seifried and "
      "Blajer 2013). load() a model file, then analyze, sweep, threshold and solve.";
  module.attr("__version__") = SERVOKIT_VERSION;
  // numpy's C API, looked up now, on the importing thread. pybind11 before 2.12 (Debian 12 has
  // 2.10) looks it up on first use, in a function-local static whose initializer imports numpy:
  // that import lets the GIL go, and a second thread entering the module then waits for the
  // static's guard while it holds the GIL, forever (pybind/pybind11#4877). 8 threads making the
  // process's first solve at once hung every time when nothing had imported numpy yet.
  static_cast<void>(pybind11::dtype::of<double>());
  python::BindErrors(module);
  python::BindAnalysis(module);
  python::BindSolveSummary(module);
  python::BindSolution(module);
  python::BindModel(module);
  python::BindLoad(module);
  python::BindGenerate(module);
}
