#pragma once
// The forward check of a solve (VerifyFeedforward): u_d, from the method's own continuous
// extension, drives the model M q'' + f = B u_d (+ C^T lambda, c(q) = 0 for a closed chain)
// forward, and the output must follow y_d within a bound derived from the solve's tolerances and
// the output's size. It proves that the feedforward reproduces y_d on the model, to the stated
// bound, starting where the physical system is: at rest with h(q) = y_d(t_start).
//
// An open-loop unstable plant (an inverted pendulum on a cart) amplifies any error, the
// forward integrator's included, exponentially: a single run from t_start diverges whatever
// u_d is. There the run is restarted from the solution's own state (q_d, q_d') at the start of
// each segment, with the segment length chosen from the plant's fastest growth rate so that
// errors grow by at most a fixed factor within a segment. A wrong u_d still shows within every
// segment; a right one is no longer drowned by the plant's own instability.
#include <Eigen/Dense>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "integrators/solve_summary.h"
#include "modeling/model.h"
#include "solvers/inverse_model.h"
#include "trajectories/trajectory.h"

namespace servokit {

struct VerificationOptions {
  // The bound on the largest output error |h(q) - y_d| is bound_factor times the solve's own
  // tolerance in output units, rtol max|y_d| + atol. 100 covers the growth of local errors
  // into a global one measured on the shipped and literature models (0.03 to 3 times rtol
  // max|y_d|), and fails a u_d off by a percent by orders of magnitude.
  double bound_factor = 100.0;
  // The bound is never below this factor times the forward runs' own tolerance in output units
  // (their rtol max|y_d| + atol): CVODE's BDF makes global errors of up to some hundred times
  // its tolerance (measured: 70 times on the mass on car). This is the whole bound for an
  // exact inverse (algebraic).
  double resolution_factor = 1000.0;
  // Euler backward has no tolerance: it is first order in its fixed step h, and its output
  // lags y_d by about one step, |y_d(t) - y_d(t - h)| <= h max|y_d'|. The bound is this
  // factor times h max|y_d'| (measured: 0.25 h max|y_d'| on the flat case 4); numerical
  // damping of internal dynamics (paper Sect. 5.2) can exceed it, and then the check says so.
  double step_bound_factor = 2.0;
  // On an unstable plant the error may grow by at most this factor within a segment: the
  // segment lasts ln(segment_growth) / (fastest growth rate).
  double segment_growth = 10.0;
  // Growth rates below this (1/s) count as a stable plant: one run from t_start, no restart.
  double stable_growth_rate = 1e-6;
  // States along the solution at which the plant's growth rate is taken (plus the rest state).
  int growth_samples = 100;
  // Throws UsageError naming the field, its value and the rule it breaks.
  void Validate() const;
};

struct Verification {
  double max_tracking_error = std::numeric_limits<double>::quiet_NaN();  // max |h(q) - y_d|
  double time_of_max_error = std::numeric_limits<double>::quiet_NaN();
  double bound = std::numeric_limits<double>::quiet_NaN();
  // A closed chain's max |c(q)| along the forward runs, which integrate its index-1 form and
  // project back onto c(q) = 0 and C q' = 0 after every step; it must be within `bound` too.
  // Unset for an open chain.
  std::optional<double> max_constraint_violation;
  // Where the solve stopped when it stopped before t_end (its status says why): the forward
  // runs cover the span up to there only, and the check does not pass (issue #33). Unset when
  // the solve reached t_end.
  std::optional<double> solve_stopped_at;
  // The method `linearized` only, when the plant needed restarts (segments > 1): the largest
  // error of the segmented runs, which restart from q_d and so hide how far the approximate
  // u_d drifts. max_tracking_error is then that of one open-loop run over the whole span,
  // which decides the check (issue #33). Unset otherwise.
  std::optional<double> segmented_tracking_error;
  std::string bound_rule;  // how the bound was derived, with the numbers
  bool passed = false;     // the forward runs reached the end and stayed within the bound
  // The start: at rest at the equilibrium with h(q) = y_d(t_start) when y_d rests there
  // ("rest"), else the solution's own state ("solution": the system must already move).
  std::string start;
  // How far the solution's own state at t_start is from that rest state, and whether that is
  // within the solve's tolerance (false: e.g. a pre-actuation cut short).
  double start_position_deviation = 0.0;
  double start_velocity_deviation = 0.0;
  bool solution_starts_at_rest = true;
  // The plant's fastest growth rate (largest real part of the linearized forward dynamics at
  // the rest state and along q_d), and what the check did about it.
  double plant_growth_rate = 0.0;
  double segment_length = std::numeric_limits<double>::infinity();  // inf: one run
  int segments = 1;
  double forward_rtol = 0.0;  // CVODE's tolerances in the forward runs
  double forward_atol = 0.0;
  SolveSummary summary;  // of the forward runs (steps summed)
  // The forward runs' output h(q) at each of their steps (a segment's start repeats the time
  // where the previous segment ended): what `solve --plot` draws against y_d.
  std::vector<double> output_times;
  std::vector<Eigen::VectorXd> outputs;
  std::vector<std::string> warnings;
};

/// Drives the model with `solution`'s u_d from its continuous extension and compares the output
/// with `trajectory` (see the file comment). Throws UsageError for bad options or a solution
/// without a continuous extension, NoSolution when the rest state at t_start cannot be found.
Verification VerifyFeedforward(const Model& model,
                               const OutputTrajectory& trajectory,
                               const FeedforwardSolution& solution,
                               const VerificationOptions& options = {});

}  // namespace servokit
