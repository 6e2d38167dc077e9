#include "solvers/verification.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "analysis/operating_point.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "base/option_check.h"
#include "integrators/sundials_integrators.h"
#include "solvers/forward_model.h"

namespace servokit {
namespace {

// The forward runs are held to this fraction of the solve's relative tolerance, within
// [kMinForwardRtol, kMaxForwardRtol]: tight enough that their own error stays far below the
// bound, and no tighter than CVODE's BDF reliably gets in double precision. An exact solve
// (the algebraic inverse) is checked at kExactForwardRtol.
constexpr double kForwardToleranceRatio = 1e-2;
constexpr double kMinForwardRtol = 1e-13;
constexpr double kMaxForwardRtol = 1e-10;
constexpr double kExactForwardRtol = 1e-12;
// CVODE's absolute tolerance in units of its relative one (states of size 1e-2 and up are
// held to the relative tolerance).
constexpr double kForwardAbsoluteScale = 1e-2;
// The solution starts at rest when its distance from the rest state is within this many times
// the solve's tolerance.
constexpr double kRestFactor = 10.0;
// y_d counts as at rest at t_start when its derivatives there are below this (they are exactly
// zero before t0 for rest-to-rest trajectories).
constexpr double kTrajectoryRestTolerance = 1e-14;
// Restarted segments at most: a plant growing so fast that more would be needed leaves no
// meaningful check (each segment is a CVODE start); the check then says so.
constexpr int kMaxSegments = 100000;
// A span within this many segments of a whole number of them is that number (a span of 4 s cut
// into 0.1 s segments is 40.000000000000003 of them, not 41).
constexpr double kWholeSegmentsTolerance = 1e-9;
// Steps allowed in all forward runs: a smooth u_d on the shipped models needs a few thousand;
// one that is not smooth (noise in a high derivative of y_d) would otherwise crawl for minutes.
constexpr long kMaxForwardSteps = 1000000;

bool TrajectoryAtRest(const OutputTrajectory& trajectory, double t) {
  for (int order = 1; order <= std::max(trajectory.continuous_derivatives(), 2); ++order) {
    if (trajectory.Derivative(t, order).lpNorm<Eigen::Infinity>() > kTrajectoryRestTolerance) {
      return false;
    }
  }
  return true;
}

struct Scales {
  double output = 0.0;    // max |y_d| over the span
  double velocity = 0.0;  // max |y_d'|
};

Scales OutputScales(const OutputTrajectory& trajectory, const FeedforwardSolution& solution) {
  std::vector<double> times = solution.times;
  for (const double t : trajectory.breakpoints()) times.push_back(t);
  Scales scales;
  for (const double t : times) {
    scales.output = std::max(scales.output, trajectory.Derivative(t, 0).lpNorm<Eigen::Infinity>());
    scales.velocity =
        std::max(scales.velocity, trajectory.Derivative(t, 1).lpNorm<Eigen::Infinity>());
  }
  return scales;
}

// Numbers in the bound's explanation and in messages, to this many digits (the bound itself is
// exact in its field).
constexpr int kExplainedDigits = 6;

// An exact solve (the algebraic inverse) has no tolerance of its own.
bool IsExact(const SolveAccuracy& accuracy) { return std::isnan(accuracy.rtol); }

// CVODE's tolerances in the forward runs, from the solve's own.
void SetForwardTolerances(const SolveAccuracy& accuracy, Verification& verification) {
  verification.forward_rtol = IsExact(accuracy) ? kExactForwardRtol
                                                : std::clamp(kForwardToleranceRatio * accuracy.rtol,
                                                             kMinForwardRtol, kMaxForwardRtol);
  verification.forward_atol = kForwardAbsoluteScale * verification.forward_rtol;
}

// How the resolution floor of the bound was derived, with the numbers.
std::string ResolutionRule(const FeedforwardSolution& solution,
                           const Scales& scales,
                           const VerificationOptions& options,
                           const Verification& verification) {
  return FormatSignificant(options.resolution_factor, kExplainedDigits) +
         " x (the forward check's own resolution, rtol max|y_d| + "
         "atol = " +
         FormatSignificant(verification.forward_rtol, kExplainedDigits) + " * " +
         FormatSignificant(scales.output, kExplainedDigits) + " + " +
         FormatSignificant(verification.forward_atol, kExplainedDigits) +
         (solution.method == SolverMethod::kLinearized
              ? "; the bound of an exact inverse: the linearization's inverse passes only where it "
                "is exact to that resolution)"
          : IsExact(solution.accuracy) ? "; the inverse is exact)"
                                       : ")");
}

// The bound from the solve's own accuracy: about one step of delay for a fixed-step method, else
// its tolerances in output units. An exact solve has neither: SetBound gives it the resolution.
void SetAccuracyBound(const SolveAccuracy& accuracy,
                      const Scales& scales,
                      const VerificationOptions& options,
                      Verification& verification) {
  if (accuracy.step) {
    verification.bound = options.step_bound_factor * *accuracy.step * scales.velocity;
    verification.bound_rule =
        FormatSignificant(options.step_bound_factor, kExplainedDigits) +
        " x step max|y_d'| = " + FormatSignificant(options.step_bound_factor, kExplainedDigits) +
        " x " + FormatSignificant(*accuracy.step, kExplainedDigits) + " * " +
        FormatSignificant(scales.velocity, kExplainedDigits) +
        " (first order: about one step of delay)";
  } else if (!IsExact(accuracy)) {
    verification.bound = options.bound_factor * (accuracy.rtol * scales.output + accuracy.atol);
    verification.bound_rule =
        FormatSignificant(options.bound_factor, kExplainedDigits) +
        " x (rtol max|y_d| + atol = " + FormatSignificant(accuracy.rtol, kExplainedDigits) + " * " +
        FormatSignificant(scales.output, kExplainedDigits) + " + " +
        FormatSignificant(accuracy.atol, kExplainedDigits) + ")";
  }
}

// The bound and its explanation, from the solve's tolerances and the output's size, never below
// what the forward runs themselves resolve.
void SetBound(const OutputTrajectory& trajectory,
              const FeedforwardSolution& solution,
              const VerificationOptions& options,
              Verification& verification) {
  const Scales scales = OutputScales(trajectory, solution);
  SetForwardTolerances(solution.accuracy, verification);
  const double forward_term = verification.forward_rtol * scales.output + verification.forward_atol;
  const double resolution = options.resolution_factor * forward_term;
  SetAccuracyBound(solution.accuracy, scales, options, verification);
  if (IsExact(solution.accuracy) || !(verification.bound >= resolution)) {
    verification.bound = resolution;
    verification.bound_rule = ResolutionRule(solution, scales, options, verification);
  }
}

// A state of the plant, (q, q'), and the input u there.
struct PlantState {
  Eigen::VectorXd q, q_dot, u;
};

// The solution's own state at t_start; throws NoSolution where its extension cannot give it.
PlantState SolutionStateAtStart(const MotionExtension& motion, double t_start) {
  PlantState state;
  std::string why;
  if (!motion.Evaluate(t_start, state.q, state.q_dot, state.u, why)) {
    throw NoSolution("the solution cannot be evaluated at t_start = " +
                     FormatSignificant(t_start, kExplainedDigits) + " s: " + why);
  }
  return state;
}

// The equilibrium at rest with h(q) = y_d(t_start), found from the solution's own q there.
PlantState RestStateAtStart(const Model& model,
                            const OutputTrajectory& trajectory,
                            double t_start,
                            const Eigen::VectorXd& q_guess) {
  const OperatingPoint rest_point =
      FindRestPoint(model, trajectory.Derivative(t_start, 0), q_guess);
  PlantState state;
  state.q = rest_point.q;
  state.u = rest_point.u;
  state.q_dot = Eigen::VectorXd::Zero(state.q.size());
  return state;
}

// max |q'| over the solution's rows.
double LargestVelocity(const FeedforwardSolution& solution) {
  double largest_velocity = 0.0;
  for (const Eigen::VectorXd& velocity : solution.q_dot) {
    largest_velocity = std::max(largest_velocity, velocity.lpNorm<Eigen::Infinity>());
  }
  return largest_velocity;
}

// Records how far the solution's own start is from the rest state, and warns when that is beyond
// the solve's tolerance (e.g. a pre-actuation cut short).
void CompareStartWithRest(const PlantState& solution_start,
                          const PlantState& rest,
                          const FeedforwardSolution& solution,
                          Verification& verification) {
  verification.start_position_deviation = (solution_start.q - rest.q).lpNorm<Eigen::Infinity>();
  verification.start_velocity_deviation = solution_start.q_dot.lpNorm<Eigen::Infinity>();
  const double largest_velocity = LargestVelocity(solution);
  const bool exact = IsExact(solution.accuracy);
  const double rtol = exact ? verification.forward_rtol : solution.accuracy.rtol;
  const double atol = exact ? verification.forward_atol : solution.accuracy.atol;
  verification.solution_starts_at_rest =
      verification.start_position_deviation <=
          kRestFactor * (rtol * std::max(1.0, rest.q.lpNorm<Eigen::Infinity>()) + atol) &&
      verification.start_velocity_deviation <=
          kRestFactor * (rtol * std::max(1.0, largest_velocity) + atol);
  if (!verification.solution_starts_at_rest) {
    verification.warnings.push_back(
        "the solution does not start at rest at t_start = " +
        FormatSignificant(solution.t_start, kExplainedDigits) + " s (|q - q_rest| = " +
        FormatSignificant(verification.start_position_deviation, kExplainedDigits) +
        ", |q'| = " + FormatSignificant(verification.start_velocity_deviation, kExplainedDigits) +
        "); the forward check starts from rest, where the physical system is");
  }
}

// Where the physical system is at t_start: at rest when y_d rests there, else on the solution.
PlantState StartState(const Model& model,
                      const OutputTrajectory& trajectory,
                      const FeedforwardSolution& solution,
                      Verification& verification) {
  const PlantState solution_start = SolutionStateAtStart(*solution.extension, solution.t_start);
  if (!TrajectoryAtRest(trajectory, solution.t_start)) {
    verification.start = "solution";
    return solution_start;
  }
  PlantState rest = RestStateAtStart(model, trajectory, solution.t_start, solution_start.q);
  verification.start = "rest";
  CompareStartWithRest(solution_start, rest, solution, verification);
  return rest;
}

// The plant's fastest growth, at the start and at growth_samples states along the solution
// (0 where it cannot be taken at the start).
double FastestGrowthRate(ForwardModel& plant,
                         const PlantState& start,
                         const FeedforwardSolution& solution,
                         const VerificationOptions& options) {
  const double rate_at_rest = plant.GrowthRate(start.q, start.q_dot, start.u);
  double fastest = std::isfinite(rate_at_rest) ? rate_at_rest : 0.0;
  const std::size_t rows = solution.times.size();
  const std::size_t samples = std::min<std::size_t>(rows, std::size_t(options.growth_samples));
  for (std::size_t k = 0; k < samples; ++k) {
    const std::size_t i = samples == 1 ? 0 : k * (rows - 1) / (samples - 1);
    const double rate = plant.GrowthRate(solution.q[i], solution.q_dot[i], solution.u[i]);
    if (std::isfinite(rate)) fastest = std::max(fastest, rate);
  }
  return fastest;
}

// Cuts `span` into segments within which errors grow by at most segment_growth.
void ChooseSegments(double span, const VerificationOptions& options, Verification& verification) {
  if (verification.plant_growth_rate > options.stable_growth_rate) {
    verification.segment_length = std::log(options.segment_growth) / verification.plant_growth_rate;
  }
  if (verification.segment_length >= span) {
    verification.segments = 1;
  } else if (span / verification.segment_length > kMaxSegments) {
    verification.segments = kMaxSegments;
    verification.warnings.push_back(
        "the plant grows so fast (" +
        FormatSignificant(verification.plant_growth_rate, kExplainedDigits) +
        " /s) that the forward check's " + std::to_string(kMaxSegments) +
        " segments let errors grow by more than " +
        FormatSignificant(options.segment_growth, kExplainedDigits) + " within one");
  } else {
    verification.segments =
        int(std::ceil(span / verification.segment_length - kWholeSegmentsTolerance));
  }
}

IntegratorOptions ForwardIntegratorOptions(const Verification& verification) {
  IntegratorOptions integrator;
  integrator.rtol = verification.forward_rtol;
  integrator.atol = verification.forward_atol;
  integrator.max_steps = kMaxForwardSteps;
  return integrator;
}

// The solution's state and input at t: buffers all forward runs share.
struct ForwardBuffers {
  Eigen::VectorXd q, q_dot, u;
};

// One forward run from `state` at `from` to `to`: u_d from the solution's extension drives the
// plant, and the output at each step is recorded and compared with y_d.
SolveSummary RunForwardSegment(ForwardModel& plant,
                               const MotionExtension& motion,
                               const OutputTrajectory& trajectory,
                               double from,
                               const Eigen::VectorXd& state,
                               double to,
                               const IntegratorOptions& integrator,
                               ForwardBuffers& buffers,
                               Verification& verification) {
  const Eigen::Index f = plant.dof();
  return SimulateForward(
      plant,
      [&](double t, Eigen::VectorXd& u, std::string& reason) {
        return motion.Evaluate(t, buffers.q, buffers.q_dot, u, reason);
      },
      from, state, to, trajectory.breakpoints(), integrator,
      [&](double t, const Eigen::VectorXd& y, const Eigen::VectorXd&) {
        if (verification.max_constraint_violation) {
          verification.max_constraint_violation = std::max(*verification.max_constraint_violation,
                                                           plant.ConstraintViolation(y.head(f)));
        }
        Eigen::VectorXd output = plant.Output(y.head(f));
        const double error = (output - trajectory.Derivative(t, 0)).lpNorm<Eigen::Infinity>();
        verification.output_times.push_back(t);
        verification.outputs.push_back(std::move(output));
        if (error > verification.max_tracking_error) {
          verification.max_tracking_error = error;
          verification.time_of_max_error = t;
        }
        return true;
      });
}

// Moves `state` = (q, q') of a closed chain onto its loops; false, with the reason in the
// summary, where the loops cannot be closed from there.
bool ProjectOntoLoops(ForwardModel& plant,
                      double t,
                      Eigen::VectorXd& state,
                      Verification& verification) {
  Eigen::VectorXd correction;
  std::string why;
  if (!plant.Project(state, correction, nullptr, why)) {
    verification.summary.status = SolveStatus::kNoConvergence;
    verification.summary.message =
        "at t = " + FormatSignificant(t, kExplainedDigits) + " s: " + why;
    return false;
  }
  state += correction;
  return true;
}

// Adds a forward run's counters to the total, which ends where the run ended.
void AccumulateRun(const SolveSummary& run, SolveSummary& total) {
  total.steps += run.steps;
  total.rejected_steps += run.rejected_steps;
  total.newton_iterations += run.newton_iterations;
  total.function_evaluations += run.function_evaluations;
  total.jacobian_evaluations += run.jacobian_evaluations;
  total.stop_time = run.stop_time;
}

// The forward runs, segment by segment: the first from `start`, each later one restarted from the
// solution's own state. Stops at the first run that fails.
void RunForwardSegments(ForwardModel& plant,
                        const OutputTrajectory& trajectory,
                        const FeedforwardSolution& solution,
                        const PlantState& start,
                        double t_stop,
                        Verification& verification) {
  const MotionExtension& motion = *solution.extension;
  const double t_start = solution.t_start;
  const double span = t_stop - t_start;
  const IntegratorOptions integrator = ForwardIntegratorOptions(verification);
  const Eigen::Index f = plant.dof();
  verification.max_tracking_error = 0.0;
  verification.time_of_max_error = t_start;
  if (plant.closed_chain()) verification.max_constraint_violation = 0.0;
  ForwardBuffers buffers;
  std::string why;
  verification.summary.status = SolveStatus::kConverged;
  for (int segment = 0; segment < verification.segments; ++segment) {
    const double from = t_start + segment * (span / verification.segments);
    const double to = segment + 1 == verification.segments
                          ? t_stop
                          : t_start + (segment + 1) * (span / verification.segments);
    Eigen::VectorXd state(2 * f);
    if (segment == 0) {
      state << start.q, start.q_dot;
    } else {
      if (!motion.Evaluate(from, buffers.q, buffers.q_dot, buffers.u, why)) {
        verification.summary.status = SolveStatus::kNoConvergence;
        verification.summary.message =
            "at t = " + FormatSignificant(from, kExplainedDigits) + " s: " + why;
        break;
      }
      state << buffers.q, buffers.q_dot;
    }
    // The physical system is on its loops: a start the solution gives (to its tolerance) is
    // projected onto c(q) = 0 and C q' = 0, as every step of the run will be.
    if (plant.closed_chain() && !ProjectOntoLoops(plant, from, state, verification)) break;
    const SolveSummary run = RunForwardSegment(plant, motion, trajectory, from, state, to,
                                               integrator, buffers, verification);
    AccumulateRun(run, verification.summary);
    if (!run.IsUsable()) {
      verification.summary.status = run.status;
      verification.summary.message = run.message;
      break;
    }
  }
}

std::string ForwardRunsMessage(double t_stop, const Verification& verification) {
  return "reached t = " + FormatSignificant(t_stop, kExplainedDigits) + " s in " +
         std::to_string(verification.segments) + (verification.segments == 1 ? " run" : " runs") +
         ", " + std::to_string(verification.summary.steps) + " steps";
}

}  // namespace

void VerificationOptions::Validate() const {
  RequireOption(bound_factor > 0.0 && std::isfinite(bound_factor), "VerificationOptions",
                "bound_factor", bound_factor, "must be a finite number > 0");
  RequireOption(resolution_factor > 0.0 && std::isfinite(resolution_factor), "VerificationOptions",
                "resolution_factor", resolution_factor, "must be a finite number > 0");
  RequireOption(step_bound_factor > 0.0 && std::isfinite(step_bound_factor), "VerificationOptions",
                "step_bound_factor", step_bound_factor, "must be a finite number > 0");
  RequireOption(segment_growth > 1.0 && std::isfinite(segment_growth), "VerificationOptions",
                "segment_growth", segment_growth, "must be a finite number > 1");
  RequireOption(stable_growth_rate >= 0.0 && std::isfinite(stable_growth_rate),
                "VerificationOptions", "stable_growth_rate", stable_growth_rate,
                "must be a finite number >= 0");
  RequireOption(growth_samples >= 0, "VerificationOptions", "growth_samples", growth_samples,
                "must be >= 0");
}

Verification VerifyFeedforward(const Model& model,
                               const OutputTrajectory& trajectory,
                               const FeedforwardSolution& solution,
                               const VerificationOptions& options) {
  options.Validate();
  if (!solution.extension || solution.times.empty()) {
    throw UsageError("nothing to verify: the solution has no continuous extension");
  }
  const double t_stop = std::min(solution.t_end, solution.extension->end());
  Verification verification;
  ForwardModel plant(model);
  SetBound(trajectory, solution, options, verification);
  const PlantState start = StartState(model, trajectory, solution, verification);
  verification.plant_growth_rate = FastestGrowthRate(plant, start, solution, options);
  ChooseSegments(t_stop - solution.t_start, options, verification);
  RunForwardSegments(plant, trajectory, solution, start, t_stop, verification);
  if (verification.summary.IsUsable()) {
    verification.summary.message = ForwardRunsMessage(t_stop, verification);
  }
  if (solution.method == SolverMethod::kLinearized && verification.segments > 1) {
    // An approximate inverse: restarting from its own q_d each segment measures only how far
    // it drifts within one. What a user who applies it sees is the open-loop run from the start
    // over the whole span, which is reported and decides; the segmented error stands beside it.
    Verification open_loop = verification;
    open_loop.segments = 1;
    open_loop.output_times.clear();
    open_loop.outputs.clear();
    open_loop.summary = SolveSummary();
    RunForwardSegments(plant, trajectory, solution, start, t_stop, open_loop);
    if (open_loop.summary.IsUsable()) {
      open_loop.summary.message = "open loop: " + ForwardRunsMessage(t_stop, open_loop);
    } else {
      open_loop.summary.message = "open loop: " + open_loop.summary.message;
    }
    open_loop.segmented_tracking_error = verification.max_tracking_error;
    verification = std::move(open_loop);
  }
  if (!solution.summary.IsUsable() || t_stop < solution.t_end) {
    verification.solve_stopped_at = t_stop;
    verification.warnings.push_back(
        "the solve stopped at t = " + FormatSignificant(t_stop, kExplainedDigits) +
        " s, before t_end = " + FormatSignificant(solution.t_end, kExplainedDigits) +
        " s: the forward check covers the span up to there only, and does not pass");
  }
  verification.passed = !verification.solve_stopped_at && verification.summary.IsUsable() &&
                        verification.max_tracking_error <= verification.bound &&
                        verification.max_constraint_violation.value_or(0.0) <= verification.bound;
  return verification;
}

}  // namespace servokit
