#pragma once
// The inverse model: the feedforward u_d(t) and the motion q_d(t) that make y = h(q) follow a
// desired y_d(t) (paper Sect. 5), by the method that fits the problem's class
// (solvers/method_choice.h), written at the method's own points or on a controller's sample
// grid from the method's continuous extension (solvers/motion_extension.h).
#include <Eigen/Dense>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "analysis/classification.h"
#include "base/vocabulary.h"
#include "modeling/model.h"
#include "solvers/feedforward_solution.h"
#include "solvers/servo_constraint_problem.h"
#include "solvers/solve_settings.h"
#include "trajectories/trajectory.h"

namespace servokit {

struct InverseModelOptions {
  // kAuto takes the class's recommended method when it fits, else the next that does
  // (MethodChooser::Choose).
  SolverMethod method = SolverMethod::kAuto;
  // Unstable zero dynamics make every forward integration diverge (paper Sect. 5.3), so the
  // forward methods refuse them unless forced. Forcing anything else is an error.
  bool force = false;
  // The span [t_start, t_end]. Unset t_start: the trajectory's first time, or for stable
  // inversion the start of the window it needs (its pre-actuation, non-causal). t_end must be
  // set, and not before the motion ends (the trajectory's last time).
  std::optional<double> t_start;
  double t_end = std::numeric_limits<double>::quiet_NaN();
  // Euler backward's fixed step, the algebraic inverse's sample spacing (methods that use
  // neither refuse it); unset: SettingsOf(method).default_step.
  std::optional<double> step;
  // Relative and absolute tolerance of the methods that take them; unset: the method's
  // default (SettingsOf). Ranges: CheckTolerances.
  std::optional<double> rtol;
  std::optional<double> atol;
  // Rows at t_start + k sample_time over exactly [t_start, t_end] (which it must divide), from
  // the method's continuous extension. Unset: the method's own points (accepted steps, the
  // collocation mesh, the algebraic inverse's samples).
  std::optional<double> sample_time;
  // Keep the method's continuous extension (FeedforwardSolution::extension), which the sample
  // grid and the forward check read (on whenever sample_time is set). Off saves its cost where
  // only the method's own points are wanted: for Dormand-Prince about five more right-hand
  // sides per step, since ARKODE evaluates its Hermite interpolant with an extra one per call.
  bool continuous_extension = true;
  // Stable inversion: time before the motion's start and after its end that the boundary
  // value problem covers; unset: chosen from the eigenvalues and widened until the answer no
  // longer changes.
  std::optional<double> pre_actuation;
  std::optional<double> post_actuation;
  ServoProblemOptions problem;
  // Throws SettingError (or UsageError for `problem`) for a value out of range whatever the
  // method: non-finite or non-positive steps, times and tolerances.
  void Validate() const;
};

/// Solves the inverse model of `model` (with its parameters) for `trajectory`; a closed chain as
/// the open chain of both its constraint sets (solvers/closed_chain.h), with the multipliers in
/// FeedforwardSolution::multipliers. `classification`
/// is the model's class at its operating point (Classify()); model and trajectory must outlive
/// the solution's extension. Throws SettingError/UsageError for bad options (a setting out of
/// range, one the chosen method does not use, a sample time that does not divide the span),
/// MethodRefused when the asked method does not fit (naming those that do), NoSolution when no
/// consistent start exists; numerical failure along the motion is reported in summary (with
/// the time and the reason), not thrown.
FeedforwardSolution SolveInverseModel(const Model& model,
                                      const OutputTrajectory& trajectory,
                                      const Classification& classification,
                                      const InverseModelOptions& options);

/// The rows t_start + k sample_time, k = 0 .. n, with the last exactly t_end. Throws
/// SettingError when sample_time is not finite and > 0 or does not divide t_end - t_start
/// into a whole number of samples (to 1e-9 relative).
std::vector<double> SampleGrid(double t_start, double t_end, double sample_time);

}  // namespace servokit
