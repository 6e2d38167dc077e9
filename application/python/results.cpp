#include "application/python/results.h"

#include <pybind11/complex.h>
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <complex>
#include <optional>
#include <string>

#include "application/python/conversions.h"

namespace servokit::python {
namespace {

// ---- plain values for to_dict() ---------------------------------------------------------------

py::list NumberList(const Eigen::VectorXd& values) {
  py::list list;
  for (Eigen::Index i = 0; i < values.size(); ++i) list.append(values(i));
  return list;
}

// A matrix as a list of its rows.
py::list RowLists(const Eigen::MatrixXd& values) {
  py::list rows;
  for (Eigen::Index i = 0; i < values.rows(); ++i) {
    rows.append(NumberList(values.row(i).transpose()));
  }
  return rows;
}

py::object OptionalNumber(const std::optional<double>& value) {
  return value ? py::object(py::float_(*value)) : py::object(py::none());
}

py::dict ModeDict(const sk::OscillatoryMode& mode) {
  return py::dict(py::arg("frequency_hz") = mode.frequency_hz,
                  py::arg("damping_ratio") = mode.damping_ratio);
}

// The layout of `analyze --format json`'s "zero_dynamics" (eigenvalues as {re, im}).
py::dict ZeroDynamicsDict(const sk::ZeroDynamics& zero) {
  py::list eigenvalues, modes;
  for (const std::complex<double>& eigenvalue : zero.eigenvalues) {
    eigenvalues.append(
        py::dict(py::arg("re") = eigenvalue.real(), py::arg("im") = eigenvalue.imag()));
  }
  for (const sk::OscillatoryMode& mode : zero.modes) modes.append(ModeDict(mode));
  return py::dict(py::arg("eigenvalues") = eigenvalues, py::arg("stability") = Word(zero.stability),
                  py::arg("minimum_phase") = zero.minimum_phase, py::arg("modes") = modes);
}

// The Analysis's fields under the keys (and in the layout) of `analyze --format json`, which
// also has report-only keys (the model, its parameters, P's singular values, the cross-check,
// the nonlinear structure, ...): json.loads(analysis.json) has those.
py::dict AnalysisDict(const sk::Analysis& analysis) {
  py::dict dict;
  dict["operating_point"] =
      py::dict(py::arg("q") = NumberList(analysis.q), py::arg("u") = NumberList(analysis.u),
               py::arg("y") = NumberList(analysis.y));
  if (analysis.multipliers.size() > 0) {  // a closed chain's, as the JSON has them
    dict["operating_point"]["multipliers"] = NumberList(analysis.multipliers);
  }
  dict["P"] = RowLists(analysis.P);
  dict["P_rank"] = analysis.P_rank;
  dict["realization"] = Word(analysis.realization);
  dict["relative_degree"] = analysis.relative_degree;
  dict["differentiation_index"] = analysis.differentiation_index;
  dict["projected_index"] = analysis.projected_index;
  dict["internal_dynamics_order"] = analysis.internal_dynamics_order;
  dict["flat"] = analysis.flat;
  dict["zero_dynamics"] = ZeroDynamicsDict(analysis.zero_dynamics);
  dict["recommended_solver"] = Word(analysis.recommended_solver);
  return dict;
}

py::dict WindowDict(const sk::ActuationWindow& window) {
  return py::dict(py::arg("start") = window.start, py::arg("end") = window.end,
                  py::arg("pre_actuation_start") = window.pre_actuation_start,
                  py::arg("post_actuation_end") = window.post_actuation_end,
                  py::arg("widenings") = window.widenings,
                  py::arg("boundary_value_residual") = window.boundary_value_residual,
                  py::arg("mesh_points") = window.mesh_points);
}

py::dict VerificationDict(const sk::Verification& verification) {
  py::dict dict;
  dict["passed"] = verification.passed;
  dict["max_tracking_error"] = verification.max_tracking_error;
  dict["time_of_max_error"] = verification.time_of_max_error;
  dict["max_constraint_violation"] = OptionalNumber(verification.max_constraint_violation);
  dict["solve_stopped_at"] = OptionalNumber(verification.solve_stopped_at);
  dict["segmented_tracking_error"] = OptionalNumber(verification.segmented_tracking_error);
  dict["bound"] = verification.bound;
  dict["bound_rule"] = verification.bound_rule;
  dict["segments"] = verification.segments;
  dict["status"] = Word(verification.status);
  dict["message"] = verification.message;
  dict["steps"] = verification.steps;
  dict["t"] = verification.t;
  dict["y"] = RowLists(verification.y);
  return dict;
}

// The keys the JSON object of `servokit solve` gives a field under another name or place, kept
// so that code written for the parsed JSON (summary["tolerances"]["rtol"],
// summary["pre_actuation_start"], summary["out"]) keeps working.
void AddJsonLayoutKeys(const sk::SolveSummary& summary, py::dict& dict) {
  dict["tolerances"] = py::dict(py::arg("rtol") = summary.rtol, py::arg("atol") = summary.atol,
                                py::arg("step") = OptionalNumber(summary.step));
  if (summary.window) {
    const sk::ActuationWindow& window = *summary.window;
    dict["pre_actuation_start"] = window.pre_actuation_start;
    dict["post_actuation_end"] = window.post_actuation_end;
    dict["window_widenings"] = window.widenings;
    dict["boundary_value_residual"] = window.boundary_value_residual;
    dict["mesh_points"] = window.mesh_points;
  }
  if (!summary.out_file.empty()) dict["out"] = summary.out_file;
}

// Every field of the summary but `json` (enums as words, unset optionals as None, NaN as nan),
// then the JSON layout's keys.
py::dict SolveSummaryDict(const sk::SolveSummary& summary) {
  py::dict dict;
  dict["method"] = Word(summary.method);
  dict["method_reason"] = summary.method_reason;
  dict["status"] = Word(summary.status);
  dict["message"] = summary.message;
  dict["stop_time"] = summary.stop_time;
  dict["t_start"] = summary.t_start;
  dict["t_end"] = summary.t_end;
  dict["sample_time"] = OptionalNumber(summary.sample_time);
  dict["rtol"] = summary.rtol;
  dict["atol"] = summary.atol;
  dict["step"] = OptionalNumber(summary.step);
  dict["steps"] = summary.steps;
  dict["rejected_steps"] = summary.rejected_steps;
  dict["newton_iterations"] = summary.newton_iterations;
  dict["function_evaluations"] = summary.function_evaluations;
  dict["samples"] = summary.samples;
  dict["max_servo_residual"] = summary.max_servo_residual;
  dict["window"] = summary.window ? py::object(WindowDict(*summary.window)) : py::none();
  dict["trajectory_note"] = summary.trajectory_note;
  dict["classification"] = AnalysisDict(summary.classification);
  dict["operating_point_time"] = summary.operating_point_time;
  dict["verification"] =
      summary.verification ? py::object(VerificationDict(*summary.verification)) : py::none();
  dict["warnings"] = summary.warnings;
  dict["out_file"] = summary.out_file;
  AddJsonLayoutKeys(summary, dict);
  return dict;
}

std::string Repr(double value) { return py::repr(py::float_(value)).cast<std::string>(); }

// ---- Analysis ---------------------------------------------------------------------------------

void BindZeroDynamics(py::module_& module) {
  py::class_<sk::OscillatoryMode>(module, "OscillatoryMode",
                                  "A lightly damped or undamped mode of the zero dynamics.")
      .def_readonly("frequency_hz", &sk::OscillatoryMode::frequency_hz)
      .def_readonly("damping_ratio", &sk::OscillatoryMode::damping_ratio)
      .def("__repr__", [](const sk::OscillatoryMode& mode) {
        return "OscillatoryMode(frequency_hz=" + Repr(mode.frequency_hz) +
               ", damping_ratio=" + Repr(mode.damping_ratio) + ")";
      });

  py::class_<sk::ZeroDynamics>(module, "ZeroDynamics",
                               "The zero dynamics at the operating point (paper Eq. 48).")
      .def_property_readonly(
          "eigenvalues",
          [](const sk::ZeroDynamics& zero) { return ComplexArray(zero.eigenvalues); },
          "Eigenvalues (1/s) as a complex numpy array.")
      .def_property_readonly(
          "stability", [](const sk::ZeroDynamics& zero) { return Word(zero.stability); },
          "asymptotically-stable, unstable, critical, none or undetermined (large linear "
          "models: the precision does not decide an eigenvalue's side)")
      .def_readonly("minimum_phase", &sk::ZeroDynamics::minimum_phase)
      .def_readonly("modes", &sk::ZeroDynamics::modes);
}

// ---- SolveSummary -----------------------------------------------------------------------------

void BindActuationWindow(py::module_& module) {
  py::class_<sk::ActuationWindow>(
      module, "ActuationWindow",
      "Stable inversion's window (paper Sect. 5.3): where the feedforward starts before the "
      "motion (pre-actuation) and ends after it (post-actuation).")
      .def_readonly("start", &sk::ActuationWindow::start,
                    "start of the span the boundary value problem was solved on (s)")
      .def_readonly("end", &sk::ActuationWindow::end, "end of that span (s)")
      .def_readonly("pre_actuation_start", &sk::ActuationWindow::pre_actuation_start)
      .def_readonly("post_actuation_end", &sk::ActuationWindow::post_actuation_end)
      .def_readonly("widenings", &sk::ActuationWindow::widenings,
                    "how often the window was widened to converge")
      .def_readonly("boundary_value_residual", &sk::ActuationWindow::boundary_value_residual,
                    "of the collocation solution")
      .def_readonly("mesh_points", &sk::ActuationWindow::mesh_points)
      .def("to_dict", &WindowDict, "The fields as a dict.")
      .def("__repr__", [](const sk::ActuationWindow& window) {
        return "ActuationWindow(start=" + Repr(window.start) + ", end=" + Repr(window.end) +
               ", pre_actuation_start=" + Repr(window.pre_actuation_start) +
               ", post_actuation_end=" + Repr(window.post_actuation_end) + ")";
      });
}

void BindVerification(py::module_& module) {
  using V = sk::Verification;
  py::class_<V>(module, "Verification",
                "The forward check of a solve (verify=True): u_d drives the model from the "
                "solution's start, and its output must stay within `bound` of y_d.")
      .def_readonly("passed", &V::passed)
      .def_readonly("max_tracking_error", &V::max_tracking_error)
      .def_readonly("time_of_max_error", &V::time_of_max_error, "nan when not known")
      .def_readonly("max_constraint_violation", &V::max_constraint_violation,
                    "a closed chain's largest |c(q)| along the forward runs, else None")
      .def_readonly("solve_stopped_at", &V::solve_stopped_at,
                    "where the solve stopped before t_end (the check then fails), else None")
      .def_readonly("segmented_tracking_error", &V::segmented_tracking_error,
                    "linearized on a plant the check restarts on: the restarted runs' error "
                    "beside the open-loop one that decides, else None")
      .def_readonly("bound", &V::bound)
      .def_readonly("bound_rule", &V::bound_rule,
                    "how the bound follows from the solve's tolerances")
      .def_readonly("segments", &V::segments,
                    "1: one forward run; more: restarts from the solution's state at the start "
                    "of each segment (an unstable plant)")
      .def_property_readonly(
          "status", [](const V& verification) { return Word(verification.status); },
          "how the forward runs ended: converged, or why they stopped")
      .def_readonly("message", &V::message)
      .def_readonly("steps", &V::steps)
      .def_property_readonly(
          "t", [](const V& verification) { return DoubleArray(verification.t); },
          "the forward runs' times, a numpy array (a segment's first time repeats the last)")
      .def_readonly("y", &V::y, "their output h(q), a 2-D numpy array (rows: t; columns: outputs)")
      .def("to_dict", &VerificationDict, "The fields as a dict (t and y as lists).")
      .def("__repr__", [](const V& verification) {
        return std::string("<servokit.Verification ") +
               (verification.passed ? "passed" : "failed") + ", max tracking error " +
               Repr(verification.max_tracking_error) + ", bound " + Repr(verification.bound) + ">";
      });
}

// The mapping protocol of the parsed JSON that Solution.summary was before (issue #30): the keys
// of to_dict().
void BindSummaryMapping(py::class_<sk::SolveSummary>& summary) {
  summary
      .def(
          "__getitem__",
          [](const sk::SolveSummary& values, const std::string& key) -> py::object {
            const py::dict dict = SolveSummaryDict(values);
            if (!dict.contains(key)) throw py::key_error(key);
            return dict[py::str(key)];
          },
          "to_dict()[key], as summary[\"verification\"][\"passed\"] read the parsed JSON")
      .def("__contains__",
           [](const sk::SolveSummary& values, const py::object& key) {
             return SolveSummaryDict(values).contains(key);
           })
      .def("keys",
           [](const sk::SolveSummary& values) { return SolveSummaryDict(values).attr("keys")(); })
      .def("__iter__",
           [](const sk::SolveSummary& values) { return py::iter(SolveSummaryDict(values)); });
}

}  // namespace

void BindAnalysis(py::module_& module) {
  BindZeroDynamics(module);
  using A = sk::Analysis;
  py::class_<A>(module, "Analysis",
                "The classification of a model at its operating point; `json` is `servokit "
                "analyze --format json`, to_dict() its keys that are the fields.")
      .def_readonly("q", &A::q)
      .def_readonly("u", &A::u)
      .def_readonly("y", &A::y)
      .def_readonly("multipliers", &A::multipliers,
                    "a closed chain's Lagrange multipliers (C^T lambda close its loops); empty "
                    "for an open chain")
      .def_readonly("P", &A::P, "H M^-1 B (paper Eq. 10); empty for a linear model")
      .def_readonly("P_rank", &A::P_rank)
      .def_property_readonly("realization",
                             [](const A& analysis) { return Word(analysis.realization); })
      .def_readonly("relative_degree", &A::relative_degree)
      .def_readonly("differentiation_index", &A::differentiation_index)
      .def_readonly("projected_index", &A::projected_index)
      .def_readonly("internal_dynamics_order", &A::internal_dynamics_order)
      .def_readonly("flat", &A::flat)
      .def_readonly("zero_dynamics", &A::zero_dynamics)
      .def_property_readonly(
          "eigenvalues",
          [](const A& analysis) { return ComplexArray(analysis.zero_dynamics.eigenvalues); },
          "zero_dynamics.eigenvalues")
      .def_property_readonly(
          "stability", [](const A& analysis) { return Word(analysis.zero_dynamics.stability); },
          "zero_dynamics.stability")
      .def_property_readonly("recommended_solver",
                             [](const A& analysis) { return Word(analysis.recommended_solver); })
      .def_readonly("text", &A::text, "`servokit analyze` (text)")
      .def_readonly("json", &A::json, "`servokit analyze --format json`")
      .def_readonly("markdown", &A::markdown, "`servokit analyze --format md`")
      .def("to_dict", &AnalysisDict,
           "The fields as a dict, under the keys and in the layout of `analyze --format json` "
           "(operating_point, P, P_rank, realization, ..., zero_dynamics, recommended_solver); "
           "json.loads(analysis.json) also has the report's other keys.")
      .def("__repr__", [](const A& analysis) {
        return "<servokit.Analysis " + Word(analysis.realization) + ", zero dynamics " +
               Word(analysis.zero_dynamics.stability) + ">";
      });
}

void BindSolveSummary(py::module_& module) {
  BindActuationWindow(module);
  BindVerification(module);
  using S = sk::SolveSummary;
  py::class_<S> summary(module, "SolveSummary",
                        "How a solve went: what `servokit solve` prints, as values. `json` is "
                        "the printed object; to_dict() and summary[key] the fields as a dict.");
  summary
      .def_property_readonly(
          "method", [](const S& values) { return Word(values.method); }, "the method that ran")
      .def_readonly("method_reason", &S::method_reason, "why it was chosen")
      .def_property_readonly(
          "status", [](const S& values) { return Word(values.status); },
          "converged, or why the solve stopped (verification-failed: it converged but failed "
          "its forward check)")
      .def_readonly("message", &S::message)
      .def_readonly("stop_time", &S::stop_time, "where the solver stopped (s)")
      .def_readonly("t_start", &S::t_start)
      .def_readonly("t_end", &S::t_end)
      .def_readonly("sample_time", &S::sample_time, "None: the solver's own steps")
      .def_readonly("rtol", &S::rtol, "nan where the method has none")
      .def_readonly("atol", &S::atol, "nan where the method has none")
      .def_readonly("step", &S::step, "the fixed step, None where the method has none")
      .def_readonly("steps", &S::steps)
      .def_readonly("rejected_steps", &S::rejected_steps)
      .def_readonly("newton_iterations", &S::newton_iterations)
      .def_readonly("function_evaluations", &S::function_evaluations)
      .def_readonly("samples", &S::samples, "rows of the feedforward")
      .def_readonly("max_servo_residual", &S::max_servo_residual)
      .def_readonly("window", &S::window, "an ActuationWindow (stable inversion), else None")
      .def_readonly("trajectory_note", &S::trajectory_note,
                    "how y_d was made smooth enough, when it was (else empty)")
      .def_readonly("classification", &S::classification,
                    "the Analysis at the operating point the solve started from")
      .def_readonly("operating_point_time", &S::operating_point_time,
                    "the time whose y_d that operating point holds (the motion's start)")
      .def_readonly("verification", &S::verification, "a Verification (verify=True), else None")
      .def_readonly("warnings", &S::warnings)
      .def_readonly("out_file", &S::out_file, "the feedforward's file, empty when none")
      .def_readonly("json", &S::json, "the JSON object `servokit solve` prints")
      .def("to_dict", &SolveSummaryDict,
           "The fields as a dict (json aside; classification, window and verification as "
           "dicts or None), plus the keys the printed JSON object has in another place: "
           "tolerances {rtol, atol, step}, out, and for stable inversion pre_actuation_start, "
           "post_actuation_end, window_widenings, boundary_value_residual and mesh_points.")
      .def("__repr__", [](const S& values) {
        return "<servokit.SolveSummary " + Word(values.method) + ", " + Word(values.status) + ", " +
               std::to_string(values.samples) + " samples>";
      });
  BindSummaryMapping(summary);
}

void BindSolution(py::module_& module) {
  py::class_<Solution>(module, "Solution",
                       "A solve: the feedforward as a table (t, coordinates, their _dot, inputs, "
                       "y1_d, ...) and its summary (a SolveSummary: what `servokit solve` "
                       "prints).")
      .def_readonly("table", &Solution::table)
      .def_property_readonly("summary",
                             [](const Solution& solution) { return &solution.feedforward.summary; })
      .def_property_readonly(
          "method",
          [](const Solution& solution) { return Word(solution.feedforward.summary.method); })
      .def_property_readonly(
          "status",
          [](const Solution& solution) { return Word(solution.feedforward.summary.status); })
      .def_property_readonly(
          "message", [](const Solution& solution) { return solution.feedforward.summary.message; })
      .def_property_readonly("usable",
                             [](const Solution& solution) { return solution.feedforward.usable; })
      .def_property_readonly(
          "warnings",
          [](const Solution& solution) { return solution.feedforward.summary.warnings; })
      .def_property_readonly("notes",
                             [](const Solution& solution) { return solution.feedforward.notes; })
      .def_property_readonly(
          "t", [](const Solution& solution) { return DoubleArray(solution.feedforward.t); },
          "the times, a numpy array")
      .def_property_readonly("q", [](const Solution& solution) { return solution.feedforward.q; })
      .def_property_readonly("q_dot",
                             [](const Solution& solution) { return solution.feedforward.q_dot; })
      .def_property_readonly("u", [](const Solution& solution) { return solution.feedforward.u; })
      .def_property_readonly("y_d",
                             [](const Solution& solution) { return solution.feedforward.y_d; })
      .def_property_readonly(
          "multipliers", [](const Solution& solution) { return solution.feedforward.multipliers; },
          "a closed chain's multipliers lambda_d along the motion (one column per constraint; "
          "none for an open chain)")
      .def("__repr__", [](const Solution& solution) {
        const sk::SolveSummary& summary = solution.feedforward.summary;
        return "<servokit.Solution " + Word(summary.method) + ", " + Word(summary.status) + ", " +
               std::to_string(solution.feedforward.t.size()) + " samples>";
      });
}

}  // namespace servokit::python
