#pragma once
// Radau IIA (3 stages, order 5) with step-size control, and Euler backward (the 1-stage
// Radau IIA) with a fixed step, for linearly implicit DAEs A(t, x) x' = phi(t, x) of index up
// to 3 (Hairer & Wanner, Solving ODEs II, Sect. IV.8 and VII.8; their RADAU5). Written here
// because none of the libraries servokit uses integrates index-3 DAEs: IDA is for index 1.
//
// Euler backward on the projected servo constraints is the paper's Eqs. (61)-(64).
#include <Eigen/Dense>
#include <functional>
#include <limits>
#include <vector>

#include "integrators/dense_output.h"
#include "integrators/linearly_implicit_dae.h"
#include "integrators/solve_summary.h"

namespace servokit {

/// rtol below this asks for more digits than a double carries once x is rounded after each
/// step (RADAU5 demands rtol > 10 eps for the same reason).
inline constexpr double kRadauMinRelativeTolerance = 1e-14;

struct RadauOptions {
  // 3: Radau IIA of order 5 (stage order 3) with error estimate and step-size control.
  // 1: Euler backward, order 1, on a fixed grid of fixed_step (the paper's Eqs. 61-64).
  int stages = 3;
  // Error tolerances per component: |err_i| <= atol + rtol |x_i| (the index-k components with
  // the tolerance divided by h^(k-1); as in RADAU5 the estimate is held to a calibrated
  // 0.1 rtol^(2/3)). On the paper's flat case 4, 1e-8 gives u_d to 2.2e-4 relative in 170
  // steps (u is the index-3 component, resolved to low order) and the positions exactly.
  double rtol = 1e-8;
  double atol = 1e-10;
  // The first step; 0 lets the integrator choose (1e-3 of the interval, then controlled).
  double initial_step = 0.0;
  // Required for stages = 1 (no error estimate, so no step-size control); ignored otherwise.
  // The grid is t_start + k fixed_step; a breakpoint shortens the step that would cross it.
  // A step whose Newton iteration fails stops the run: it is never halved (see radau.cpp).
  double fixed_step = 0.0;
  // Upper bound of the step size; infinity leaves it to the error control.
  double max_step = std::numeric_limits<double>::infinity();
  // Accepted steps allowed before stopping with kTooManySteps.
  long max_steps = 1000000;
  // Simplified Newton iterations per step before the step is rejected and halved; Hairer and
  // Wanner's default for RADAU5.
  int max_newton_iterations = 7;
  // Throws UsageError naming the field, its value and the rule it breaks.
  void Validate() const;
};

/// Called at the start and after each accepted step with the time and the solution there
/// (step values, not interpolated); returning false stops the integration (kInterrupted).
using StepObserver = std::function<bool(double t, const Eigen::VectorXd& x)>;

/// Integrates A x' = phi from (t_start, x_start) to t_end. x_start must be consistent (satisfy
/// the algebraic equations and their hidden constraints); the caller computes it. Steps land
/// exactly on every breakpoint inside (t_start, t_end) (where the right-hand side is not smooth)
/// and on t_end. Never throws for numerical trouble: returns a summary whose status says why it
/// stopped and when (a failed Evaluate() stops with its `why` when halving the step does not
/// help). Throws UsageError for invalid options. `dense_output`, when given (empty, of the DAE's
/// size), receives each accepted step's collocation polynomial (Radau IIA: degree 3 through x
/// at the step's start and the three stage values; Euler backward: the straight line).
SolveSummary IntegrateRadau(LinearlyImplicitDae& dae,
                            double t_start,
                            const Eigen::VectorXd& x_start,
                            double t_end,
                            const std::vector<double>& breakpoints,
                            const RadauOptions& options,
                            const StepObserver& observer,
                            DenseOutput* dense_output = nullptr);

}  // namespace servokit
