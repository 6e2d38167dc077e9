#include "solvers/stable_inversion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include "models/errors.h"
#include "solvers/boundary_value.h"
#include "solvers/internal_dynamics.h"
#include "solvers/linear_stable_inversion.h"
#include "solvers/servo_constraint_problem.h"
#include "solvers/solver_messages.h"

namespace servokit {
namespace {

// Gauss-Lobatto points per collocation interval: order 12 at the interval ends and 8 in
// between (BoundaryValueOptions::collocation_points). The internal dynamics are smooth between
// the trajectory's breakpoints, so high order needs far fewer unknowns than bvp4c's order 4
// (measured on the rotational arm at tolerance 1e-6: 199 nodes against 1384).
constexpr int kCollocationPoints = 7;
// First mesh: intervals of at most this many time constants 1 / |lambda| of the fastest
// zero-dynamics mode (an exponential over one time constant is resolved by the degree-7
// polynomial to about 1e-6, and refinement does the rest), and at least kMinIntervalsPerPiece
// between consecutive breakpoints (the motion's polynomial).
constexpr double kTimeConstantsPerInterval = 4.0;
constexpr int kMinIntervalsPerPiece = 4;
// Bisections locating where the input departs from rest between two mesh points (2^-40 of
// their spacing: below any digit a user reads).
constexpr int kCrossingBisections = 40;

// Each widening grows the pre- and post-actuation windows by this factor.
constexpr double kWideningFactor = 1.5;

// ln(1/tolerance) / rate: the time a mode of that decay rate needs to fall to the tolerance.
double DecayTime(double rate, double tolerance) { return std::log(1.0 / tolerance) / rate; }

}  // namespace

void StableInversionOptions::Validate() const {
  if (!(tolerance > 0.0 && tolerance < 1.0)) {
    throw UsageError("StableInversionOptions::tolerance = " + FormatNumber(tolerance) +
                     ": must be in (0, 1)");
  }
  if (!(absolute_tolerance > 0.0 && std::isfinite(absolute_tolerance))) {
    throw UsageError("StableInversionOptions::absolute_tolerance = " +
                     FormatNumber(absolute_tolerance) + ": must be a finite number > 0");
  }
  for (const auto& [value, name] : {std::pair{pre_actuation, "pre_actuation"},
                                    std::pair{post_actuation, "post_actuation"}}) {
    if (value && !(*value > 0.0 && std::isfinite(*value))) {
      throw UsageError(std::string("StableInversionOptions::") + name + " = " + FormatNumber(*value) +
                       ": must be a finite number > 0");
    }
  }
  if (max_widenings < 0) {
    throw UsageError("StableInversionOptions::max_widenings = " + std::to_string(max_widenings) +
                     ": must be >= 0");
  }
}

StableInversionSolution SolveStableInversion(const Model& model,
                                             const OutputTrajectory& trajectory,
                                             const Eigen::VectorXd& start_q,
                                             const Eigen::VectorXd& end_q,
                                             const StableInversionOptions& options) {
  options.Validate();
  const LinearInternalDynamics start = LinearizeInternalDynamics(model, start_q);
  const LinearInternalDynamics end = LinearizeInternalDynamics(model, end_q);
  if (!start.internal_directions.isApprox(end.internal_directions)) {
    throw NoSolution("stable inversion: the internal coordinates chosen at the start and end "
                     "equilibria differ (H_a singular there); not supported yet");
  }
  const HyperbolicSplit start_split = SplitHyperbolic(start.state_matrix);
  const HyperbolicSplit end_split = SplitHyperbolic(end.state_matrix);

  // The slowest unstable mode at the start sets the pre-actuation, the slowest stable mode at
  // the end the post-actuation.
  double slowest_unstable = INFINITY, slowest_stable = INFINITY;
  for (const auto& value : start_split.eigenvalues) {
    if (value.real() > 0) slowest_unstable = std::min(slowest_unstable, value.real());
  }
  for (const auto& value : end_split.eigenvalues) {
    if (value.real() < 0) slowest_stable = std::min(slowest_stable, -value.real());
  }
  const std::vector<double> breakpoints = trajectory.breakpoints();
  const double t0 = breakpoints.front(), tf = breakpoints.back();
  double pre = options.pre_actuation.value_or(
      std::isfinite(slowest_unstable) ? DecayTime(slowest_unstable, options.tolerance) : 0.1 * (tf - t0));
  double post = options.post_actuation.value_or(
      std::isfinite(slowest_stable) ? DecayTime(slowest_stable, options.tolerance) : 0.1 * (tf - t0));

  // Shared with the feedforward closure returned at the end (one problem, built once).
  const auto shared_problem = std::make_shared<ServoConstraintProblem>(model, trajectory, start_q);
  ServoConstraintProblem& problem = *shared_problem;
  const Eigen::Index internal = problem.num_internal();
  const Eigen::MatrixXd& directions = problem.internal_directions();
  Eigen::VectorXd q = start_q, q_dot, u, q_ddot;
  const BvpRightHandSide rhs = [&](double t, const Eigen::VectorXd& x, Eigen::VectorXd& x_dot,
                                   std::string& why) {
    if (!problem.StateFromInternal(t, x.head(internal), x.tail(internal), q, q_dot, why) ||
        !problem.NormalForm(t, q, q_dot, u, q_ddot, why)) {
      return false;
    }
    x_dot.resize(2 * internal);
    x_dot.head(internal) = x.tail(internal);
    x_dot.tail(internal).noalias() = directions.transpose() * q_ddot;  // Eq. (25)
    return true;
  };
  const Eigen::Index stable_count = start_split.stable_basis.cols();
  BoundaryConditions conditions;
  conditions.residual = [&](const Eigen::VectorXd& at_start, const Eigen::VectorXd& at_end,
                            Eigen::VectorXd& residual) {
    residual.resize(2 * internal);
    residual.head(stable_count) = start_split.stable_left * (at_start - start.equilibrium_state);
    residual.tail(2 * internal - stable_count) =
        end_split.unstable_left * (at_end - end.equilibrium_state);
  };
  conditions.jacobians = [&](const Eigen::VectorXd&, const Eigen::VectorXd&,
                             Eigen::MatrixXd& d_start, Eigen::MatrixXd& d_end) {
    d_start = Eigen::MatrixXd::Zero(2 * internal, 2 * internal);
    d_end = Eigen::MatrixXd::Zero(2 * internal, 2 * internal);
    d_start.topRows(stable_count) = start_split.stable_left;
    d_end.bottomRows(2 * internal - stable_count) = end_split.unstable_left;
  };
  if (end_split.unstable_basis.cols() != 2 * internal - stable_count) {
    throw NoSolution("stable inversion: the start and end equilibria have different numbers of "
                     "unstable modes (" + std::to_string(2 * internal - stable_count) + " and " +
                     std::to_string(end_split.unstable_basis.cols()) + ")");
  }

  StableInversionSolution solution;
  std::optional<BoundaryValueSolution> previous;
  BoundaryValueOptions bvp_options;
  bvp_options.tolerance = options.tolerance;
  bvp_options.absolute_tolerance = options.absolute_tolerance;
  bvp_options.collocation_points = kCollocationPoints;
  double fastest = 0.0;
  for (const auto* split : {&start_split, &end_split}) {
    for (const auto& value : split->eigenvalues) fastest = std::max(fastest, std::abs(value));
  }
  // The linear solution is only Newton's starting point: a few digits suffice.
  IntegratorOptions guess_accuracy;
  guess_accuracy.rtol = 1e-4;
  guess_accuracy.atol = 1e-7;
  for (int widening = 0;; ++widening) {
    const double t_a = t0 - pre, t_b = tf + post;
    // The first mesh: the window cut at the breakpoints, each piece into equal intervals.
    std::vector<double> ends = {t_a};
    for (double breakpoint : breakpoints) {
      if (breakpoint > t_a && breakpoint < t_b) ends.push_back(breakpoint);
    }
    ends.push_back(t_b);
    std::vector<double> mesh = {t_a};
    for (std::size_t piece = 0; piece + 1 < ends.size(); ++piece) {
      const double length = ends[piece + 1] - ends[piece];
      const int intervals = std::max(
          kMinIntervalsPerPiece, int(std::ceil(length * fastest / kTimeConstantsPerInterval)));
      for (int k = 1; k <= intervals; ++k) {
        mesh.push_back(k == intervals ? ends[piece + 1] : ends[piece] + length * k / intervals);
      }
    }
    // Newton's start: the equilibria, the start one before t0 and the end one after tf,
    // joined linearly in between (SciPy users start solve_bvp the same way). On the arm this
    // converges in fewer iterations than the linear stable inversion would, and costs
    // nothing; when Newton fails from it, the linear stable inversion about the start (exact
    // for linear models) is the second start.
    std::vector<Eigen::VectorXd> guess;
    for (const double t : mesh) {
      const double progress = std::clamp((t - t0) / (tf - t0), 0.0, 1.0);
      guess.push_back((1.0 - progress) * start.equilibrium_state +
                      progress * end.equilibrium_state);
    }
    BoundaryValueSolution bvp =
        SolveBoundaryValueProblem(rhs, {}, conditions, mesh, guess, bvp_options);
    if (bvp.summary.status == SolveStatus::kNoConvergence) {
      // Steps as long as the accuracy allows (a finite cap, so that
      // SolveLinearStableInversion does not impose its own fine one).
      guess_accuracy.max_step = t_b - t_a;
      const LinearStableInversion linear = SolveLinearStableInversion(
          start_split,
          [&](double t) -> Eigen::VectorXd {
            Eigen::VectorXd outputs(start.equilibrium_output.size());
            const Eigen::Index m = outputs.size() / 3;
            for (int order = 0; order < 3; ++order) {
              outputs.segment(order * m, m) = trajectory.Derivative(t, order);
            }
            return start.drive_matrix * (outputs - start.equilibrium_output);
          },
          t_a, t_b, mesh, breakpoints, guess_accuracy);
      if (linear.summary.IsUsable()) {
        for (std::size_t i = 0; i < mesh.size(); ++i) {
          guess[i] = start.equilibrium_state + linear.states[i];
        }
        const long earlier_evaluations = bvp.summary.function_evaluations;
        bvp = SolveBoundaryValueProblem(rhs, {}, conditions, mesh, guess, bvp_options);
        bvp.summary.function_evaluations += earlier_evaluations;
      }
    }
    solution.summary = bvp.summary;
    solution.window.boundary_value_residual = bvp.max_residual;
    solution.window.start = t_a;
    solution.window.end = t_b;
    solution.window.widenings = widening;
    if (!bvp.summary.IsUsable()) return solution;
    // Unchanged when widened: compare the input on the previous window's mesh.
    bool settled = false;
    if (previous) {
      double change = 0.0, scale = 0.0;
      for (double t : previous->mesh) {
        Eigen::VectorXd input_new, input_old;
        std::string why;
        for (int which = 0; which < 2; ++which) {
          const Eigen::VectorXd x = (which == 0 ? bvp : *previous).Evaluate(t);
          Eigen::VectorXd x_dot;
          if (!rhs(t, x, x_dot, why)) break;
          (which == 0 ? input_new : input_old) = u;
        }
        if (input_new.size() == 0 || input_old.size() == 0) continue;
        change = std::max(change, (input_new - input_old).cwiseAbs().maxCoeff());
        scale = std::max(scale, input_new.cwiseAbs().maxCoeff());
      }
      settled = change <= 10.0 * options.tolerance * std::max(scale, 1e-300);
    }
    if (settled || widening >= options.max_widenings ||
        (options.pre_actuation && options.post_actuation)) {
      previous = std::move(bvp);
      break;
    }
    previous = std::move(bvp);
    // A side the caller fixed stays as it is.
    if (!options.pre_actuation) pre *= kWideningFactor;
    if (!options.post_actuation) post *= kWideningFactor;
  }

  // The answer at the mesh points, and where the input departs from rest.
  const BoundaryValueSolution& bvp = *previous;
  std::string why;
  Eigen::VectorXd x_dot;
  for (std::size_t i = 0; i < bvp.mesh.size(); ++i) {
    if (!rhs(bvp.mesh[i], bvp.y[i], x_dot, why)) {
      solution.summary.status = SolveStatus::kNoConvergence;
      solution.summary.message = "at t = " + FormatNumber(bvp.mesh[i]) + " s: " + why;
      return solution;
    }
    solution.times.push_back(bvp.mesh[i]);
    solution.q.push_back(q);
    solution.q_dot.push_back(q_dot);
    solution.u.push_back(u);
  }
  double largest = 0.0;
  for (const auto& input : solution.u) {
    largest = std::max(largest, (input - start.equilibrium_input).cwiseAbs().maxCoeff());
  }
  // The motion between mesh points, through the same problem (kept alive by the extension;
  // its calls must not overlap, as for any ServoConstraintProblem).
  auto collocation = std::make_shared<const BoundaryValueSolution>(std::move(*previous));
  solution.extension = InternalMotion(
      shared_problem, [collocation](double t) { return collocation->Evaluate(t); }, start_q,
      collocation->mesh.front(), collocation->mesh.back());
  const auto input_at = [&](double t) {
    Eigen::VectorXd coordinates, velocities, input;
    std::string reason;
    if (!solution.extension->Evaluate(t, coordinates, velocities, input, reason)) {
      input.setConstant(problem.num_inputs(), std::numeric_limits<double>::quiet_NaN());
    }
    return input;
  };
  // Where the input departs from rest (by more than tolerance times its largest departure):
  // the first and last mesh times beyond the threshold, then the crossings on the interpolant
  // by bisection, since the high-order mesh is coarse where u is smooth.
  const double threshold = options.tolerance * largest;
  const auto departs = [&](double t, const Eigen::VectorXd& input) {
    return (input - (t < t0 ? start : end).equilibrium_input).cwiseAbs().maxCoeff() > threshold;
  };
  const auto crossing = [&](double quiet, double active) {
    for (int halving = 0; halving < kCrossingBisections; ++halving) {
      const double middle = 0.5 * (quiet + active);
      (departs(middle, input_at(middle)) ? active : quiet) = middle;
    }
    return active;
  };
  std::optional<std::size_t> first_active, last_active;
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    if (!departs(solution.times[i], solution.u[i])) continue;
    if (!first_active) first_active = i;
    last_active = i;
  }
  solution.window.pre_actuation_start = solution.times.front();
  solution.window.post_actuation_end = solution.times.back();
  if (first_active && *first_active > 0) {
    solution.window.pre_actuation_start =
        crossing(solution.times[*first_active - 1], solution.times[*first_active]);
  }
  if (last_active && *last_active + 1 < solution.times.size()) {
    solution.window.post_actuation_end =
        crossing(solution.times[*last_active + 1], solution.times[*last_active]);
  }
  solution.window.mesh_points = solution.times.size();
  solution.summary.message = "boundary value problem on [" + FormatNumber(solution.window.start) +
                             ", " + FormatNumber(solution.window.end) + "] s, " +
                             std::to_string(solution.times.size()) + " mesh points, residual " +
                             FormatNumber(solution.window.boundary_value_residual);
  return solution;
}

}  // namespace servokit
