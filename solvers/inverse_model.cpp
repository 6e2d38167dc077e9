#include "solvers/inverse_model.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "analysis/operating_point.h"
#include "models/errors.h"
#include "solvers/algebraic_inversion.h"
#include "solvers/radau.h"
#include "solvers/stable_inversion.h"
#include "solvers/solver_messages.h"

namespace servokit {
namespace {

// Radau IIA and Euler backward converge on DAEs of index up to 3 (Hairer & Wanner VII.8);
// beyond that the Newton iteration of the stages is too ill-conditioned.
constexpr int kMaxProjectedIndexForRadau = 3;
// Points of the local interpolant of u_d between samples (degree 5): matches the order of
// Dormand-Prince and Radau IIA, so interpolation adds less error than the solver made.
constexpr int kInterpolationPoints = 6;
// The trajectory counts as at rest at t_start when its derivatives there are below this
// (they are exactly zero before t0 for rest-to-rest trajectories).
constexpr double kRestTolerance = 1e-14;

struct MethodDefaults {
  double rtol;
  double atol;
};
MethodDefaults DefaultTolerances(SolverMethod method) {
  if (method == SolverMethod::kRadau || method == SolverMethod::kEuler) return {1e-8, 1e-10};
  // The boundary value problem's collocation residual; its errors come out far smaller.
  if (method == SolverMethod::kStableInversion) return {1e-8, 1e-10};
  return {1e-10, 1e-12};
}

// P = H M^-1 B has full rank at the operating point (an orthogonal realization).
bool DecouplingRegular(const Classification& classification) {
  return classification.decoupling.rank == classification.decoupling.decoupling_matrix.rows();
}

// The method to run and why, or NoSolution when the asked method does not fit the class.
std::pair<SolverMethod, std::string> ChooseMethod(const Classification& classification,
                                                  const InverseModelOptions& options) {
  const bool unstable = classification.zero_dynamics.stability == Stability::kUnstable;
  const bool decoupling_regular = DecouplingRegular(classification);
  const int projected_index = classification.structure.projected_index;
  SolverMethod method = options.method;
  std::string reason = "asked for with --method";
  if (method == SolverMethod::kAuto) {
    method = classification.recommended_solver;
    reason = "auto: recommended for this class (" +
             (classification.flat
                  ? std::string("flat")
                  : std::string(ToString(classification.zero_dynamics.stability)) +
                        " zero dynamics") +
             ", projected index " + std::to_string(projected_index) + ")";
  }
  if (unstable && !options.force && method != SolverMethod::kAlgebraic &&
      method != SolverMethod::kStableInversion) {
    throw NoSolution("the zero dynamics are unstable: --method " + std::string(ToString(method)) +
                     " integrates the internal dynamics forward, which diverges; use --method "
                     "stable-inversion (paper Sect. 5.3), or --force to integrate anyway");
  }
  if ((method == SolverMethod::kBdf || method == SolverMethod::kNormalForm ||
       method == SolverMethod::kStableInversion) &&
      !decoupling_regular) {
    throw NoSolution("--method " + std::string(ToString(method)) +
                     " needs P = H M^-1 B regular (an orthogonal realization); this problem is " +
                     std::string(ToString(classification.decoupling.realization)) +
                     ": use --method radau" + (classification.flat ? " or algebraic" : ""));
  }
  if ((method == SolverMethod::kRadau || method == SolverMethod::kEuler) &&
      projected_index > kMaxProjectedIndexForRadau) {
    throw NoSolution("the projected DAE has index " + std::to_string(projected_index) +
                     ", more than the 3 that --method " + std::string(ToString(method)) +
                     " handles" +
                     (classification.flat ? "; the problem is flat: use --method algebraic" : ""));
  }
  return {method, reason};
}

// The start of the motion: at rest at the equilibrium with h(q) = y_d(t_start) when the
// trajectory rests there; otherwise (orthogonal realizations only) the internal coordinates at
// that equilibrium and at rest while the output moves.
struct StartState {
  Eigen::VectorXd q, q_dot, u;
};

StartState FindStartState(const Model& model,
                          const OutputTrajectory& trajectory,
                          const Classification& classification,
                          ServoConstraintProblem& problem,
                          double t_start,
                          int highest_derivative) {
  Workspace workspace(model);
  OperatingPointOptions equilibrium_options;
  equilibrium_options.y0 = trajectory.Derivative(t_start, 0);
  equilibrium_options.q_guess = classification.operating_point.q;
  const OperatingPoint equilibrium = FindOperatingPoint(model, workspace, equilibrium_options);

  bool at_rest = true;
  for (int order = 1; order <= highest_derivative; ++order) {
    at_rest = at_rest && trajectory.Derivative(t_start, order).norm() <= kRestTolerance;
  }
  StartState start{equilibrium.q, Eigen::VectorXd::Zero(problem.dof()), equilibrium.u};
  if (at_rest) return start;
  if (!DecouplingRegular(classification)) {
    throw NoSolution("the trajectory moves at t_start = " + FormatNumber(t_start) +
                     ": a problem with P singular needs it at rest there (choose t_start <= t0)");
  }
  const Eigen::VectorXd z = problem.internal_directions().transpose() * equilibrium.q;
  const Eigen::VectorXd z_dot = Eigen::VectorXd::Zero(problem.num_internal());
  std::string why;
  Eigen::VectorXd q_ddot;
  if (!problem.StateFromInternal(t_start, z, z_dot, start.q, start.q_dot, why) ||
      !problem.NormalForm(t_start, start.q, start.q_dot, start.u, q_ddot, why)) {
    throw NoSolution("no consistent start at t_start = " + FormatNumber(t_start) + ": " + why);
  }
  return start;
}

// Sample times of the fixed grid t_start + k step, with the breakpoints in between.
std::vector<double> FixedGrid(double t_start, double t_end, double step,
                              const std::vector<double>& breakpoints) {
  std::vector<double> times;
  const long count = long(std::ceil((t_end - t_start) / step - 1e-9));
  for (long k = 0; k < count; ++k) times.push_back(t_start + double(k) * step);
  times.push_back(t_end);
  for (double breakpoint : breakpoints) {
    if (breakpoint > t_start && breakpoint < t_end) times.push_back(breakpoint);
  }
  std::sort(times.begin(), times.end());
  times.erase(std::unique(times.begin(), times.end(),
                          [](double a, double b) { return std::abs(a - b) <= 1e-12 * (1 + std::abs(a)); }),
              times.end());
  return times;
}

// u_d between samples: Lagrange interpolation through kInterpolationPoints neighbouring samples
// of the same smooth piece (never across a breakpoint, where derivatives of u_d jump).
class SampledFeedforward {
 public:
  SampledFeedforward(std::vector<double> times,
                     std::vector<Eigen::VectorXd> values,
                     const std::vector<double>& breakpoints)
      : times_(std::move(times)), values_(std::move(values)) {
    for (double breakpoint : breakpoints) {
      if (breakpoint > times_.front() && breakpoint < times_.back()) breakpoints_.push_back(breakpoint);
    }
  }

  Eigen::VectorXd operator()(double t) const {
    const double tolerance = 1e-12 * (1.0 + std::abs(t));
    // The piece [piece_start, piece_end] holding t; at a breakpoint the later piece answers.
    double piece_start = times_.front(), piece_end = times_.back();
    for (double breakpoint : breakpoints_) {
      if (breakpoint <= t + tolerance) piece_start = breakpoint;
      if (breakpoint > t + tolerance) {
        piece_end = breakpoint;
        break;
      }
    }
    const auto first_in_piece =
        std::lower_bound(times_.begin(), times_.end(), piece_start - tolerance) - times_.begin();
    const auto last_in_piece =
        std::upper_bound(times_.begin(), times_.end(), piece_end + tolerance) - times_.begin() - 1;
    const auto at = std::upper_bound(times_.begin(), times_.end(), t) - times_.begin();
    const long count = std::min<long>(kInterpolationPoints, long(last_in_piece - first_in_piece) + 1);
    long first = std::clamp<long>(long(at) - count / 2, long(first_in_piece),
                                  long(last_in_piece) - count + 1);
    Eigen::VectorXd value = Eigen::VectorXd::Zero(values_.front().size());
    for (long i = first; i < first + count; ++i) {
      double weight = 1.0;
      for (long j = first; j < first + count; ++j) {
        if (j != i) weight *= (t - times_[std::size_t(j)]) / (times_[std::size_t(i)] - times_[std::size_t(j)]);
      }
      value += weight * values_[std::size_t(i)];
    }
    return value;
  }

 private:
  std::vector<double> times_;
  std::vector<Eigen::VectorXd> values_;
  std::vector<double> breakpoints_;
};

// Appends a sample, replacing one at the same time (an integrator restarting at a breakpoint
// reports that time twice).
void Record(FeedforwardSolution& solution, double t, const Eigen::VectorXd& q,
            const Eigen::VectorXd& q_dot, const Eigen::VectorXd& u) {
  if (!solution.times.empty() && t <= solution.times.back()) {
    solution.q.back() = q;
    solution.q_dot.back() = q_dot;
    solution.u.back() = u;
    return;
  }
  solution.times.push_back(t);
  solution.q.push_back(q);
  solution.q_dot.push_back(q_dot);
  solution.u.push_back(u);
}

Eigen::MatrixXd OutputDerivatives(const OutputTrajectory& trajectory, double t, int highest) {
  Eigen::MatrixXd derivatives(trajectory.outputs(), highest + 1);
  for (int order = 0; order <= highest; ++order) derivatives.col(order) = trajectory.Derivative(t, order);
  return derivatives;
}

void SolveAlgebraic(const Model& model,
                    const OutputTrajectory& trajectory,
                    const InverseModelOptions& options,
                    const StartState& start,
                    std::shared_ptr<const AlgebraicInverse> inverse,
                    FeedforwardSolution& solution) {
  const int highest = inverse->highest_output_derivative();
  Eigen::VectorXd q = start.q, q_dot = start.q_dot, u;
  std::string why;
  solution.summary.status = SolveStatus::kConverged;
  for (double t : FixedGrid(options.t_start, options.t_end, options.step, trajectory.breakpoints())) {
    if (!inverse->Evaluate(OutputDerivatives(trajectory, t, highest), model.parameters(), q, q_dot, u,
                           why)) {
      solution.summary.status = SolveStatus::kNoConvergence;
      solution.summary.message = "at t = " + FormatNumber(t) + " s: " + why;
      solution.summary.stop_time = t;
      return;
    }
    ++solution.summary.steps;
    Record(solution, t, q, q_dot, u);
  }
  solution.summary.stop_time = options.t_end;
  solution.summary.message = "evaluated at " + std::to_string(solution.times.size()) + " times";
  // Exact u_d at any t: the inverse itself, started from the nearest sample's state.
  const Eigen::VectorXd parameters = model.parameters();
  const std::vector<double> times = solution.times;
  const std::vector<Eigen::VectorXd> q_samples = solution.q, q_dot_samples = solution.q_dot;
  const OutputTrajectory* path = &trajectory;
  solution.feedforward = [inverse, parameters, times, q_samples, q_dot_samples, path,
                          highest](double t) {
    const auto index = std::size_t(std::clamp<long>(
        long(std::upper_bound(times.begin(), times.end(), t) - times.begin()) - 1, 0,
        long(times.size()) - 1));
    Eigen::VectorXd state_q = q_samples[index], state_q_dot = q_dot_samples[index], input;
    std::string reason;
    if (!inverse->Evaluate(OutputDerivatives(*path, t, highest), parameters, state_q, state_q_dot,
                           input, reason)) {
      input.setConstant(Eigen::Index(inverse->output_derivative_orders().size()),
                        std::numeric_limits<double>::quiet_NaN());
    }
    return input;
  };
}

void SolveProjected(ServoConstraintProblem& problem,
                    const Classification& classification,
                    const InverseModelOptions& options,
                    SolverMethod method,
                    const StartState& start,
                    FeedforwardSolution& solution) {
  const Eigen::Index f = problem.dof();
  const bool decoupling_regular = DecouplingRegular(classification);
  ProjectedDae dae(problem, decoupling_regular);
  Eigen::VectorXd x_start(dae.size());
  x_start << start.q, start.q_dot, start.u;
  RadauOptions radau;
  const MethodDefaults defaults = DefaultTolerances(method);
  radau.rtol = options.rtol.value_or(defaults.rtol);
  radau.atol = options.atol.value_or(defaults.atol);
  if (method == SolverMethod::kEuler) {
    radau.stages = 1;
    radau.fixed_step = options.step;
  }
  solution.summary = IntegrateRadau(
      dae, options.t_start, x_start, options.t_end, problem.trajectory().breakpoints(), radau,
      [&](double t, const Eigen::VectorXd& x) {
        Record(solution, t, x.head(f), x.segment(f, f), x.tail(problem.num_inputs()));
        return true;
      });
}

// Watches det P from step to step: a sign change means P passed through singular between two
// steps, where u_d ~ P^-1 has a pole, even if the integrator stepped over the instant (as it
// may when the internal dynamics do not feel it). Stops the run there.
class DecouplingWatch {
 public:
  // True to go on; false (with the summary's status and message set by Finish()) to stop.
  bool Check(double t, double determinant) {
    const bool crossed = std::isfinite(previous_) && determinant * previous_ < 0.0;
    if (crossed) {
      message_ = "P = H M^-1 B is singular between t = " + FormatNumber(previous_time_) + " s and " +
                 FormatNumber(t) + " s (det P changes sign from " + FormatNumber(previous_) + " to " +
                 FormatNumber(determinant) + "): u_d has a pole there";
      return false;
    }
    previous_ = determinant;
    previous_time_ = t;
    return true;
  }
  // After the integrator stopped: a crossing overrides its kInterrupted.
  void Finish(SolveSummary& summary) const {
    if (message_.empty()) return;
    summary.status = SolveStatus::kSingularDecoupling;
    summary.message = message_;
    summary.stop_time = previous_time_;
  }

 private:
  double previous_ = std::numeric_limits<double>::quiet_NaN();
  double previous_time_ = 0.0;
  std::string message_;
};

void SolveBdf(ServoConstraintProblem& problem,
              const InverseModelOptions& options,
              const StartState& start,
              FeedforwardSolution& solution) {
  const Eigen::Index f = problem.dof();
  const Eigen::Index n = 2 * f + problem.num_inputs();
  Eigen::VectorXd x_start(n), x_dot_start(n), u, q_ddot;
  std::string why;
  if (!problem.NormalForm(options.t_start, start.q, start.q_dot, u, q_ddot, why)) {
    throw NoSolution("no consistent start at t_start = " + FormatNumber(options.t_start) + ": " + why);
  }
  x_start << start.q, start.q_dot, u;
  x_dot_start << start.q_dot, q_ddot, Eigen::VectorXd::Zero(problem.num_inputs());
  DecouplingWatch watch;
  std::vector<bool> differential(std::size_t(n), true);
  for (Eigen::Index i = 2 * f; i < n; ++i) differential[std::size_t(i)] = false;
  IntegratorOptions integrator;
  const MethodDefaults defaults = DefaultTolerances(SolverMethod::kBdf);
  integrator.rtol = options.rtol.value_or(defaults.rtol);
  integrator.atol = options.atol.value_or(defaults.atol);
  solution.summary = IntegrateIda(
      [&](double t, const Eigen::VectorXd& x, const Eigen::VectorXd& x_dot,
          Eigen::VectorXd& residual, std::string& reason) {
        return problem.IndexOneResidual(t, x, x_dot, residual, reason);
      },
      // No breakpoints: a restart there needs IDACalcIC, whose split into differential and
      // algebraic components must be by component, while here Eq. (15) projected on C and
      // D^T M v' mix the components. The residual reads y_d'' at most, which is continuous
      // across the breakpoints (Eq. 65 has 4 continuous derivatives), so BDF steps across.
      options.t_start, x_start, x_dot_start, differential, options.t_end, {}, integrator,
      [&](double t, const Eigen::VectorXd& x, const Eigen::VectorXd&) {
        // det P at the step, from the normal form of the same state.
        Eigen::VectorXd input, q_ddot_at_step;
        std::string reason;
        if (!problem.NormalForm(t, x.head(f), x.segment(f, f), input, q_ddot_at_step, reason) ||
            !watch.Check(t, problem.decoupling_determinant())) {
          return false;
        }
        Record(solution, t, x.head(f), x.segment(f, f), x.tail(problem.num_inputs()));
        return true;
      });
  watch.Finish(solution.summary);
}

void SolveNormalForm(ServoConstraintProblem& problem,
                     const InverseModelOptions& options,
                     const StartState& start,
                     FeedforwardSolution& solution) {
  const Eigen::Index internal = problem.num_internal();
  const Eigen::MatrixXd& directions = problem.internal_directions();
  Eigen::VectorXd internal_start(2 * internal);
  internal_start << directions.transpose() * start.q, directions.transpose() * start.q_dot;
  // The last q found: Newton's starting point for the next one (the motion is smooth).
  Eigen::VectorXd q = start.q, q_dot = start.q_dot, u, q_ddot;
  // Where q, q_dot and u were last computed: Dormand-Prince evaluates its last stage at the
  // step's end (FSAL), so the observer finds them there without a second evaluation.
  double evaluated_t = std::numeric_limits<double>::quiet_NaN();
  Eigen::VectorXd evaluated_y;
  auto state_at = [&](double t, const Eigen::VectorXd& y, std::string& why) {
    if (t == evaluated_t && y == evaluated_y) return true;
    evaluated_t = std::numeric_limits<double>::quiet_NaN();
    if (!problem.StateFromInternal(t, y.head(internal), y.tail(internal), q, q_dot, why) ||
        !problem.NormalForm(t, q, q_dot, u, q_ddot, why)) {
      return false;
    }
    evaluated_t = t;
    evaluated_y = y;
    return true;
  };
  DecouplingWatch watch;
  IntegratorOptions integrator;
  const MethodDefaults defaults = DefaultTolerances(SolverMethod::kNormalForm);
  integrator.rtol = options.rtol.value_or(defaults.rtol);
  integrator.atol = options.atol.value_or(defaults.atol);
  solution.summary = IntegrateDormandPrince(
      [&](double t, const Eigen::VectorXd& y, Eigen::VectorXd& y_dot, std::string& why) {
        if (!state_at(t, y, why)) return false;
        y_dot.resize(2 * internal);
        y_dot.head(internal) = y.tail(internal);
        y_dot.tail(internal).noalias() = directions.transpose() * q_ddot;  // Eq. (25)
        return true;
      },
      options.t_start, internal_start, options.t_end, problem.trajectory().breakpoints(),
      integrator, [&](double t, const Eigen::VectorXd& y, const Eigen::VectorXd&) {
        std::string why;
        if (!state_at(t, y, why) || !watch.Check(t, problem.decoupling_determinant())) {
          return false;
        }
        Record(solution, t, q, q_dot, u);
        return true;
      });
  watch.Finish(solution.summary);
}

// Stable inversion on the window the boundary value problem chooses (or the user fixed), from
// the equilibrium at the start of the motion to the one at its end.
void SolveByStableInversion(const Model& model,
                            const OutputTrajectory& trajectory,
                            const InverseModelOptions& options,
                            const StartState& start,
                            FeedforwardSolution& solution) {
  Workspace workspace(model);
  OperatingPointOptions end_options;
  end_options.y0 = trajectory.Derivative(trajectory.breakpoints().back(), 0);
  end_options.q_guess = start.q;
  const OperatingPoint end = FindOperatingPoint(model, workspace, end_options);
  StableInversionOptions inversion;
  inversion.tolerance = options.rtol.value_or(DefaultTolerances(SolverMethod::kStableInversion).rtol);
  inversion.pre_actuation = options.pre_actuation;
  inversion.post_actuation = options.post_actuation;
  const StableInversionSolution result =
      SolveStableInversion(model, trajectory, start.q, end.q, inversion);
  solution.summary = result.summary;
  solution.summary.steps = long(result.times.size());
  solution.times = result.times;
  solution.q = result.q;
  solution.q_dot = result.q_dot;
  solution.u = result.u;
  solution.window_start = result.window_start;
  solution.window_end = result.window_end;
  solution.pre_actuation_start = result.pre_actuation_start;
  solution.post_actuation_end = result.post_actuation_end;
  solution.boundary_value_residual = result.max_residual;
  solution.window_widenings = result.widenings;
  solution.feedforward = result.feedforward;
}

}  // namespace

void InverseModelOptions::Validate() const {
  if (!std::isfinite(t_start) || !std::isfinite(t_end) || !(t_end > t_start)) {
    throw UsageError("the time span t_start = " + FormatNumber(t_start) + ", t_end = " + FormatNumber(t_end) +
                     ": needs finite t_start < t_end");
  }
  if (!(step > 0.0) || !std::isfinite(step)) {
    throw UsageError("step = " + FormatNumber(step) + ": must be a finite number > 0");
  }
  if (rtol && !(*rtol > 0.0 && *rtol < 1.0)) {
    throw UsageError("rtol = " + FormatNumber(*rtol) + ": must be in (0, 1)");
  }
  if (atol && !(*atol > 0.0 && std::isfinite(*atol))) {
    throw UsageError("atol = " + FormatNumber(*atol) + ": must be a finite number > 0");
  }
  for (const auto& [value, name] : {std::pair{pre_actuation, "pre_actuation"},
                                    std::pair{post_actuation, "post_actuation"}}) {
    if (value && !(*value > 0.0 && std::isfinite(*value))) {
      throw UsageError(std::string(name) + " = " + FormatNumber(*value) +
                       ": must be a finite number > 0");
    }
  }
  problem.Validate();
}

FeedforwardSolution SolveInverseModel(const Model& model,
                                      const OutputTrajectory& trajectory,
                                      const Classification& classification,
                                      const InverseModelOptions& options) {
  options.Validate();
  FeedforwardSolution solution;
  std::tie(solution.method, solution.method_reason) = ChooseMethod(classification, options);
  std::shared_ptr<const AlgebraicInverse> inverse;
  if (solution.method == SolverMethod::kAlgebraic) {
    try {
      inverse = std::make_shared<const AlgebraicInverse>(model);
    } catch (const NoSolution& error) {
      // Flat at the operating point, yet not invertible by static algebra along the motion
      // (e.g. a crane, whose outputs see the inputs only through the rope force: it needs a
      // dynamic extension). Auto falls back to the projected DAE; an explicit ask fails.
      if (options.method != SolverMethod::kAuto ||
          classification.structure.projected_index > kMaxProjectedIndexForRadau) {
        throw;
      }
      solution.method = SolverMethod::kRadau;
      solution.method_reason += "; Radau IIA instead of algebraic inversion, since " +
                                std::string(error.what());
    }
  }
  ServoConstraintProblem problem(model, trajectory, classification.operating_point.q,
                                 options.problem);
  const int highest_derivative = classification.structure.differentiation_index - 1;
  const StartState start = FindStartState(model, trajectory, classification, problem,
                                          options.t_start, std::max(highest_derivative, 2));
  switch (solution.method) {
    case SolverMethod::kAlgebraic:
      SolveAlgebraic(model, trajectory, options, start, inverse, solution);
      break;
    case SolverMethod::kEuler:
    case SolverMethod::kRadau:
      SolveProjected(problem, classification, options, solution.method, start, solution);
      break;
    case SolverMethod::kBdf:
      SolveBdf(problem, options, start, solution);
      break;
    case SolverMethod::kNormalForm:
      SolveNormalForm(problem, options, start, solution);
      break;
    case SolverMethod::kStableInversion:
      SolveByStableInversion(model, trajectory, options, start, solution);
      break;
    case SolverMethod::kAuto:
      break;  // ChooseMethod() never returns it
  }
  // An integrator that stopped on a refused evaluation knows why only as text; the problem
  // knows the kind (P or M singular).
  if (!solution.summary.IsUsable() &&
      (problem.last_failure() == SolveStatus::kSingularDecoupling ||
       problem.last_failure() == SolveStatus::kSingularMass)) {
    solution.summary.status = problem.last_failure();
  }
  solution.max_servo_residual = 0.0;
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    solution.max_servo_residual =
        std::max(solution.max_servo_residual, problem.ServoResidual(solution.times[i], solution.q[i]));
  }
  if (!solution.feedforward && !solution.times.empty()) {
    solution.feedforward = SampledFeedforward(solution.times, solution.u, trajectory.breakpoints());
  }
  return solution;
}

Verification VerifyFeedforward(const Model& model,
                               const OutputTrajectory& trajectory,
                               const FeedforwardSolution& solution,
                               const IntegratorOptions& options) {
  if (solution.times.empty() || !solution.feedforward) {
    throw UsageError("nothing to verify: the solution has no samples");
  }
  const Eigen::Index f = Eigen::Index(model.dof());
  Workspace workspace(model);
  constexpr unsigned kForwardDynamics =
      Quantity::kMassMatrix | Quantity::kForces | Quantity::kInputMatrix;
  Eigen::VectorXd state(2 * f);
  state << solution.q.front(), solution.q_dot.front();
  Verification verification;
  verification.max_tracking_error = 0.0;
  verification.time_of_max_error = solution.times.front();
  const double t_end = solution.times.back();  // where the solve stopped, if it failed
  verification.summary = IntegrateBdf(
      [&](double t, const Eigen::VectorXd& y, Eigen::VectorXd& y_dot, std::string& why) {
        Evaluate(model, workspace, y.head(f), y.tail(f), kForwardDynamics);
        const Eigen::VectorXd u = solution.feedforward(t);
        if (!u.allFinite()) {
          why = "u_d is not finite at t = " + FormatNumber(t);
          return false;
        }
        const Eigen::LLT<Eigen::MatrixXd> mass_factor(workspace.mass_matrix);
        if (mass_factor.info() != Eigen::Success) {
          why = "M(q) is not positive definite";
          return false;
        }
        y_dot.resize(2 * f);
        y_dot << y.tail(f), mass_factor.solve(workspace.input_matrix * u - workspace.forces);
        return true;
      },
      solution.times.front(), state, t_end, trajectory.breakpoints(), options,
      [&](double t, const Eigen::VectorXd& y, const Eigen::VectorXd&) {
        Evaluate(model, workspace, y.head(f), y.tail(f), Quantity::kOutput);
        const double error = (workspace.output - trajectory.Derivative(t, 0)).cwiseAbs().maxCoeff();
        if (error > verification.max_tracking_error) {
          verification.max_tracking_error = error;
          verification.time_of_max_error = t;
        }
        return true;
      });
  return verification;
}

}  // namespace servokit
