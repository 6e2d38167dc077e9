#pragma once
// SUNDIALS integrators behind one small interface each, for the solvers of this folder:
//   - ARKODE ERKStep with the Dormand-Prince 5(4) pair (MATLAB's ode45): the normal form;
//   - CVODE BDF with a dense Newton solver (MATLAB's ode15s on ODEs): forward simulations;
//   - IDA BDF (ode15s on DAEs): the projected DAE in its index-1 form.
// Each runs in one-step mode so the observer sees every internal step, stops exactly on every
// breakpoint (where the right-hand side is not smooth) and restarts there, and never throws
// for numerical trouble: the summary says why and when it stopped.
//
// Breakpoints: only those inside (t_start, t_end) count, in any order. Between two of them the
// callbacks are evaluated strictly inside the segment (SUNDIALS' evaluations on a breakpoint
// itself are moved one ulp into the segment), so a function that jumps there is seen from the
// side being integrated; the observer sees the breakpoint once, with the function's own value
// there. IDA recomputes consistent x' and algebraic x after each breakpoint (IDACalcIC).
//
// Callbacks: a refusal (false with `why`) is recoverable: CVODE and IDA retry with a smaller
// step, and when they fail, or creep up to a time they cannot pass until the step size falls
// below round-off, the summary says "at t = <time of the refusal> s: <why>" and stop_time is
// the last time reached. ARKODE's explicit ERKStep cannot retry and stops at the first refusal.
// A non-finite result counts as a refusal. An exception thrown by a callback is caught before
// it reaches SUNDIALS' C frames and rethrown from the Integrate* call.
//
// All three throw UsageError for invalid options or inputs (IntegratorOptions::Validate, empty
// or non-finite start, t_end < t_start, mismatched sizes), before any evaluation.
#include <Eigen/Dense>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "integrators/dense_output.h"
#include "integrators/solve_summary.h"

namespace servokit {

struct IntegratorOptions {
  // Local error test per component: |err_i| <= atol + rtol |y_i|. Tight defaults, since the
  // feedforward is integrated twice more by the plant it drives (the forward check,
  // solvers/verification.h).
  double rtol = 1e-10;
  double atol = 1e-12;
  // The first step; 0 lets SUNDIALS choose.
  double initial_step = 0.0;
  // Upper bound of the step size; infinity leaves it to the error control.
  double max_step = std::numeric_limits<double>::infinity();
  // Internal steps allowed in all before stopping with kTooManySteps.
  long max_steps = 10000000;
  // Throws UsageError naming the field, its value and the rule it breaks.
  void Validate() const;
};

/// y' = g(t, y). Returns false and sets `why` (one line) when g cannot be evaluated at (t, y);
/// the integrator then stops with that reason (after trying a smaller step where SUNDIALS can).
using OdeRightHandSide = std::function<bool(
    double t, const Eigen::VectorXd& y, Eigen::VectorXd& y_dot, std::string& why)>;

/// F(t, x, x') = 0, with the same convention.
using DaeResidual = std::function<bool(double t,
                                       const Eigen::VectorXd& x,
                                       const Eigen::VectorXd& x_dot,
                                       Eigen::VectorXd& residual,
                                       std::string& why)>;

/// Called at the start and after every internal step with t, the solution and its derivative
/// there; returning false stops the integration (kInterrupted). May be empty. For the ODEs the
/// derivative is g(t, y) itself; for IDA it is x' from IDA's BDF polynomial.
using IntegratorObserver =
    std::function<bool(double t, const Eigen::VectorXd& y, const Eigen::VectorXd& y_dot)>;

/// y' = g(t, y) from (t_start, y_start) to t_end with ARKODE's explicit Dormand-Prince 5(4).
/// `dense_output`, when given (empty, of the state's size), receives every accepted step's
/// interpolant (ERKStepGetDky, CVodeGetDky, IDAGetDky) as one piece: the method's own
/// continuous extension over [t_start, where it stopped].
SolveSummary IntegrateDormandPrince(const OdeRightHandSide& rhs,
                                    double t_start,
                                    const Eigen::VectorXd& y_start,
                                    double t_end,
                                    const std::vector<double>& breakpoints,
                                    const IntegratorOptions& options,
                                    const IntegratorObserver& observer,
                                    DenseOutput* dense_output = nullptr);

/// Puts y back onto the invariant manifold its ODE keeps in exact arithmetic (a closed chain's
/// c(q) = 0 and C q' = 0), which the integrator's own errors leave: `correction` (resized by
/// the caller to y's size) such that y + correction lies on it, and, when `error` is given,
/// that local error estimate replaced by its projection. Same convention as OdeRightHandSide.
using OdeProjection = std::function<bool(double t,
                                         const Eigen::VectorXd& y,
                                         Eigen::VectorXd& correction,
                                         Eigen::VectorXd* error,
                                         std::string& why)>;

/// The same ODE with CVODE's BDF (orders 1-5), Newton with a dense difference Jacobian.
SolveSummary IntegrateBdf(const OdeRightHandSide& rhs,
                          double t_start,
                          const Eigen::VectorXd& y_start,
                          double t_end,
                          const std::vector<double>& breakpoints,
                          const IntegratorOptions& options,
                          const IntegratorObserver& observer,
                          DenseOutput* dense_output = nullptr);

/// IntegrateBdf with CVODE projecting onto the ODE's invariant manifold after every step
/// (CVodeSetProjFn: the coordinate projection method, Hairer & Wanner, Solving ODEs II,
/// Sect. VII.2, for the index-1 form of a constrained mechanical system). `y_start` must lie on
/// the manifold.
SolveSummary IntegrateProjectedBdf(const OdeRightHandSide& rhs,
                                   const OdeProjection& projection,
                                   double t_start,
                                   const Eigen::VectorXd& y_start,
                                   double t_end,
                                   const std::vector<double>& breakpoints,
                                   const IntegratorOptions& options,
                                   const IntegratorObserver& observer,
                                   DenseOutput* dense_output = nullptr);

/// F(t, x, x') = 0 of index 1 with IDA from consistent (x_start, x_dot_start), which the caller
/// computes (F(t_start, x_start, x_dot_start) = 0 to round-off). `differential[i]` says whether
/// x_i' appears in F; the algebraic components are left out of the local error test, as
/// ode15s does for index 1.
SolveSummary IntegrateIda(const DaeResidual& residual,
                          double t_start,
                          const Eigen::VectorXd& x_start,
                          const Eigen::VectorXd& x_dot_start,
                          const std::vector<bool>& differential,
                          double t_end,
                          const std::vector<double>& breakpoints,
                          const IntegratorOptions& options,
                          const IntegratorObserver& observer,
                          DenseOutput* dense_output = nullptr);

}  // namespace servokit
