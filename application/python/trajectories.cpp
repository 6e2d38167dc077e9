#include "application/python/trajectories.h"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "application/python/conversions.h"

namespace servokit::python {

struct PythonTrajectory::State {
  py::object function;
  Eigen::Index outputs = 1;
  bool sequence = false;
  std::optional<py::error_already_set> python_error;
  std::string usage_error;
  bool failed() const { return python_error.has_value() || !usage_error.empty(); }
};

PythonTrajectory::PythonTrajectory(py::object function, Eigen::Index outputs)
    : state_(std::make_shared<State>()) {
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

void PythonTrajectory::operator()(double t, int highest, Eigen::MatrixXd& derivatives) const {
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

void PythonTrajectory::RaiseIfFailed() const {
  if (state_->python_error) {
    py::error_already_set raised = std::move(*state_->python_error);
    state_->python_error.reset();
    throw raised;
  }
  if (!state_->usage_error.empty()) throw servokit::UsageError(state_->usage_error);
}

Eigen::VectorXd PythonTrajectory::Call(const State& state, double t, int order) {
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
        "solve(function=...): at t = " + py::repr(py::float_(t)).cast<std::string>() + ", order " +
        std::to_string(order) + " gave " + py::repr(value).cast<std::string>() + ": expected " +
        std::to_string(state.outputs) + " finite number(s), one per output");
  }
  return *values;
}

namespace {

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

// One kind of trajectory, and only its own arguments.
void CheckTrajectoryArguments(const TrajectoryArguments& a) {
  const int kinds =
      int(!a.waypoints.is_none()) + int(!a.samples.is_none()) + int(!a.function.is_none());
  if (kinds > 1) {
    throw servokit::UsageError(
        "solve: give one of waypoints, samples and function (or y0, yf and tf)");
  }
  if (kinds == 1 && (!a.y0.is_none() || !a.yf.is_none() || !a.tf.is_none())) {
    throw servokit::UsageError(
        "solve: y0, yf and tf belong to a rest-to-rest trajectory; waypoints, samples "
        "and function give their own");
  }
  if (a.samples.is_none() && !a.sample_tolerance.is_none()) {
    throw servokit::UsageError("solve: sample_tolerance belongs to samples");
  }
  if (a.function.is_none() && (!a.breakpoints.is_none() || a.continuous_derivatives != 0)) {
    throw servokit::UsageError("solve: breakpoints and continuous_derivatives belong to function");
  }
}

}  // namespace

sk::OutputTrajectory ToOutputTrajectory(const sk::Model& model,
                                        const TrajectoryArguments& arguments,
                                        std::optional<PythonTrajectory>& python) {
  CheckTrajectoryArguments(arguments);
  const TrajectoryArguments& a = arguments;
  sk::OutputTrajectory trajectory;
  if (!a.waypoints.is_none()) {
    trajectory.waypoint_file = ToPath(a.waypoints);
  } else if (!a.samples.is_none()) {
    SetSamples(a.samples, trajectory);
    if (!a.sample_tolerance.is_none()) {
      trajectory.sample_tolerance = a.sample_tolerance.cast<double>();
    }
  } else if (!a.function.is_none()) {
    python.emplace(a.function, Eigen::Index(model.num_outputs()));
    trajectory.function = *python;
    trajectory.function_outputs = int(model.num_outputs());
    trajectory.function_continuous_derivatives = a.continuous_derivatives;
    trajectory.function_breakpoints = a.breakpoints.is_none()
                                          ? std::vector<double>{a.t0}
                                          : a.breakpoints.cast<std::vector<double>>();
  } else {
    if (a.y0.is_none() || a.yf.is_none() || a.tf.is_none()) {
      throw servokit::UsageError(
          "solve: a rest-to-rest trajectory needs y0, yf and tf (or give waypoints)");
    }
    trajectory.y0 = *ToOptionalVector(a.y0);
    trajectory.yf = *ToOptionalVector(a.yf);
    trajectory.t0 = a.t0;
    trajectory.tf = a.tf.cast<double>();
  }
  return trajectory;
}

}  // namespace servokit::python
