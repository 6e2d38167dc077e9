#include "solvers/stable_inversion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include "base/errors.h"
#include "base/option_check.h"
#include "integrators/boundary_value.h"
#include "solvers/internal_dynamics.h"
#include "solvers/linear_stable_inversion.h"
#include "solvers/output_normal_form.h"
#include "solvers/servo_constraint_problem.h"

namespace servokit {
namespace {

// --- The window ---
// A side without modes to wait for (no unstable mode at the start, or no stable one at the
// end) still gets this fraction of the motion's duration, so that the mesh has room there.
constexpr double kWindowWithoutModes = 0.1;
// Each widening grows the pre- and post-actuation margins by this factor: by half, so the modes
// at the window's ends decay by another tolerance^(1/2) (the margins are ln(1/tolerance) /
// rate), enough for a change to show, without doubling the mesh at each widening.
constexpr double kWideningFactor = 1.5;
// A widened window has settled when u changed by at most this many times the tolerance (the
// collocation error of each answer is up to the tolerance, so their difference can reach a
// few times it without the window mattering).
constexpr double kSettledFactor = 10.0;

// --- The collocation and its first mesh ---
// Gauss-Lobatto points per collocation interval: order 12 at the interval ends and 8 in
// between (BoundaryValueOptions::collocation_points). The internal dynamics are smooth between
// the trajectory's breakpoints, so high order needs far fewer unknowns than bvp4c's order 4
// (measured on the rotational arm at tolerance 1e-6: 199 nodes against 1384).
constexpr int kCollocationPoints = 7;
// First mesh: intervals of at most this many time constants 1 / |lambda| of the fastest
// zero-dynamics mode (an exponential over one time constant is resolved by the degree-7
// polynomial to about 1e-6, and refinement does the rest), and at least kMinIntervalsPerPiece
// between consecutive breakpoints, so that each piece of the motion's polynomial is seen by
// several collocation polynomials from the start.
constexpr double kTimeConstantsPerInterval = 4.0;
constexpr int kMinIntervalsPerPiece = 4;

// --- Newton's second start, the linear stable inversion ---
// Only a starting point: a few digits suffice (Newton converges from much further away), so
// the integration is cheap. The absolute level is for internal states of size about 1 (rad).
constexpr double kGuessRelativeTolerance = 1e-4;
constexpr double kGuessAbsoluteTolerance = 1e-7;
// The linear internal dynamics are driven by Y = (y_d, y_d', y_d''), stacked by order
// (LinearInternalDynamics::equilibrium_output; Eq. 25 needs y_d up to its second derivative).
constexpr int kDriveOrders = 3;

// --- Where the input departs from rest ---
// Bisections locating where the input departs from rest between two mesh points (2^-40 of
// their spacing: below any digit a user reads).
constexpr int kCrossingBisections = 40;

// --- The input-output normal form's rest linearization ---
// Central-difference step of the rest Jacobian, relative to max(1, |x_j|): about the cube root
// of the machine epsilon, where truncation and round-off errors balance (1e-11 relative).
constexpr double kRestJacobianStep = 6e-6;

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
  std::function<bool(double t,
                     const Eigen::VectorXd& x,
                     Eigen::VectorXd& x_dot,
                     Eigen::VectorXd& u,
                     std::string& why)>
      rhs;
  InternalRest start, end;
  // Optional second start for Newton on `mesh` over [t_a, t_b] (the linear stable inversion);
  // false when there is none.
  std::function<bool(
      const std::vector<double>& mesh, double t_a, double t_b, std::vector<Eigen::VectorXd>& guess)>
      linear_guess;
  // The motion on [start, end] from the collocation solution's interpolant.
  std::function<std::shared_ptr<const MotionExtension>(
      std::function<Eigen::VectorXd(double)> internal_state, double start, double end)>
      extension;
};

// Time the window covers before the motion's first breakpoint and after its last.
struct WindowMargins {
  double pre = 0.0, post = 0.0;
};

// The slowest unstable mode at the start sets the pre-actuation, the slowest stable mode at the
// end the post-actuation: each must decay to the tolerance outside the window. A side the
// caller fixed keeps its value.
WindowMargins ChooseWindowMargins(const InternalBoundaryValueProblem& problem,
                                  double t0,
                                  double tf,
                                  const StableInversionOptions& options) {
  double slowest_unstable = INFINITY, slowest_stable = INFINITY;
  for (const auto& value : problem.start.split.eigenvalues) {
    if (value.real() > 0) slowest_unstable = std::min(slowest_unstable, value.real());
  }
  for (const auto& value : problem.end.split.eigenvalues) {
    if (value.real() < 0) slowest_stable = std::min(slowest_stable, -value.real());
  }
  WindowMargins margins;
  margins.pre = options.pre_actuation.value_or(std::isfinite(slowest_unstable)
                                                   ? DecayTime(slowest_unstable, options.tolerance)
                                                   : kWindowWithoutModes * (tf - t0));
  margins.post = options.post_actuation.value_or(std::isfinite(slowest_stable)
                                                     ? DecayTime(slowest_stable, options.tolerance)
                                                     : kWindowWithoutModes * (tf - t0));
  return margins;
}

// The margins after one more widening; a side the caller fixed stays as it is.
WindowMargins Widened(WindowMargins margins, const StableInversionOptions& options) {
  if (!options.pre_actuation) margins.pre *= kWideningFactor;
  if (!options.post_actuation) margins.post *= kWideningFactor;
  return margins;
}

// At t_a the deviation from the start's rest state has no stable part, at t_b the deviation
// from the end's rest state no unstable part (stable_inversion.h). `problem` must outlive the
// conditions. Throws NoSolution when the two rest states have different numbers of unstable
// modes (then there are not `size` conditions).
BoundaryConditions MakeBoundaryConditions(const InternalBoundaryValueProblem& problem) {
  const InternalRest& start = problem.start;
  const InternalRest& end = problem.end;
  const Eigen::Index size = problem.size;
  const Eigen::Index stable_count = start.split.stable_basis.cols();
  if (end.split.unstable_basis.cols() != size - stable_count) {
    throw NoSolution(
        "stable inversion: the start and end equilibria have different numbers of "
        "unstable modes (" +
        std::to_string(size - stable_count) + " and " +
        std::to_string(end.split.unstable_basis.cols()) + ")");
  }
  BoundaryConditions conditions;
  conditions.residual = [&start, &end, size, stable_count](const Eigen::VectorXd& at_start,
                                                           const Eigen::VectorXd& at_end,
                                                           Eigen::VectorXd& residual) {
    residual.resize(size);
    residual.head(stable_count) = start.split.stable_left * (at_start - start.state);
    residual.tail(size - stable_count) = end.split.unstable_left * (at_end - end.state);
  };
  conditions.jacobians = [&start, &end, size, stable_count](
                             const Eigen::VectorXd&, const Eigen::VectorXd&,
                             Eigen::MatrixXd& d_start, Eigen::MatrixXd& d_end) {
    d_start = Eigen::MatrixXd::Zero(size, size);
    d_end = Eigen::MatrixXd::Zero(size, size);
    d_start.topRows(stable_count) = start.split.stable_left;
    d_end.bottomRows(size - stable_count) = end.split.unstable_left;
  };
  return conditions;
}

// The collocation's options: the stable inversion's tolerances at kCollocationPoints.
BoundaryValueOptions CollocationOptions(const StableInversionOptions& options) {
  BoundaryValueOptions collocation;
  collocation.tolerance = options.tolerance;
  collocation.absolute_tolerance = options.absolute_tolerance;
  collocation.collocation_points = kCollocationPoints;
  return collocation;
}

// max |lambda| over both rest states' linearizations: the fastest mode the mesh must resolve.
double FastestRate(const InternalBoundaryValueProblem& problem) {
  double fastest = 0.0;
  for (const auto* split : {&problem.start.split, &problem.end.split}) {
    for (const auto& value : split->eigenvalues) fastest = std::max(fastest, std::abs(value));
  }
  return fastest;
}

// The first mesh: [t_a, t_b] cut at the breakpoints, each piece into equal intervals of at most
// kTimeConstantsPerInterval time constants of the fastest mode, and at least
// kMinIntervalsPerPiece of them.
std::vector<double> InitialMesh(const std::vector<double>& breakpoints,
                                double t_a,
                                double t_b,
                                double fastest) {
  std::vector<double> ends = {t_a};
  for (double breakpoint : breakpoints) {
    if (breakpoint > t_a && breakpoint < t_b) ends.push_back(breakpoint);
  }
  ends.push_back(t_b);
  std::vector<double> mesh = {t_a};
  for (std::size_t piece = 0; piece + 1 < ends.size(); ++piece) {
    const double length = ends[piece + 1] - ends[piece];
    const int intervals = std::max(kMinIntervalsPerPiece,
                                   int(std::ceil(length * fastest / kTimeConstantsPerInterval)));
    for (int k = 1; k <= intervals; ++k) {
      mesh.push_back(k == intervals ? ends[piece + 1] : ends[piece] + length * k / intervals);
    }
  }
  return mesh;
}

// Newton's first start: the start's rest state before t0 and the end's after tf, joined
// linearly in between (SciPy users start solve_bvp the same way). On the arm this converges in
// fewer iterations than the linear stable inversion would, and costs nothing.
std::vector<Eigen::VectorXd> LinearJoinGuess(const std::vector<double>& mesh,
                                             double t0,
                                             double tf,
                                             const InternalRest& start,
                                             const InternalRest& end) {
  std::vector<Eigen::VectorXd> guess;
  for (const double t : mesh) {
    const double progress = std::clamp((t - t0) / (tf - t0), 0.0, 1.0);
    guess.push_back((1.0 - progress) * start.state + progress * end.state);
  }
  return guess;
}

// The internal dynamics as the collocation calls them, x' = f(t, x), keeping the input u of
// the last evaluation for the settled test.
class CollocatedDynamics {
 public:
  explicit CollocatedDynamics(const InternalBoundaryValueProblem& problem) : problem_(problem) {}
  CollocatedDynamics(const CollocatedDynamics&) = delete;
  CollocatedDynamics& operator=(const CollocatedDynamics&) = delete;

  // f for SolveBoundaryValueProblem; refers to this object, which must outlive it.
  BvpRightHandSide RightHandSide() {
    return [this](double t, const Eigen::VectorXd& x, Eigen::VectorXd& x_dot, std::string& why) {
      return problem_.rhs(t, x, x_dot, input_, why);
    };
  }
  // u at (t, x); false with `why` when f cannot be evaluated there.
  bool Input(double t, const Eigen::VectorXd& x, Eigen::VectorXd& input, std::string& why) {
    Eigen::VectorXd x_dot;
    if (!problem_.rhs(t, x, x_dot, input_, why)) return false;
    input = input_;
    return true;
  }

 private:
  const InternalBoundaryValueProblem& problem_;
  Eigen::VectorXd input_;
};

// The boundary value problem on the window [t_a, t_b] with the first mesh for it: from the
// linear join, and when Newton fails from there, from the problem's linear stable inversion
// (exact for linear models) as the second start.
BoundaryValueSolution SolveOnWindow(const InternalBoundaryValueProblem& problem,
                                    const BvpRightHandSide& rhs,
                                    const BoundaryConditions& conditions,
                                    const std::vector<double>& mesh,
                                    double t0,
                                    double tf,
                                    const BoundaryValueOptions& collocation) {
  const double t_a = mesh.front(), t_b = mesh.back();
  std::vector<Eigen::VectorXd> guess = LinearJoinGuess(mesh, t0, tf, problem.start, problem.end);
  BoundaryValueSolution bvp =
      SolveBoundaryValueProblem(rhs, {}, conditions, mesh, guess, collocation);
  if (bvp.summary.status == SolveStatus::kNoConvergence && problem.linear_guess &&
      problem.linear_guess(mesh, t_a, t_b, guess)) {
    const long earlier_evaluations = bvp.summary.function_evaluations;
    bvp = SolveBoundaryValueProblem(rhs, {}, conditions, mesh, guess, collocation);
    bvp.summary.function_evaluations += earlier_evaluations;
  }
  return bvp;
}

// Whether the widened window's input equals the previous one's on the previous mesh, up to
// kSettledFactor times the tolerance relative to the input's size. Points where either input
// cannot be evaluated are skipped.
bool InputSettled(CollocatedDynamics& dynamics,
                  const BoundaryValueSolution& widened,
                  const BoundaryValueSolution& previous,
                  double tolerance) {
  double change = 0.0, scale = 0.0;
  std::string why;
  for (double t : previous.mesh) {
    Eigen::VectorXd input_new, input_old;
    if (!dynamics.Input(t, widened.Evaluate(t), input_new, why) ||
        !dynamics.Input(t, previous.Evaluate(t), input_old, why)) {
      continue;
    }
    change = std::max(change, (input_new - input_old).cwiseAbs().maxCoeff());
    scale = std::max(scale, input_new.cwiseAbs().maxCoeff());
  }
  // The smallest normal number as the scale's floor: an input that is zero throughout has
  // settled only when it did not change at all.
  return change <= kSettledFactor * tolerance * std::max(scale, std::numeric_limits<double>::min());
}

// The window [t_a, t_b] needs more mesh points at the fastest zero-dynamics rate than the
// collocation may take: the zero dynamics span too many time scales for that window.
NoSolution TooStiffForWindow(std::size_t points,
                             double t_a,
                             double t_b,
                             double fastest,
                             const BoundaryValueOptions& collocation) {
  return NoSolution("stable inversion: the window from t = " + FormatNumber(t_a) + " s to " +
                    FormatNumber(t_b) + " s, at the fastest zero-dynamics rate |lambda| = " +
                    FormatNumber(fastest) + " 1/s, needs " + std::to_string(points) +
                    " mesh points, more than the " + std::to_string(collocation.max_mesh_points) +
                    " the collocation takes: the zero dynamics span too many time scales (the "
                    "slowest mode sets the window's length, the fastest its mesh); a shorter "
                    "pre- or post-actuation shortens the window");
}

// Solves on the window the margins give, widening it while the input still changes (until the
// widenings run out, or at once when the caller fixed both sides). Writes the summary and the
// window's ends, residual and widenings into `solution`; returns the last collocation solution,
// or none when it is not usable.
std::optional<BoundaryValueSolution> SolveWideningWindow(
    const InternalBoundaryValueProblem& problem,
    const std::vector<double>& breakpoints,
    const StableInversionOptions& options,
    StableInversionSolution& solution) {
  const double t0 = breakpoints.front(), tf = breakpoints.back();
  WindowMargins margins = ChooseWindowMargins(problem, t0, tf, options);
  CollocatedDynamics dynamics(problem);
  const BvpRightHandSide rhs = dynamics.RightHandSide();
  const BoundaryConditions conditions = MakeBoundaryConditions(problem);
  const BoundaryValueOptions collocation = CollocationOptions(options);
  const double fastest = FastestRate(problem);
  std::optional<BoundaryValueSolution> previous;
  for (int widening = 0;; ++widening) {
    const double t_a = t0 - margins.pre, t_b = tf + margins.post;
    std::vector<double> mesh = InitialMesh(breakpoints, t_a, t_b, fastest);
    if (long(mesh.size()) > collocation.max_mesh_points)
      throw TooStiffForWindow(mesh.size(), t_a, t_b, fastest, collocation);
    BoundaryValueSolution bvp =
        SolveOnWindow(problem, rhs, conditions, std::move(mesh), t0, tf, collocation);
    solution.summary = bvp.summary;
    solution.window.boundary_value_residual = bvp.max_residual;
    solution.window.start = t_a;
    solution.window.end = t_b;
    solution.window.widenings = widening;
    if (!bvp.summary.IsUsable()) return std::nullopt;
    const bool settled = previous && InputSettled(dynamics, bvp, *previous, options.tolerance);
    previous = std::move(bvp);
    if (settled || widening >= options.max_widenings ||
        (options.pre_actuation && options.post_actuation)) {
      return previous;
    }
    margins = Widened(margins, options);
  }
}

// The motion at the collocation mesh points from `solution.extension`, appended to
// `solution`'s rows. False, with the time and the reason in the summary and the extension
// dropped, where the motion cannot be evaluated.
bool SampleMotion(const std::vector<double>& mesh, StableInversionSolution& solution) {
  std::string why;
  for (const double t : mesh) {
    Eigen::VectorXd q, q_dot, input;
    if (!solution.extension->Evaluate(t, q, q_dot, input, why)) {
      solution.summary.status = SolveStatus::kNoConvergence;
      solution.summary.message = "at t = " + FormatNumber(t) + " s: " + why;
      solution.extension.reset();
      return false;
    }
    solution.times.push_back(t);
    solution.q.push_back(q);
    solution.q_dot.push_back(q_dot);
    solution.u.push_back(input);
  }
  return true;
}

// Whether an input departs from rest: by more than `threshold` from the start's rest input
// before t0, from the end's after.
struct RestDeparture {
  const InternalRest& start;
  const InternalRest& end;
  double t0 = 0.0;
  double threshold = 0.0;
  bool operator()(double t, const Eigen::VectorXd& input) const {
    return (input - (t < t0 ? start : end).input).cwiseAbs().maxCoeff() > threshold;
  }
};

// u_d at t from the extension; NaN where it cannot be evaluated (which never counts as a
// departure).
Eigen::VectorXd InputOnInterpolant(const MotionExtension& extension,
                                   double t,
                                   Eigen::Index inputs) {
  Eigen::VectorXd coordinates, velocities, input;
  std::string reason;
  if (!extension.Evaluate(t, coordinates, velocities, input, reason)) {
    input.setConstant(inputs, std::numeric_limits<double>::quiet_NaN());
  }
  return input;
}

// The time between `quiet` (the input at rest) and `active` (departed) where the input
// crosses the threshold, by kCrossingBisections bisections on the interpolant (the high-order
// mesh is coarse where u is smooth).
double DepartureCrossing(const MotionExtension& extension,
                         const RestDeparture& departs,
                         double quiet,
                         double active) {
  const Eigen::Index inputs = departs.start.input.size();
  for (int halving = 0; halving < kCrossingBisections; ++halving) {
    const double middle = 0.5 * (quiet + active);
    const bool departed = departs(middle, InputOnInterpolant(extension, middle, inputs));
    (departed ? active : quiet) = middle;
  }
  return active;
}

// The first and last time the input departs from rest by more than tolerance times its largest
// departure (from the start's rest input): the first and last mesh times beyond the threshold,
// then the crossings on the interpolant. The window's ends where it never rests.
void LocateActuationWindow(const InternalBoundaryValueProblem& problem,
                           double t0,
                           double tolerance,
                           StableInversionSolution& solution) {
  double largest = 0.0;
  for (const auto& input : solution.u) {
    largest = std::max(largest, (input - problem.start.input).cwiseAbs().maxCoeff());
  }
  const RestDeparture departs{problem.start, problem.end, t0, tolerance * largest};
  std::optional<std::size_t> first_active, last_active;
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    if (!departs(solution.times[i], solution.u[i])) continue;
    if (!first_active) first_active = i;
    last_active = i;
  }
  const std::vector<double>& times = solution.times;
  solution.window.pre_actuation_start = times.front();
  solution.window.post_actuation_end = times.back();
  if (first_active && *first_active > 0) {
    solution.window.pre_actuation_start = DepartureCrossing(
        *solution.extension, departs, times[*first_active - 1], times[*first_active]);
  }
  if (last_active && *last_active + 1 < times.size()) {
    solution.window.post_actuation_end = DepartureCrossing(
        *solution.extension, departs, times[*last_active + 1], times[*last_active]);
  }
}

// The stable inversion of `problem` along the motion with these breakpoints: the window, the
// collocation solution on it, the motion at its mesh and where the input departs from rest.
StableInversionSolution SolveInternalBoundaryValue(const InternalBoundaryValueProblem& problem,
                                                   const std::vector<double>& breakpoints,
                                                   const StableInversionOptions& options) {
  StableInversionSolution solution;
  std::optional<BoundaryValueSolution> settled =
      SolveWideningWindow(problem, breakpoints, options, solution);
  if (!settled) return solution;
  // The motion at the mesh points and between them, from the interpolant.
  auto collocation = std::make_shared<const BoundaryValueSolution>(std::move(*settled));
  solution.extension =
      problem.extension([collocation](double t) { return collocation->Evaluate(t); },
                        collocation->mesh.front(), collocation->mesh.back());
  if (!SampleMotion(collocation->mesh, solution)) return solution;
  LocateActuationWindow(problem, breakpoints.front(), options.tolerance, solution);
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

// Newton's second start for Eq. (25): the linear stable inversion about the start equilibrium
// `start` (whose linearization `split` divides) on `mesh` over [t_a, t_b], written into `guess`
// (one entry per mesh point). False when the linear solution fails.
bool LinearStableInversionGuess(const LinearInternalDynamics& start,
                                const HyperbolicSplit& split,
                                const OutputTrajectory& trajectory,
                                const std::vector<double>& breakpoints,
                                const std::vector<double>& mesh,
                                double t_a,
                                double t_b,
                                std::vector<Eigen::VectorXd>& guess) {
  // The linear solution is only Newton's starting point: a few digits suffice, with steps as
  // long as the accuracy allows (a finite cap, so that SolveLinearStableInversion does not
  // impose its own fine one).
  IntegratorOptions guess_accuracy;
  guess_accuracy.rtol = kGuessRelativeTolerance;
  guess_accuracy.atol = kGuessAbsoluteTolerance;
  guess_accuracy.max_step = t_b - t_a;
  const LinearStableInversion linear = SolveLinearStableInversion(
      split,
      [&](double t) -> Eigen::VectorXd {
        Eigen::VectorXd outputs(start.equilibrium_output.size());
        const Eigen::Index m = outputs.size() / kDriveOrders;
        for (int order = 0; order < kDriveOrders; ++order) {
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
}

}  // namespace

StableInversionSolution SolveStableInversion(const Model& model,
                                             const OutputTrajectory& trajectory,
                                             const Eigen::VectorXd& start_q,
                                             const Eigen::VectorXd& end_q,
                                             const StableInversionOptions& options) {
  options.Validate();
  const LinearInternalDynamics start = LinearizeInternalDynamics(model, start_q);
  // In the start's chart: the one the boundary value problem below integrates in.
  const LinearInternalDynamics end = LinearizeInternalDynamics(model, end_q, start_q);
  // Shared with the extension (one problem, built once; its calls must not overlap).
  const auto shared_problem = std::make_shared<ServoConstraintProblem>(model, trajectory, start_q);
  ServoConstraintProblem& servo = *shared_problem;
  const Eigen::Index internal = servo.num_internal();
  const Eigen::MatrixXd& directions = servo.internal_directions();
  Eigen::VectorXd q = start_q, q_dot, q_ddot;

  InternalBoundaryValueProblem problem;
  problem.size = 2 * internal;
  problem.rhs = [&](double t, const Eigen::VectorXd& x, Eigen::VectorXd& x_dot, Eigen::VectorXd& u,
                    std::string& why) {
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
    return LinearStableInversionGuess(start, problem.start.split, trajectory, breakpoints, mesh,
                                      t_a, t_b, guess);
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
                      Eigen::VectorXd& u,
                      std::string& why) { return map->RightHandSide(t, z, z_dot, u, why); };
  const std::vector<double> breakpoints = trajectory.breakpoints();
  // The rest states, and the linearization there at a time when y_d is at rest: one motion
  // duration before the motion and after it (any time outside the motion would do, since y_d
  // is constant there).
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
      throw NoSolution(
          "stable inversion: the input-output normal form cannot be evaluated at "
          "rest (t = " +
          FormatNumber(t) + " s): " + why);
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
                        Eigen::VectorXd& q_dot, Eigen::VectorXd& u,
                        std::string& why) { return extension_map->State(t, z, q, q_dot, u, why); },
        std::move(internal_state), from, to);
  };
  return SolveInternalBoundaryValue(problem, breakpoints, options);
}

}  // namespace servokit
