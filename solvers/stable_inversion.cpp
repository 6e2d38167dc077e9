#include "solvers/stable_inversion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include "models/errors.h"
#include "models/option_check.h"
#include "solvers/boundary_value.h"
#include "solvers/internal_dynamics.h"
#include "solvers/linear_stable_inversion.h"
#include "solvers/output_normal_form.h"
#include "solvers/servo_constraint_problem.h"

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

// Central-difference step of the rest Jacobian, relative to max(1, |x_j|): about the cube root
// of the machine epsilon, where truncation and round-off errors balance (1e-11 relative).
constexpr double kRestJacobianStep = 6e-6;

// A side without modes to wait for (no unstable mode at the start, or no stable one at the
// end) still gets this fraction of the motion's duration, so that the mesh has room there.
constexpr double kWindowWithoutModes = 0.1;
// A widened window has settled when u changed by at most this many times the tolerance (the
// collocation error of each answer is up to the tolerance, so their difference can reach a
// few times it without the window mattering).
constexpr double kSettledFactor = 10.0;
// The linear stable inversion is only Newton's second start: a few digits suffice.
constexpr double kGuessRelativeTolerance = 1e-4;
constexpr double kGuessAbsoluteTolerance = 1e-7;

// Each widening grows the pre- and post-actuation windows by this factor.
constexpr double kWideningFactor = 1.5;

// ln(1/tolerance) / rate: the time a mode of that decay rate needs to fall to the tolerance.
double DecayTime(double rate, double tolerance) { return std::log(1.0 / tolerance) / rate; }

}  // namespace

void StableInversionOptions::Validate() const {
  constexpr const char* kOwner = "StableInversionOptions";
  RequireOption(tolerance > 0.0 && tolerance < 1.0, kOwner, "tolerance", tolerance,
                "must be in (0, 1)");
  RequireOption(absolute_tolerance > 0.0 && std::isfinite(absolute_tolerance), kOwner,
                "absolute_tolerance", absolute_tolerance, "must be a finite number > 0");
  for (const auto& [value, field] :
       {std::pair{pre_actuation, "pre_actuation"}, std::pair{post_actuation, "post_actuation"}}) {
    RequireOption(!value || (*value > 0.0 && std::isfinite(*value)), kOwner, field,
                  value.value_or(0.0), "must be a finite number > 0");
  }
  RequireOption(max_widenings >= 0, kOwner, "max_widenings", max_widenings, "must be >= 0");
}

namespace {

// A rest state of the internal dynamics and their linearization there.
struct InternalRest {
  Eigen::VectorXd state;  // x at rest
  Eigen::VectorXd input;  // u at rest
  HyperbolicSplit split;  // of the linearization's matrix
};

// Internal dynamics x' = f(t, x) as the boundary value problem needs them, whichever normal
// form they come from (Eq. 25 for P regular, the input-output normal form otherwise).
struct InternalBoundaryValueProblem {
  Eigen::Index size = 0;
  // f, and the input u at (t, x).
  std::function<bool(double t, const Eigen::VectorXd& x, Eigen::VectorXd& x_dot,
                     Eigen::VectorXd& u, std::string& why)>
      rhs;
  InternalRest start, end;
  // Optional second start for Newton on `mesh` over [t_a, t_b] (the linear stable inversion);
  // false when there is none.
  std::function<bool(const std::vector<double>& mesh, double t_a, double t_b,
                     std::vector<Eigen::VectorXd>& guess)>
      linear_guess;
  // The motion on [start, end] from the collocation solution's interpolant.
  std::function<std::shared_ptr<const MotionExtension>(
      std::function<Eigen::VectorXd(double)> internal_state, double start, double end)>
      extension;
};

StableInversionSolution SolveInternalBoundaryValue(const InternalBoundaryValueProblem& problem,
                                                   const std::vector<double>& breakpoints,
                                                   const StableInversionOptions& options) {
  const InternalRest& start = problem.start;
  const InternalRest& end = problem.end;
  const HyperbolicSplit& start_split = start.split;
  const HyperbolicSplit& end_split = end.split;
  const Eigen::Index size = problem.size;

  // The slowest unstable mode at the start sets the pre-actuation, the slowest stable mode at
  // the end the post-actuation.
  double slowest_unstable = INFINITY, slowest_stable = INFINITY;
  for (const auto& value : start_split.eigenvalues) {
    if (value.real() > 0) slowest_unstable = std::min(slowest_unstable, value.real());
  }
  for (const auto& value : end_split.eigenvalues) {
    if (value.real() < 0) slowest_stable = std::min(slowest_stable, -value.real());
  }
  const double t0 = breakpoints.front(), tf = breakpoints.back();
  double pre = options.pre_actuation.value_or(
      std::isfinite(slowest_unstable) ? DecayTime(slowest_unstable, options.tolerance)
                                      : kWindowWithoutModes * (tf - t0));
  double post = options.post_actuation.value_or(
      std::isfinite(slowest_stable) ? DecayTime(slowest_stable, options.tolerance)
                                    : kWindowWithoutModes * (tf - t0));

  Eigen::VectorXd u;
  const BvpRightHandSide rhs = [&](double t, const Eigen::VectorXd& x, Eigen::VectorXd& x_dot,
                                   std::string& why) { return problem.rhs(t, x, x_dot, u, why); };
  const Eigen::Index stable_count = start_split.stable_basis.cols();
  if (end_split.unstable_basis.cols() != size - stable_count) {
    throw NoSolution("stable inversion: the start and end equilibria have different numbers of "
                     "unstable modes (" + std::to_string(size - stable_count) + " and " +
                     std::to_string(end_split.unstable_basis.cols()) + ")");
  }
  BoundaryConditions conditions;
  conditions.residual = [&](const Eigen::VectorXd& at_start, const Eigen::VectorXd& at_end,
                            Eigen::VectorXd& residual) {
    residual.resize(size);
    residual.head(stable_count) = start_split.stable_left * (at_start - start.state);
    residual.tail(size - stable_count) = end_split.unstable_left * (at_end - end.state);
  };
  conditions.jacobians = [&](const Eigen::VectorXd&, const Eigen::VectorXd&,
                             Eigen::MatrixXd& d_start, Eigen::MatrixXd& d_end) {
    d_start = Eigen::MatrixXd::Zero(size, size);
    d_end = Eigen::MatrixXd::Zero(size, size);
    d_start.topRows(stable_count) = start_split.stable_left;
    d_end.bottomRows(size - stable_count) = end_split.unstable_left;
  };

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
      guess.push_back((1.0 - progress) * start.state + progress * end.state);
    }
    BoundaryValueSolution bvp =
        SolveBoundaryValueProblem(rhs, {}, conditions, mesh, guess, bvp_options);
    if (bvp.summary.status == SolveStatus::kNoConvergence && problem.linear_guess &&
        problem.linear_guess(mesh, t_a, t_b, guess)) {
      const long earlier_evaluations = bvp.summary.function_evaluations;
      bvp = SolveBoundaryValueProblem(rhs, {}, conditions, mesh, guess, bvp_options);
      bvp.summary.function_evaluations += earlier_evaluations;
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
      settled = change <= kSettledFactor * options.tolerance *
                              std::max(scale, std::numeric_limits<double>::min());
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

  // The motion at the mesh points and between them, from the interpolant.
  auto collocation = std::make_shared<const BoundaryValueSolution>(std::move(*previous));
  solution.extension = problem.extension([collocation](double t) { return collocation->Evaluate(t); },
                                         collocation->mesh.front(), collocation->mesh.back());
  std::string why;
  for (const double t : collocation->mesh) {
    Eigen::VectorXd q, q_dot, input;
    if (!solution.extension->Evaluate(t, q, q_dot, input, why)) {
      solution.summary.status = SolveStatus::kNoConvergence;
      solution.summary.message = "at t = " + FormatNumber(t) + " s: " + why;
      solution.extension.reset();
      return solution;
    }
    solution.times.push_back(t);
    solution.q.push_back(q);
    solution.q_dot.push_back(q_dot);
    solution.u.push_back(input);
  }
  double largest = 0.0;
  for (const auto& input : solution.u) {
    largest = std::max(largest, (input - start.input).cwiseAbs().maxCoeff());
  }
  const auto input_at = [&](double t) {
    Eigen::VectorXd coordinates, velocities, input;
    std::string reason;
    if (!solution.extension->Evaluate(t, coordinates, velocities, input, reason)) {
      input.setConstant(start.input.size(), std::numeric_limits<double>::quiet_NaN());
    }
    return input;
  };
  // Where the input departs from rest (by more than tolerance times its largest departure):
  // the first and last mesh times beyond the threshold, then the crossings on the interpolant
  // by bisection, since the high-order mesh is coarse where u is smooth.
  const double threshold = options.tolerance * largest;
  const auto departs = [&](double t, const Eigen::VectorXd& input) {
    return (input - (t < t0 ? start : end).input).cwiseAbs().maxCoeff() > threshold;
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

// df/dx at a rest state by central differences of f itself (as LinearizeInternalDynamics
// does for Eq. 25): the linearization of exactly what the boundary value problem solves.
bool RestJacobian(const InternalBoundaryValueProblem& problem,
                  double t,
                  const Eigen::VectorXd& state,
                  Eigen::MatrixXd& jacobian,
                  std::string& why) {
  const Eigen::Index n = state.size();
  jacobian.resize(n, n);
  Eigen::VectorXd plus, minus, u;
  for (Eigen::Index j = 0; j < n; ++j) {
    const double step = kRestJacobianStep * std::max(1.0, std::abs(state[j]));
    Eigen::VectorXd shifted = state;
    shifted[j] += step;
    if (!problem.rhs(t, shifted, plus, u, why)) return false;
    shifted[j] = state[j] - step;
    if (!problem.rhs(t, shifted, minus, u, why)) return false;
    jacobian.col(j) = (plus - minus) / (2 * step);
  }
  return true;
}

}  // namespace

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
  // Shared with the extension (one problem, built once; its calls must not overlap).
  const auto shared_problem = std::make_shared<ServoConstraintProblem>(model, trajectory, start_q);
  ServoConstraintProblem& servo = *shared_problem;
  const Eigen::Index internal = servo.num_internal();
  const Eigen::MatrixXd& directions = servo.internal_directions();
  Eigen::VectorXd q = start_q, q_dot, q_ddot;

  InternalBoundaryValueProblem problem;
  problem.size = 2 * internal;
  problem.rhs = [&](double t, const Eigen::VectorXd& x, Eigen::VectorXd& x_dot,
                    Eigen::VectorXd& u, std::string& why) {
    if (!servo.StateFromInternal(t, x.head(internal), x.tail(internal), q, q_dot, why) ||
        !servo.NormalForm(t, q, q_dot, u, q_ddot, why)) {
      return false;
    }
    x_dot.resize(2 * internal);
    x_dot.head(internal) = x.tail(internal);
    x_dot.tail(internal).noalias() = directions.transpose() * q_ddot;  // Eq. (25)
    return true;
  };
  problem.start = {start.equilibrium_state, start.equilibrium_input,
                   SplitHyperbolic(start.state_matrix)};
  problem.end = {end.equilibrium_state, end.equilibrium_input, SplitHyperbolic(end.state_matrix)};
  const std::vector<double> breakpoints = trajectory.breakpoints();
  problem.linear_guess = [&](const std::vector<double>& mesh, double t_a, double t_b,
                             std::vector<Eigen::VectorXd>& guess) {
    // The linear solution is only Newton's starting point: a few digits suffice, with steps
    // as long as the accuracy allows (a finite cap, so that SolveLinearStableInversion does
    // not impose its own fine one).
    IntegratorOptions guess_accuracy;
    guess_accuracy.rtol = kGuessRelativeTolerance;
    guess_accuracy.atol = kGuessAbsoluteTolerance;
    guess_accuracy.max_step = t_b - t_a;
    const LinearStableInversion linear = SolveLinearStableInversion(
        problem.start.split,
        [&](double t) -> Eigen::VectorXd {
          Eigen::VectorXd outputs(start.equilibrium_output.size());
          const Eigen::Index m = outputs.size() / 3;
          for (int order = 0; order < 3; ++order) {
            outputs.segment(order * m, m) = trajectory.Derivative(t, order);
          }
          return start.drive_matrix * (outputs - start.equilibrium_output);
        },
        t_a, t_b, mesh, breakpoints, guess_accuracy);
    if (!linear.summary.IsUsable()) return false;
    for (std::size_t i = 0; i < mesh.size(); ++i) {
      guess[i] = start.equilibrium_state + linear.states[i];
    }
    return true;
  };
  problem.extension = [&](std::function<Eigen::VectorXd(double)> internal_state, double from,
                          double to) {
    return InternalMotion(shared_problem, std::move(internal_state), start_q, from, to);
  };
  return SolveInternalBoundaryValue(problem, breakpoints, options);
}

StableInversionSolution SolveOutputStableInversion(const Model& model,
                                                   const OutputTrajectory& trajectory,
                                                   std::shared_ptr<const AlgebraicInverse> form,
                                                   const Eigen::VectorXd& start_q,
                                                   const Eigen::VectorXd& end_q,
                                                   const StableInversionOptions& options) {
  options.Validate();
  const Eigen::Index dof = start_q.size();
  const Eigen::Index internal = form->internal_order();
  if (internal == 0) {
    throw NoSolution("stable inversion: there are no internal dynamics (the problem is flat)");
  }
  const auto map = std::make_shared<OutputNormalFormMap>(model, trajectory, form, start_q,
                                                         Eigen::VectorXd::Zero(dof));
  InternalBoundaryValueProblem problem;
  problem.size = internal;
  problem.rhs = [map](double t, const Eigen::VectorXd& z, Eigen::VectorXd& z_dot,
                      Eigen::VectorXd& u, std::string& why) {
    return map->RightHandSide(t, z, z_dot, u, why);
  };
  const std::vector<double> breakpoints = trajectory.breakpoints();
  // The rest states, and the linearization there at a time when y_d is at rest.
  const auto rest = [&](const Eigen::VectorXd& q, double t) {
    Eigen::VectorXd state(2 * dof);
    state << q, Eigen::VectorXd::Zero(dof);
    InternalRest result;
    result.state = form->internal_directions().transpose() * state;
    Eigen::VectorXd z_dot;
    Eigen::MatrixXd jacobian;
    std::string why;
    if (!problem.rhs(t, result.state, z_dot, result.input, why) ||
        !RestJacobian(problem, t, result.state, jacobian, why)) {
      throw NoSolution("stable inversion: the input-output normal form cannot be evaluated at "
                       "rest (t = " + FormatNumber(t) + " s): " + why);
    }
    result.split = SplitHyperbolic(jacobian);
    return result;
  };
  const double span = breakpoints.back() - breakpoints.front();
  problem.start = rest(start_q, breakpoints.front() - span);
  problem.end = rest(end_q, breakpoints.back() + span);
  problem.extension = [&](std::function<Eigen::VectorXd(double)> internal_state, double from,
                          double to) {
    auto extension_map = std::make_shared<OutputNormalFormMap>(model, trajectory, form, start_q,
                                                               Eigen::VectorXd::Zero(dof));
    return MappedMotion(
        [extension_map](double t, const Eigen::VectorXd& z, Eigen::VectorXd& q,
                        Eigen::VectorXd& q_dot, Eigen::VectorXd& u, std::string& why) {
          return extension_map->State(t, z, q, q_dot, u, why);
        },
        std::move(internal_state), from, to);
  };
  return SolveInternalBoundaryValue(problem, breakpoints, options);
}

}  // namespace servokit
