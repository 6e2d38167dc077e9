#include "solvers/inverse_model.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "analysis/decoupling_matrix.h"
#include "analysis/operating_point.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "base/option_check.h"
#include "integrators/dense_output.h"
#include "integrators/radau.h"
#include "integrators/sundials_integrators.h"
#include "solvers/algebraic_inversion.h"
#include "solvers/closed_chain.h"
#include "solvers/linearized_inverse.h"
#include "solvers/method_choice.h"
#include "solvers/output_normal_form.h"
#include "solvers/stable_inversion.h"

namespace servokit {
namespace {

// The trajectory counts as at rest at t_start when its derivatives there are below this
// (they are exactly zero before t0 for rest-to-rest trajectories).
constexpr double kRestTolerance = 1e-14;
// A sample time divides a span when the span holds a whole number of samples to this relative
// precision (0.1 s into 4 s: 40.000000000000003).
constexpr double kWholeSamplesTolerance = 1e-9;
// More rows than this is a mistake (a sample time in ms given as s), not a controller's grid.
constexpr double kMaxSamples = 1e8;
// Two grid or breakpoint times closer than this, relative to 1 + |t|, are one.
constexpr double kSameTimeTolerance = 1e-12;

// P = H M^-1 B has full rank at the operating point (an orthogonal realization).
bool DecouplingRegular(const Classification& classification) {
  return classification.decoupling.rank == classification.decoupling.decoupling_matrix.rows();
}

std::string Seconds(double t) { return FormatNumber(t) + " s"; }

// The start of the motion: at rest at the equilibrium with h(q) = y_d(t_start) when the
// trajectory rests there; otherwise, for the algebraic inverse, that equilibrium as Newton's
// first guess of the state y_d and its derivatives determine (a flat problem has no free
// state: issue #33), and for orthogonal realizations the internal coordinates at that
// equilibrium and at rest while the output moves.
struct StartState {
  Eigen::VectorXd q, q_dot, u;
};

StartState FindStartState(const Model& model,
                          const OutputTrajectory& trajectory,
                          const Classification& classification,
                          SolverMethod method,
                          ServoConstraintProblem& problem,
                          double t_start) {
  Workspace workspace(model);
  OperatingPointOptions equilibrium_options;
  equilibrium_options.y0 = trajectory.Derivative(t_start, 0);
  equilibrium_options.q_guess = classification.operating_point.q;
  const OperatingPoint equilibrium = FindOperatingPoint(model, workspace, equilibrium_options);

  const int highest_derivative = std::max(classification.structure.differentiation_index - 1, 2);
  bool at_rest = true;
  for (int order = 1; order <= highest_derivative; ++order) {
    at_rest = at_rest && trajectory.Derivative(t_start, order).norm() <= kRestTolerance;
  }
  StartState start{equilibrium.q, Eigen::VectorXd::Zero(problem.dof()), equilibrium.u};
  if (at_rest || method == SolverMethod::kAlgebraic) return start;
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

// The method's name in a message: "bdf (auto's choice)" when auto chose it.
std::string MethodName(const FeedforwardSolution& solution) {
  return std::string(ToString(solution.method)) +
         (solution.method_reason.rfind("auto", 0) == 0 ? " (auto's choice)" : "");
}

// Settings the method does not read, and tolerances outside its range, are errors.
void CheckSettingsFor(const FeedforwardSolution& solution,
                      const InverseModelOptions& options,
                      const Classification& classification) {
  const MethodSettings& settings = SettingsOf(solution.method);
  const std::string method = MethodName(solution);
  const auto refuse = [&](SolveSetting setting, const std::string& why) {
    throw SettingError(setting, "the " + std::string(ToString(setting)) + " is not used by " +
                                    method + ": " + why);
  };
  if (options.step && !settings.uses_step) {
    refuse(SolveSetting::kStep, "it chooses its own steps (a fixed step is euler's)");
  }
  if (options.step && solution.method == SolverMethod::kAlgebraic && options.sample_time) {
    refuse(SolveSetting::kStep,
           "it is evaluated at the sample times; the step spaces its own points without them");
  }
  if (!settings.uses_tolerances && (options.rtol || options.atol)) {
    refuse(options.rtol ? SolveSetting::kRelativeTolerance : SolveSetting::kAbsoluteTolerance,
           "it is exact up to round-off and has no tolerance");
  }
  if (!settings.uses_actuation && (options.pre_actuation || options.post_actuation)) {
    refuse(options.pre_actuation ? SolveSetting::kPreActuation : SolveSetting::kPostActuation,
           "only stable inversion acts before and after the motion");
  }
  // Forcing makes a forward method integrate unstable zero dynamics; anywhere else it would
  // be silently meaningless.
  if (options.force && !settings.forward) {
    throw SettingError(SolveSetting::kForce, "nothing to force: " + method +
                                                 " does not integrate the internal dynamics "
                                                 "forward");
  }
  if (options.force && classification.zero_dynamics.stability != Stability::kUnstable) {
    throw SettingError(SolveSetting::kForce,
                       "nothing to force: the zero dynamics are " +
                           std::string(ToString(classification.zero_dynamics.stability)) +
                           ", not unstable");
  }
  CheckTolerances(solution.method, options.rtol, options.atol);
}

// The tolerances the method runs with.
SolveAccuracy AccuracyOf(SolverMethod method, const InverseModelOptions& options) {
  const MethodSettings& settings = SettingsOf(method);
  SolveAccuracy accuracy;
  if (settings.uses_tolerances) {
    accuracy.rtol = options.rtol.value_or(settings.default_rtol);
    accuracy.atol = options.atol.value_or(settings.default_atol);
  }
  if (method == SolverMethod::kEuler) accuracy.step = options.step.value_or(settings.default_step);
  return accuracy;
}

// Sample times of the fixed grid t_start + k step, with the breakpoints in between.
std::vector<double> FixedGrid(double t_start,
                              double t_end,
                              double step,
                              const std::vector<double>& breakpoints) {
  std::vector<double> times;
  const long count = long(std::ceil((t_end - t_start) / step - kWholeSamplesTolerance));
  for (long k = 0; k < count; ++k) times.push_back(t_start + double(k) * step);
  times.push_back(t_end);
  for (double breakpoint : breakpoints) {
    if (breakpoint > t_start && breakpoint < t_end) times.push_back(breakpoint);
  }
  std::sort(times.begin(), times.end());
  times.erase(std::unique(times.begin(), times.end(),
                          [](double a, double b) {
                            return std::abs(a - b) <= kSameTimeTolerance * (1 + std::abs(a));
                          }),
              times.end());
  return times;
}

// Appends a row, replacing one at the same time (an integrator restarting at a breakpoint
// reports that time twice).
void Record(FeedforwardSolution& solution,
            double t,
            const Eigen::VectorXd& q,
            const Eigen::VectorXd& q_dot,
            const Eigen::VectorXd& u) {
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

void ClearRows(FeedforwardSolution& solution) {
  solution.times.clear();
  solution.q.clear();
  solution.q_dot.clear();
  solution.u.clear();
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
      message_ = "P = H M^-1 B is singular between t = " + FormatNumber(previous_time_) +
                 " s and " + FormatNumber(t) + " s (det P changes sign from " +
                 FormatNumber(previous_) + " to " + FormatNumber(determinant) +
                 "): u_d has a pole there";
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

void SolveAlgebraic(const Model& model,
                    const OutputTrajectory& trajectory,
                    const std::vector<double>& times,
                    const StartState& start,
                    std::shared_ptr<const AlgebraicInverse> inverse,
                    FeedforwardSolution& solution) {
  const int highest = inverse->highest_output_derivative();
  Eigen::VectorXd q = start.q, q_dot = start.q_dot, u;
  Eigen::MatrixXd derivatives;
  std::string why;
  solution.summary.status = SolveStatus::kConverged;
  for (double t : times) {
    trajectory.Derivatives(t, highest, derivatives);
    if (!inverse->Evaluate(derivatives, model.parameters(), q, q_dot, u, why)) {
      solution.summary.status = SolveStatus::kNoConvergence;
      solution.summary.message = "at t = " + Seconds(t) + ": " + why;
      solution.summary.stop_time = t;
      break;
    }
    ++solution.summary.steps;
    Record(solution, t, q, q_dot, u);
  }
  if (solution.summary.IsUsable()) {
    solution.summary.stop_time = times.back();
    solution.summary.message = "evaluated at " + std::to_string(solution.times.size()) + " times";
  }
  if (!solution.times.empty()) {
    solution.extension =
        AlgebraicMotion(inverse, model, trajectory, solution.times, solution.q, solution.q_dot);
  }
}

// An accepted step of a DAE method (state x = [q, q', u]) recorded as a row. With a watch, det P
// is first checked against the last step's sign, from the normal form of the same state: a pole
// of u_d between two steps is otherwise stepped over, writing F ~ 1e18 N. False stops the
// integrator.
bool RecordWatchedStep(ServoConstraintProblem& problem,
                       DecouplingWatch* watch,
                       double t,
                       const Eigen::VectorXd& x,
                       FeedforwardSolution& solution) {
  const Eigen::Index f = problem.dof();
  if (watch) {
    Eigen::VectorXd input, q_ddot;
    std::string reason;
    if (!problem.NormalForm(t, x.head(f), x.segment(f, f), input, q_ddot, reason) ||
        !watch->Check(t, problem.decoupling_determinant())) {
      return false;
    }
  }
  Record(solution, t, x.head(f), x.segment(f, f), x.tail(problem.num_inputs()));
  return true;
}

void SolveProjected(ServoConstraintProblem& problem,
                    const Classification& classification,
                    const StartState& start,
                    bool keep_extension,
                    FeedforwardSolution& solution) {
  const Eigen::Index f = problem.dof();
  const bool decoupling_regular = DecouplingRegular(classification);
  ProjectedDae dae(problem, decoupling_regular);
  Eigen::VectorXd x_start(dae.size());
  x_start << start.q, start.q_dot, start.u;
  RadauOptions radau;
  radau.rtol = solution.accuracy.rtol;
  radau.atol = solution.accuracy.atol;
  if (solution.method == SolverMethod::kEuler) {
    radau.stages = 1;
    radau.fixed_step = *solution.accuracy.step;
  }
  DecouplingWatch watch;
  DenseOutput states(dae.size());
  solution.summary = IntegrateRadau(
      dae, solution.t_start, x_start, solution.t_end, problem.trajectory().breakpoints(), radau,
      // With P regular at the operating point, u is index 2 and det P must keep its sign.
      [&](double t, const Eigen::VectorXd& x) {
        return RecordWatchedStep(problem, decoupling_regular ? &watch : nullptr, t, x, solution);
      },
      keep_extension ? &states : nullptr);
  watch.Finish(solution.summary);
  if (!states.empty()) solution.extension = InterpolatedMotion(std::move(states), f);
}

void SolveBdf(ServoConstraintProblem& problem,
              const StartState& start,
              bool keep_extension,
              FeedforwardSolution& solution) {
  const Eigen::Index f = problem.dof();
  const Eigen::Index n = 2 * f + problem.num_inputs();
  Eigen::VectorXd x_start(n), x_dot_start(n), u, q_ddot;
  std::string why;
  if (!problem.NormalForm(solution.t_start, start.q, start.q_dot, u, q_ddot, why)) {
    throw NoSolution("no consistent start at t_start = " + FormatNumber(solution.t_start) + ": " +
                     why);
  }
  x_start << start.q, start.q_dot, u;
  x_dot_start << start.q_dot, q_ddot, Eigen::VectorXd::Zero(problem.num_inputs());
  DecouplingWatch watch;
  std::vector<bool> differential(std::size_t(n), true);
  for (Eigen::Index i = 2 * f; i < n; ++i) differential[std::size_t(i)] = false;
  IntegratorOptions integrator;
  integrator.rtol = solution.accuracy.rtol;
  integrator.atol = solution.accuracy.atol;
  DenseOutput states(n);
  solution.summary = IntegrateIda(
      [&](double t, const Eigen::VectorXd& x, const Eigen::VectorXd& x_dot,
          Eigen::VectorXd& residual,
          std::string& reason) { return problem.IndexOneResidual(t, x, x_dot, residual, reason); },
      // No breakpoints: the residual reads y_d'' at most, which is continuous across them
      // (Eq. 65 has 4 continuous derivatives), so BDF steps across.
      solution.t_start, x_start, x_dot_start, differential, solution.t_end, {}, integrator,
      [&](double t, const Eigen::VectorXd& x, const Eigen::VectorXd&) {
        return RecordWatchedStep(problem, &watch, t, x, solution);
      },
      keep_extension ? &states : nullptr);
  watch.Finish(solution.summary);
  if (!states.empty()) solution.extension = InterpolatedMotion(std::move(states), f);
}

void SolveNormalForm(const std::shared_ptr<ServoConstraintProblem>& shared_problem,
                     const StartState& start,
                     bool keep_extension,
                     FeedforwardSolution& solution) {
  ServoConstraintProblem& problem = *shared_problem;
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
  integrator.rtol = solution.accuracy.rtol;
  integrator.atol = solution.accuracy.atol;
  auto internal_states = std::make_shared<DenseOutput>(2 * internal);
  solution.summary = IntegrateDormandPrince(
      [&](double t, const Eigen::VectorXd& y, Eigen::VectorXd& y_dot, std::string& why) {
        if (!state_at(t, y, why)) return false;
        y_dot.resize(2 * internal);
        y_dot.head(internal) = y.tail(internal);
        y_dot.tail(internal).noalias() = directions.transpose() * q_ddot;  // Eq. (25)
        return true;
      },
      solution.t_start, internal_start, solution.t_end, problem.trajectory().breakpoints(),
      integrator,
      [&](double t, const Eigen::VectorXd& y, const Eigen::VectorXd&) {
        std::string why;
        if (!state_at(t, y, why) || !watch.Check(t, problem.decoupling_determinant())) {
          return false;
        }
        Record(solution, t, q, q_dot, u);
        return true;
      },
      keep_extension ? internal_states.get() : nullptr);
  watch.Finish(solution.summary);
  if (!internal_states->empty()) {
    solution.extension = InternalMotion(
        shared_problem, [internal_states](double t) { return (*internal_states)(t); }, start.q,
        internal_states->start(), internal_states->end());
  }
}

// Replaces the rows by the extension at the sample times up to where the solve stopped.
void SampleRows(const std::vector<double>& grid, FeedforwardSolution& solution) {
  ClearRows(solution);
  if (!solution.extension) return;
  const double reached = solution.extension->end();
  Eigen::VectorXd q, q_dot, u;
  std::string why;
  for (const double t : grid) {
    if (t > reached + kSameTimeTolerance * (1.0 + std::abs(reached))) break;
    if (!solution.extension->Evaluate(t, q, q_dot, u, why)) {
      solution.summary.status = SolveStatus::kNoConvergence;
      solution.summary.message = "at t = " + Seconds(t) + ": " + why;
      solution.summary.stop_time = t;
      return;
    }
    Record(solution, t, q, q_dot, u);
  }
}

// The normal form of any vector relative degree: the internal coordinates integrated with
// Dormand-Prince. With none left (a flat problem) it is the algebraic inverse itself.
// Whether the internal dynamics are stiff over the span: asymptotically stable, and so fast
// that Dormand-Prince's stability limit (|lambda| h <= 3.3) alone would need more than
// kStiffStepBudget steps. Critical (undamped) zero dynamics stay explicit: BDF would damp them.
constexpr double kExplicitStabilityLimit = 3.3;
constexpr double kStiffStepBudget = 5000.0;
// BDF's global error on the internal dynamics is 10-100 times its local tolerance (measured
// on a chain whose zero dynamics reach 5e4/s: 1.5e-8 at rtol 1e-10, 1.8e-10 at 1e-12), so it
// runs at this fraction of rtol to deliver the accuracy asked for.
constexpr double kBdfToleranceFactor = 1e-2;
// Below this CVODE's BDF stalls on round-off.
constexpr double kMinBdfRelativeTolerance = 1e-14;

std::optional<double> StiffRate(const Classification& classification, double span) {
  if (classification.zero_dynamics.stability != Stability::kAsymptoticallyStable) {
    return std::nullopt;
  }
  double fastest = 0.0;
  for (const auto& value : classification.zero_dynamics.eigenvalues) {
    fastest = std::max(fastest, std::abs(value));
  }
  if (fastest * span / kExplicitStabilityLimit <= kStiffStepBudget) return std::nullopt;
  return fastest;
}

void SolveOutputNormalForm(const Model& model,
                           const OutputTrajectory& trajectory,
                           const Classification& classification,
                           const std::shared_ptr<const AlgebraicInverse>& form,
                           const StartState& start,
                           bool keep_extension,
                           FeedforwardSolution& solution) {
  const Eigen::Index internal = form->internal_order();
  if (internal == 0) {
    SolveAlgebraic(
        model, trajectory,
        FixedGrid(solution.t_start, solution.t_end,
                  SettingsOf(SolverMethod::kAlgebraic).default_step, trajectory.breakpoints()),
        start, form, solution);
    return;
  }
  Eigen::VectorXd state_start(2 * start.q.size());
  state_start << start.q, start.q_dot;
  const Eigen::VectorXd internal_start = form->internal_directions().transpose() * state_start;
  OutputNormalFormMap map(model, trajectory, form, start.q, start.q_dot);
  Eigen::VectorXd q, q_dot, u;
  // Where q, q_dot and u were last computed: Dormand-Prince evaluates its last stage at the
  // step's end (FSAL), so the observer finds them there without a second Newton solve.
  double evaluated_t = std::numeric_limits<double>::quiet_NaN();
  Eigen::VectorXd evaluated_z;
  const auto state_at = [&](double t, const Eigen::VectorXd& z, std::string& why) {
    if (t == evaluated_t && z == evaluated_z) return true;
    evaluated_t = std::numeric_limits<double>::quiet_NaN();
    if (!map.State(t, z, q, q_dot, u, why)) return false;
    evaluated_t = t;
    evaluated_z = z;
    return true;
  };
  IntegratorOptions integrator;
  integrator.rtol = solution.accuracy.rtol;
  integrator.atol = solution.accuracy.atol;
  auto internal_states = std::make_shared<DenseOutput>(internal);
  const OdeRightHandSide rhs = [&](double t, const Eigen::VectorXd& z, Eigen::VectorXd& z_dot,
                                   std::string& why) {
    return state_at(t, z, why) && map.InternalDerivative(u, z_dot, why);
  };
  const IntegratorObserver observer = [&](double t, const Eigen::VectorXd& z,
                                          const Eigen::VectorXd&) {
    std::string why;
    if (!state_at(t, z, why)) return false;
    Record(solution, t, q, q_dot, u);
    return true;
  };
  DenseOutput* dense = keep_extension ? internal_states.get() : nullptr;
  if (const std::optional<double> rate =
          StiffRate(classification, solution.t_end - solution.t_start)) {
    // Stiff: CVODE's BDF (ode15s), whose steps follow the accuracy, not the fastest mode.
    IntegratorOptions bdf = integrator;
    bdf.rtol = std::max(kBdfToleranceFactor * integrator.rtol, kMinBdfRelativeTolerance);
    bdf.atol = kBdfToleranceFactor * integrator.atol;
    solution.summary = IntegrateBdf(rhs, solution.t_start, internal_start, solution.t_end,
                                    trajectory.breakpoints(), bdf, observer, dense);
    solution.method_reason += "; the internal dynamics are stiff (zero dynamics up to " +
                              FormatNumber(*rate) + "/s over " +
                              Seconds(solution.t_end - solution.t_start) +
                              "): integrated with CVODE's BDF, not Dormand-Prince";
  } else {
    solution.summary =
        IntegrateDormandPrince(rhs, solution.t_start, internal_start, solution.t_end,
                               trajectory.breakpoints(), integrator, observer, dense);
  }
  // The input equations' matrix singular along the motion: the general form of P singular.
  if (!solution.summary.IsUsable() && map.singular_inputs()) {
    solution.summary.status = SolveStatus::kSingularDecoupling;
  }
  if (internal_states->empty()) return;
  // The extension maps the dense output through a map of its own (its own Newton starts).
  auto extension_map =
      std::make_shared<OutputNormalFormMap>(model, trajectory, form, start.q, start.q_dot);
  solution.extension = MappedMotion(
      [extension_map](double t, const Eigen::VectorXd& z, Eigen::VectorXd& q_at,
                      Eigen::VectorXd& q_dot_at, Eigen::VectorXd& u_at, std::string& why) {
        return extension_map->State(t, z, q_at, q_dot_at, u_at, why);
      },
      [internal_states](double t) { return (*internal_states)(t); }, internal_states->start(),
      internal_states->end());
}

// The equilibrium at rest with h(q) = y_d(t).
OperatingPoint RestAt(const Model& model,
                      const OutputTrajectory& trajectory,
                      double t,
                      const Eigen::VectorXd& q_guess) {
  return FindRestPoint(model, trajectory.Derivative(t, 0), q_guess);
}

// The stable inversion's settings: the method's accuracy, and the window's sides the user fixed.
StableInversionOptions StableInversionSettings(const SolveAccuracy& accuracy,
                                               const InverseModelOptions& options) {
  StableInversionOptions inversion;
  inversion.tolerance = accuracy.rtol;
  inversion.absolute_tolerance = accuracy.atol;
  inversion.pre_actuation = options.pre_actuation;
  inversion.post_actuation = options.post_actuation;
  return inversion;
}

// A warning for each end of the span where u_d is not at rest (the span cuts the window's
// pre- or post-actuation short).
void WarnWhereNotAtRest(const StableInversionWindow& window, FeedforwardSolution& solution) {
  if (window.pre_actuation_start < solution.t_start) {
    solution.warnings.push_back("u_d is not at rest at t_start = " + Seconds(solution.t_start) +
                                ": the pre-actuation starts at " +
                                Seconds(window.pre_actuation_start) +
                                "; the motion written starts from a state that is not at rest");
  }
  if (window.post_actuation_end > solution.t_end) {
    solution.warnings.push_back("u_d is not at rest at t_end = " + Seconds(solution.t_end) +
                                ": the post-actuation goes on until " +
                                Seconds(window.post_actuation_end));
  }
}

// The method's own points within [t_start, t_end]: the mesh inside the span, and its ends.
std::vector<double> MeshInSpan(const std::vector<double>& mesh, double t_start, double t_end) {
  std::vector<double> times = {t_start};
  for (const double t : mesh) {
    if (t > t_start && t < t_end) times.push_back(t);
  }
  times.push_back(t_end);
  return times;
}

// Stable inversion on the window the boundary value problem chooses (or the user fixed), from
// the equilibrium at the start of the motion to the one at its end, then cut or padded with
// the rest states to [t_start, t_end].
void SolveByStableInversion(const Model& model,
                            const OutputTrajectory& trajectory,
                            const Classification& classification,
                            const InverseModelOptions& options,
                            const std::shared_ptr<const AlgebraicInverse>& output_normal_form,
                            FeedforwardSolution& solution) {
  const std::vector<double> breakpoints = trajectory.breakpoints();
  const OperatingPoint start =
      RestAt(model, trajectory, breakpoints.front(), classification.operating_point.q);
  const OperatingPoint end = RestAt(model, trajectory, breakpoints.back(), start.q);
  const StableInversionOptions inversion = StableInversionSettings(solution.accuracy, options);
  // P regular: the normal form of Eq. (25); otherwise the input-output normal form.
  const StableInversionSolution result =
      output_normal_form ? SolveOutputStableInversion(model, trajectory, output_normal_form,
                                                      start.q, end.q, inversion)
                         : SolveStableInversion(model, trajectory, start.q, end.q, inversion);
  solution.summary = result.summary;
  solution.summary.steps = long(result.times.size());
  solution.window = result.window;
  if (!result.extension) return;
  // The span: unset t_start begins with the window (its pre-actuation).
  if (!options.t_start) solution.t_start = std::min(result.window.start, breakpoints.front());
  solution.extension = PaddedWithRest(result.extension, solution.t_start, solution.t_end,
                                      {start.q, start.u}, {end.q, end.u});
  WarnWhereNotAtRest(result.window, solution);
  SampleRows(MeshInSpan(result.times, solution.t_start, solution.t_end), solution);
  if (solution.summary.IsUsable()) solution.summary.stop_time = solution.t_end;
}

// max |h(q) - y_d| over the solution's rows.
double MaxServoResidual(ServoConstraintProblem& problem, const FeedforwardSolution& solution) {
  double residual = 0.0;
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    residual = std::max(residual, problem.ServoResidual(solution.times[i], solution.q[i]));
  }
  return residual;
}

// The grid of sample_time for a span whose start is only known after a stable inversion:
// anchored at `anchor` (t_start, or the motion's start) and reaching back to cover t_start.
std::vector<double> GridCovering(double t_start, double t_end, double anchor, double sample_time) {
  const double samples_before =
      std::ceil((anchor - t_start) / sample_time - kWholeSamplesTolerance);
  return SampleGrid(anchor - std::max(samples_before, 0.0) * sample_time, t_end, sample_time);
}

// The span [t_start, t_end]: t_end not before the motion ends, t_start the trajectory's start
// unless set (stable inversion moves it to its window later). A sample time that does not
// divide the span is refused here, before any work.
void ResolveSpan(const OutputTrajectory& trajectory,
                 const InverseModelOptions& options,
                 FeedforwardSolution& solution) {
  const std::vector<double> breakpoints = trajectory.breakpoints();
  if (options.t_end < breakpoints.back()) {
    throw SettingError(SolveSetting::kEndTime, "the end time " + Seconds(options.t_end) +
                                                   " comes before the motion ends, at " +
                                                   Seconds(breakpoints.back()));
  }
  solution.t_start = options.t_start.value_or(breakpoints.front());
  solution.t_end = options.t_end;
  solution.sample_time = options.sample_time;
  if (options.sample_time) SampleGrid(solution.t_start, solution.t_end, *options.sample_time);
}

// Every method but stable inversion: from the start state at t_start forward to t_end.
// Below this fraction of |H| |M^-1 B| the smallest singular value of P at the last row of a
// solve that stopped marks a singularity of the inverse there: u_d ~ P^-1 grows without bound
// as it is approached, which the integrators see as steps shrinking to nothing.
constexpr double kNearSingularDecoupling = 1e-6;

// Where a forward solve of a problem with P regular at the operating point stopped early: when P
// is nearly singular at the last row, a note that names it (the time and the singular value),
// so that the message says why, not only how the integrator stopped (issue #33). Empty else.
std::string SingularityNote(const Model& model, const FeedforwardSolution& solution) {
  if (solution.times.empty()) return "";
  Workspace workspace(model);
  const Eigen::VectorXd& q = solution.q.back();
  Evaluate(model, workspace, q, Eigen::VectorXd::Zero(q.size()),
           Quantity::kMassMatrix | Quantity::kInputMatrix | Quantity::kOutputJacobian);
  const Eigen::LLT<Eigen::MatrixXd> mass(workspace.mass_matrix);
  if (mass.info() != Eigen::Success) return "";
  const Eigen::MatrixXd input_accelerations = mass.solve(workspace.input_matrix);
  const Eigen::MatrixXd decoupling =
      DecouplingMatrix(workspace.output_jacobian, input_accelerations);
  const Eigen::VectorXd singular = Eigen::JacobiSVD<Eigen::MatrixXd>(decoupling).singularValues();
  const double scale = workspace.output_jacobian.norm() * input_accelerations.norm();
  if (singular.size() == 0 || !(scale > 0.0)) return "";
  const double smallest = singular(singular.size() - 1) / scale;
  if (!(smallest <= kNearSingularDecoupling)) return "";
  return "; P = H M^-1 B, regular at the operating point, is nearly singular at t = " +
         Seconds(solution.times.back()) + " (smallest singular value " +
         FormatSignificant(smallest, 3) +
         " of |H| |M^-1 B|): u_d grows without bound there, so no inverse continues through "
         "that point along this motion";
}

void SolveForward(const Model& model,
                  const OutputTrajectory& trajectory,
                  const Classification& classification,
                  const InverseModelOptions& options,
                  const MethodChooser& chooser,
                  const std::shared_ptr<ServoConstraintProblem>& problem,
                  FeedforwardSolution& solution) {
  const StartState start = FindStartState(model, trajectory, classification, solution.method,
                                          *problem, solution.t_start);
  const bool keep_extension = options.continuous_extension || options.sample_time;
  switch (solution.method) {
    case SolverMethod::kAlgebraic: {
      const std::vector<double> times =
          options.sample_time
              ? SampleGrid(solution.t_start, solution.t_end, *options.sample_time)
              : FixedGrid(solution.t_start, solution.t_end,
                          options.step.value_or(SettingsOf(solution.method).default_step),
                          trajectory.breakpoints());
      SolveAlgebraic(model, trajectory, times, start, chooser.algebraic_inverse(), solution);
      break;
    }
    case SolverMethod::kEuler:
    case SolverMethod::kRadau:
      SolveProjected(*problem, classification, start, keep_extension, solution);
      break;
    case SolverMethod::kBdf:
      SolveBdf(*problem, start, keep_extension, solution);
      break;
    case SolverMethod::kNormalForm:
      if (chooser.output_normal_form()) {
        SolveOutputNormalForm(model, trajectory, classification, chooser.output_normal_form(),
                              start, keep_extension, solution);
      } else {
        SolveNormalForm(problem, start, keep_extension, solution);
      }
      break;
    case SolverMethod::kStableInversion:
    case SolverMethod::kLinearized:
    case SolverMethod::kAuto:
      break;  // not forward; Choose() never returns kAuto
  }
  if (!solution.summary.IsUsable() && DecouplingRegular(classification)) {
    solution.summary.message += SingularityNote(model, solution);
  }
  // An integrator that stopped on a refused evaluation knows why only as text; the problem
  // knows the kind (P or M singular).
  if (!solution.summary.IsUsable() &&
      (problem->last_failure() == SolveStatus::kSingularDecoupling ||
       problem->last_failure() == SolveStatus::kSingularMass)) {
    solution.summary.status = problem->last_failure();
  }
}

// The rest of a solve once its method (never kLinearized) is chosen and its settings checked:
// the span, the method's run, the rows on the sample grid, the servo residual.
void SolveByChosenMethod(const Model& model,
                         const OutputTrajectory& trajectory,
                         const Classification& classification,
                         const InverseModelOptions& options,
                         MethodChooser& chooser,
                         FeedforwardSolution& solution) {
  solution.accuracy = AccuracyOf(solution.method, options);
  ResolveSpan(trajectory, options, solution);
  const double grid_anchor = solution.t_start;

  const auto problem = std::make_shared<ServoConstraintProblem>(
      model, trajectory, classification.operating_point.q, options.problem);
  if (solution.method == SolverMethod::kStableInversion) {
    SolveByStableInversion(model, trajectory, classification, options, chooser.output_normal_form(),
                           solution);
  } else {
    SolveForward(model, trajectory, classification, options, chooser, problem, solution);
  }
  if (options.sample_time && solution.method != SolverMethod::kAlgebraic) {
    SampleRows(GridCovering(solution.t_start, solution.t_end, grid_anchor, *options.sample_time),
               solution);
    if (!solution.times.empty()) solution.t_start = solution.times.front();
  }
  solution.max_servo_residual = MaxServoResidual(*problem, solution);
}

// The method `linearized`: the deviation problem solved by the exact linear method that fits
// it, shifted back to the operating point; its servo residual is the nonlinear model's.
FeedforwardSolution SolveLinearization(const Model& model,
                                       const OutputTrajectory& trajectory,
                                       const Classification& classification,
                                       const InverseModelOptions& options) {
  std::shared_ptr<DeviationProblem> deviation =
      MakeDeviationProblem(model, trajectory, classification);
  InverseModelOptions linear_options = options;
  linear_options.method = ExactLinearInverseMethod(deviation->classification);
  MethodChooser chooser(deviation->model, deviation->classification, options.force);
  FeedforwardSolution solution;
  std::tie(solution.method, solution.method_reason) = chooser.Choose(linear_options.method);
  CheckSettingsFor(solution, linear_options, deviation->classification);
  SolveByChosenMethod(deviation->model, *deviation->trajectory, deviation->classification,
                      linear_options, chooser, solution);
  ShiftToOperatingPoint(std::move(deviation), classification, solution);
  ServoConstraintProblem problem(model, trajectory, classification.operating_point.q,
                                 options.problem);
  solution.max_servo_residual = MaxServoResidual(problem, solution);
  return solution;
}

}  // namespace

void InverseModelOptions::Validate() const {
  const auto require = [](bool valid, SolveSetting setting, const std::string& what) {
    if (!valid) throw SettingError(setting, what);
  };
  require(std::isfinite(t_end), SolveSetting::kEndTime,
          "the end time " + FormatNumber(t_end) + " is not a finite number");
  if (t_start) {
    require(std::isfinite(*t_start), SolveSetting::kStartTime,
            "the start time " + FormatNumber(*t_start) + " is not a finite number");
    require(*t_start < t_end, SolveSetting::kStartTime,
            "the start time " + FormatNumber(*t_start) + " s is not before the end time " +
                FormatNumber(t_end) + " s");
  }
  for (const auto& [value, setting] :
       {std::pair{step, SolveSetting::kStep}, std::pair{sample_time, SolveSetting::kSampleTime},
        std::pair{pre_actuation, SolveSetting::kPreActuation},
        std::pair{post_actuation, SolveSetting::kPostActuation}}) {
    require(!value || (std::isfinite(*value) && *value > 0.0), setting,
            "the " + std::string(ToString(setting)) + " " + FormatNumber(value.value_or(0.0)) +
                " s is not a finite number > 0");
  }
  problem.Validate();
}

std::vector<double> SampleGrid(double t_start, double t_end, double sample_time) {
  if (!(std::isfinite(sample_time) && sample_time > 0.0)) {
    throw SettingError(SolveSetting::kSampleTime, "the sample time " + FormatNumber(sample_time) +
                                                      " s is not a finite number > 0");
  }
  const double samples = (t_end - t_start) / sample_time;
  const double whole = std::round(samples);
  if (!(std::abs(samples - whole) <= kWholeSamplesTolerance * std::max(1.0, whole)) ||
      whole < 1.0) {
    throw SettingError(SolveSetting::kSampleTime,
                       "the sample time " + FormatNumber(sample_time) +
                           " s does not divide the span from " + Seconds(t_start) + " to " +
                           Seconds(t_end) + " (" + FormatNumber(samples) +
                           " samples): choose the end time " +
                           FormatNumber(t_start + std::ceil(samples) * sample_time) +
                           " s or a sample time that divides it");
  }
  if (whole > kMaxSamples) {
    throw SettingError(SolveSetting::kSampleTime, "the sample time " + FormatNumber(sample_time) +
                                                      " s gives " + FormatNumber(whole) +
                                                      " samples, more than " +
                                                      FormatNumber(kMaxSamples));
  }
  const auto count = static_cast<std::size_t>(whole);
  std::vector<double> grid(count + 1);
  for (std::size_t k = 0; k < count; ++k) grid[k] = t_start + double(k) * sample_time;
  grid[count] = t_end;
  return grid;
}

FeedforwardSolution SolveInverseModel(const Model& model,
                                      const OutputTrajectory& trajectory,
                                      const Classification& classification,
                                      const InverseModelOptions& options) {
  options.Validate();
  if (model.num_constraints() > 0) {
    const LoopsAsServoProblem open_chain =
        MakeLoopsAsServoProblem(model, trajectory, classification);
    FeedforwardSolution solution = SolveInverseModel(*open_chain.model, *open_chain.trajectory,
                                                     open_chain.classification, options);
    SplitMultipliers(open_chain, model.num_inputs(), solution);
    return solution;
  }
  MethodChooser chooser(model, classification, options.force);
  FeedforwardSolution solution;
  std::tie(solution.method, solution.method_reason) = chooser.Choose(options.method);
  CheckSettingsFor(solution, options, classification);
  if (solution.method == SolverMethod::kLinearized) {
    return SolveLinearization(model, trajectory, classification, options);
  }
  SolveByChosenMethod(model, trajectory, classification, options, chooser, solution);
  return solution;
}

}  // namespace servokit
