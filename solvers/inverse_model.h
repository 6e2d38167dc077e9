#pragma once
// The inverse model: the feedforward u_d(t) and the motion q_d(t) that make y = h(q) follow a
// desired y_d(t) (paper Sect. 5), by the method that fits the problem's class, and the forward
// check of the answer.
#include <Eigen/Dense>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "analysis/classification.h"
#include "analysis/types.h"
#include "models/model.h"
#include "solvers/servo_constraint_problem.h"
#include "solvers/solve_summary.h"
#include "solvers/sundials_integrators.h"
#include "solvers/trajectory.h"

namespace servokit {

struct InverseModelOptions {
  // kAuto takes Classification::recommended_solver (flat -> algebraic, critical -> normal form,
  // stable with projected index 1 -> BDF, otherwise Radau IIA).
  SolverMethod method = SolverMethod::kAuto;
  // Unstable zero dynamics make every forward integration diverge (paper Sect. 5.3), so the
  // forward methods refuse them unless forced.
  bool force = false;
  // The time span; t_end must be set (> t_start).
  double t_start = 0.0;
  double t_end = std::numeric_limits<double>::quiet_NaN();
  // Step of Euler backward (fixed) and sample spacing of the algebraic inverse. 1 ms is the
  // paper's finest Euler step (Fig. 10).
  double step = 1e-3;
  // Error tolerances of the adaptive methods; unset takes the method's default: 1e-8 / 1e-10
  // for Radau IIA (u_d of the paper's case 4 to 1.5e-4 relative in 170 steps, 0.6 ms) and
  // 1e-10 / 1e-12 for Dormand-Prince and BDF (cheap for them, and a forward check of u_d then
  // tracks to ~1e-8).
  std::optional<double> rtol;
  std::optional<double> atol;
  ServoProblemOptions problem;
  // Stable inversion: time before the motion's start and after its end that the boundary
  // value problem covers; unset: chosen from the eigenvalues (modes decayed to rtol) and
  // widened until the answer no longer changes. rtol is the BVP's tolerance (default 1e-8).
  std::optional<double> pre_actuation, post_actuation;
  // Throws UsageError naming the field, its value and the rule it breaks.
  void Validate() const;
};

/// The answer: samples at every step (the adaptive methods' accepted steps, the fixed grid
/// otherwise; always including t_start, t_end and the trajectory's breakpoints in between).
struct FeedforwardSolution {
  SolverMethod method = SolverMethod::kAuto;  // the method that ran (never kAuto)
  std::string method_reason;                  // why that method (auto's choice, or "asked")
  SolveSummary summary;
  std::vector<double> times;
  std::vector<Eigen::VectorXd> q, q_dot, u;  // one per time: dof, dof, inputs
  double max_servo_residual = std::numeric_limits<double>::quiet_NaN();  // max |h(q) - y_d|
  // Stable inversion only: the window [window_start, window_end] of the boundary value problem,
  // where u_d departs from rest (first and last time |u_d - u_rest| > rtol max |u_d - u_rest|),
  // the largest collocation residual and the widenings of the window.
  std::optional<double> window_start, window_end, pre_actuation_start, post_actuation_end;
  std::optional<double> boundary_value_residual;
  int window_widenings = 0;
  // u_d at any t in [t_start, t_end] to drive a forward simulation: exact for the algebraic
  // inverse, otherwise the degree-5 interpolant of the samples within each smooth piece.
  std::function<Eigen::VectorXd(double)> feedforward;
};

/// Solves the inverse model of `model` (with its parameters) for `trajectory`. `classification`
/// is the model's class at its operating point (Classify()). Throws UsageError for bad options
/// and NoSolution when the asked method cannot apply (algebraic inversion of a non-flat
/// problem, BDF or the normal form with singular P, forward integration of unstable internal
/// dynamics without options.force) or no consistent start exists; numerical failure along the
/// motion is reported in summary (with the time and the reason), not thrown.
FeedforwardSolution SolveInverseModel(const Model& model,
                                      const OutputTrajectory& trajectory,
                                      const Classification& classification,
                                      const InverseModelOptions& options);

/// The outcome of driving the model with u_d.
struct Verification {
  double max_tracking_error = std::numeric_limits<double>::quiet_NaN();  // max |h(q) - y_d|
  double time_of_max_error = std::numeric_limits<double>::quiet_NaN();
  SolveSummary summary;  // of the forward simulation
};

/// Drives M q'' + f = B u_d(t) forward with CVODE BDF from (q_d, q_d') at the solution's first
/// time and reports the largest output error against `trajectory`. Throws UsageError for bad
/// options or an empty solution.
Verification VerifyFeedforward(const Model& model,
                               const OutputTrajectory& trajectory,
                               const FeedforwardSolution& solution,
                               const IntegratorOptions& options = {});

}  // namespace servokit
