#pragma once
// The desired output of Model.solve from its Python arguments: rest-to-rest (y0, yf, t0, tf),
// a waypoint file, samples (t, y), or a Python function.
#include <pybind11/pybind11.h>

#include <memory>
#include <optional>

#include "servokit/servokit.h"

namespace servokit::python {

namespace py = pybind11;
namespace sk = servokit::api;

/// function=f or [f0, f1, ...]: y_d from Python. f(t, order) gives d^order y_d / dt^order at t;
/// f_i(t) gives the i-th derivative. Each gives a number, or one number per output. It is called
/// from inside the solve, which runs without the GIL: the call takes the GIL, and an exception
/// it raises cannot pass through the integrators, so it is kept, the solve is stopped (NaN), and
/// the exception is raised when the solve returns.
class PythonTrajectory {
 public:
  PythonTrajectory(py::object function, Eigen::Index outputs);

  // The API's OutputTrajectory::function. Copies share the state, so that no copy touches a
  // Python reference count without the GIL.
  void operator()(double t, int highest, Eigen::MatrixXd& derivatives) const;

  /// Raises what the function raised, or a UsageError for what it gave wrong.
  void RaiseIfFailed() const;

 private:
  struct State;
  static Eigen::VectorXd Call(const State& state, double t, int order);

  std::shared_ptr<State> state_;
};

/// Model.solve's arguments that give the desired output (None where not given).
struct TrajectoryArguments {
  py::object y0, yf;
  double t0 = 0.0;
  py::object tf, waypoints, samples, sample_tolerance, function, breakpoints;
  int continuous_derivatives = 0;
};

/// The OutputTrajectory of `arguments` for `model`; a function's PythonTrajectory is kept in
/// `python` (to raise what it raised after the solve). Throws UsageError for arguments of two
/// kinds, or missing ones.
sk::OutputTrajectory ToOutputTrajectory(const sk::Model& model,
                                        const TrajectoryArguments& arguments,
                                        std::optional<PythonTrajectory>& python);

}  // namespace servokit::python
