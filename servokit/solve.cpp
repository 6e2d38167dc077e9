// api::Solve: the feedforward of a multibody model for a desired output, checked forward on
// request: trajectory, classification, inverse model, forward check and the files of a solve.
#include <algorithm>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "analysis/classification.h"
#include "base/errors.h"
#include "base/option_check.h"
#include "reports/solve_files.h"
#include "servokit/toolkit_bridge.h"
#include "solvers/inverse_model.h"
#include "solvers/verification.h"
#include "trajectories/sampled_trajectory.h"
#include "trajectories/trajectory.h"
#include "trajectories/waypoint_trajectory.h"

namespace servokit::api {
namespace {

// Which kind of OutputTrajectory the caller gave; more than one is a usage error.
enum class TrajectoryKind { kRestToRest, kWaypoints, kSamples, kFunction };

TrajectoryKind KindOf(const OutputTrajectory& trajectory) {
  std::vector<TrajectoryKind> given;
  if (!trajectory.waypoint_file.empty()) given.push_back(TrajectoryKind::kWaypoints);
  if (!trajectory.sample_times.empty() || trajectory.sample_values.size() > 0) {
    given.push_back(TrajectoryKind::kSamples);
  }
  if (trajectory.function) given.push_back(TrajectoryKind::kFunction);
  if (given.size() > 1) {
    throw UsageError(
        "OutputTrajectory: give one of waypoint_file, sample_times/sample_values and function "
        "(or none of them for rest-to-rest)");
  }
  return given.empty() ? TrajectoryKind::kRestToRest : given.front();
}

// What the caller calls the trajectory's values, for messages about their number.
std::string ValuesName(const OutputTrajectory& trajectory, TrajectoryKind kind) {
  switch (kind) {
    case TrajectoryKind::kRestToRest:
      return "OutputTrajectory::y0, yf";
    case TrajectoryKind::kWaypoints:
      return trajectory.waypoint_file + ": waypoints[0].y";
    case TrajectoryKind::kSamples:
      return "OutputTrajectory::sample_values";
    case TrajectoryKind::kFunction:
      return "OutputTrajectory::function_outputs";
  }
  return "OutputTrajectory";
}

// What a solve from samples says of its spline: the degree (above 9 when the inverse reads y_d
// to a higher order), the knots, and how closely it keeps to the samples.
std::string SamplesNote(const SampledTrajectory& spline,
                        std::size_t samples,
                        int needed_derivatives) {
  const int degree = 2 * spline.continuous_derivatives() + 1;
  std::string note =
      std::to_string(samples) + " samples joined by a spline of degree " + std::to_string(degree);
  if (degree > 9) {
    note += " (the inverse reads y_d up to order " + std::to_string(needed_derivatives) + ")";
  }
  const std::size_t stride = spline.knot_stride();
  if (stride == 1) {
    note += " through every sample";
  } else if (stride >= samples - 1) {
    note += " without inner knots";
  } else {
    note += " with a knot every " + std::to_string(stride) + " samples";
  }
  return note + ": largest deviation from a sample " + FormatNumber(spline.largest_deviation()) +
         " of the output's range";
}

// The desired trajectory, raised in order when the problem needs more continuous derivatives
// of y_d than asked for (the inverse reads y_d up to order differentiation index - 1); `note`
// says so when it was.
std::unique_ptr<servokit::OutputTrajectory> MakeTrajectory(const OutputTrajectory& trajectory,
                                                           int needed_derivatives,
                                                           std::string& note) {
  const int order = RestToRestOrderFor(needed_derivatives);
  switch (KindOf(trajectory)) {
    case TrajectoryKind::kRestToRest:
      if (order > 4) {
        note = "rest-to-rest raised from Eq. (65) (4 continuous derivatives) to " +
               std::to_string(order) + ": the inverse reads y_d up to order " +
               std::to_string(needed_derivatives);
      }
      return std::make_unique<RestToRestTrajectory>(trajectory.y0, trajectory.yf, trajectory.t0,
                                                    trajectory.tf, order);
    case TrajectoryKind::kWaypoints: {
      WaypointTrajectory file = LoadWaypointTrajectory(trajectory.waypoint_file);
      if (file.continuous_derivatives() < needed_derivatives) {
        note = trajectory.waypoint_file + ": raised from " +
               std::to_string(file.continuous_derivatives()) + " to " +
               std::to_string(needed_derivatives) +
               " continuous derivatives: the inverse reads y_d up to that order";
        file = file.WithContinuousDerivatives(needed_derivatives);
      }
      return std::make_unique<WaypointTrajectory>(std::move(file));
    }
    case TrajectoryKind::kSamples: {
      RequireOption(trajectory.sample_tolerance >= 0.0 && trajectory.sample_tolerance < 1.0,
                    "OutputTrajectory", "sample_tolerance", trajectory.sample_tolerance,
                    "must be >= 0 (0: through every sample) and < 1");
      auto samples = std::make_unique<SampledTrajectory>(
          trajectory.sample_times, trajectory.sample_values, order, trajectory.sample_tolerance,
          trajectory.sample_source);
      note = SamplesNote(*samples, trajectory.sample_times.size(), needed_derivatives);
      return samples;
    }
    case TrajectoryKind::kFunction: {
      const int declared = trajectory.function_continuous_derivatives;
      RequireOption(declared >= 0, "OutputTrajectory", "function_continuous_derivatives", declared,
                    "must be >= 0 (0: as many as the inverse reads)");
      RequireOption(declared == 0 || declared >= needed_derivatives, "OutputTrajectory",
                    "function_continuous_derivatives", declared,
                    "the inverse reads y_d up to order " + std::to_string(needed_derivatives) +
                        " and needs those derivatives continuous");
      return std::make_unique<FunctionTrajectory>(
          trajectory.function, Eigen::Index(trajectory.function_outputs),
          declared > 0 ? declared : std::max(needed_derivatives, 1),
          trajectory.function_breakpoints);
    }
  }
  return nullptr;
}

// The model has one output per value of y_d, or the trajectory is a usage error.
void RequireOutputCount(const servokit::Model& model,
                        const OutputTrajectory& trajectory,
                        const servokit::OutputTrajectory& desired) {
  const std::size_t outputs = model.num_outputs();
  if (desired.outputs() == Eigen::Index(outputs)) return;
  throw UsageError(ValuesName(trajectory, KindOf(trajectory)) + ": " +
                   std::to_string(desired.outputs()) + " values, but the model has " +
                   std::to_string(outputs) + (outputs == 1 ? " output" : " outputs") +
                   " (one value per output)");
}

// Whether MakeTrajectory makes the same y_d (and note) for `needed` derivatives as for
// `made_for`: rest to rest and samples depend on them only through the order of their
// smoothness, so that a y_d made to locate the operating point is not fitted again.
bool MadeAlike(const OutputTrajectory& trajectory, int made_for, int needed) {
  const TrajectoryKind kind = KindOf(trajectory);
  return (kind == TrajectoryKind::kRestToRest || kind == TrajectoryKind::kSamples) &&
         RestToRestOrderFor(needed) == RestToRestOrderFor(made_for);
}

// Where the solve's motion starts: t_start when given, else the first breakpoint of y_d (a
// stable inversion's pre-actuation starts earlier, with y_d at rest at that value).
double MotionStartTime(const servokit::OutputTrajectory& desired, std::optional<double> t_start) {
  return t_start.value_or(desired.breakpoints().front());
}

InverseModelOptions ToInverseModelOptions(const SolveOptions& options) {
  InverseModelOptions inverse;
  inverse.method = options.method;
  inverse.force = options.force;
  inverse.t_start = options.t_start;
  inverse.t_end = options.t_end;
  inverse.step = options.step;
  inverse.rtol = options.rtol;
  inverse.atol = options.atol;
  inverse.sample_time = options.sample_time;
  inverse.continuous_extension = options.verify;  // the sample grid asks for it itself
  inverse.pre_actuation = options.pre_actuation;
  inverse.post_actuation = options.post_actuation;
  return inverse;
}

// The rows of the solution as matrices (one row per time).
Eigen::MatrixXd Rows(const std::vector<Eigen::VectorXd>& values, std::size_t columns) {
  Eigen::MatrixXd rows(Eigen::Index(values.size()), Eigen::Index(columns));
  for (std::size_t i = 0; i < values.size(); ++i) rows.row(Eigen::Index(i)) = values[i];
  return rows;
}

// The format of options.out_file, checked against its name and, for MAT, the model's columns
// (before any work: a solve whose answer cannot be written is wasted).
SolveFileFormat ChooseFileFormat(const servokit::Model& model, const SolveOptions& options) {
  if (options.out_file.empty()) return options.file_format.value_or(SolveFileFormat::kCsv);
  const SolveFileFormat format =
      options.file_format.value_or(SolveFileFormatOfName(options.out_file));
  if (const std::optional<std::string> problem =
          servokit::SolveFileNameProblem(options.out_file, format)) {
    throw UsageError(
        "SolveOptions::file_format = " + std::string(options.file_format ? ToString(format) : "") +
        ", out_file = " + options.out_file + ": " + *problem);
  }
  if (format == SolveFileFormat::kMat) {
    if (const std::optional<std::string> problem = MatColumnsProblem(model)) {
      throw UsageError(options.out_file + ": " + *problem);
    }
  }
  return format;
}

// The API's view of the forward check.
Verification FromVerification(const servokit::Verification& verification, std::size_t outputs) {
  Verification result;
  result.passed = verification.passed;
  result.max_tracking_error = verification.max_tracking_error;
  result.time_of_max_error = verification.time_of_max_error;
  result.max_constraint_violation = verification.max_constraint_violation;
  result.solve_stopped_at = verification.solve_stopped_at;
  result.segmented_tracking_error = verification.segmented_tracking_error;
  result.bound = verification.bound;
  result.bound_rule = verification.bound_rule;
  result.segments = verification.segments;
  result.status = verification.summary.status;
  result.message = verification.summary.message;
  result.steps = verification.summary.steps;
  result.t = verification.output_times;
  result.y = Rows(verification.outputs, outputs);
  return result;
}

// The summary's values of the solve itself (the verification and the file come after it).
SolveSummary FromSolution(const FeedforwardSolution& solution, std::string trajectory_note) {
  SolveSummary summary;
  summary.method = solution.method;
  summary.method_reason = solution.method_reason;
  summary.status = solution.summary.status;
  summary.message = solution.summary.message;
  summary.stop_time = solution.summary.stop_time;
  summary.t_start = solution.t_start;
  summary.t_end = solution.t_end;
  summary.sample_time = solution.sample_time;
  summary.rtol = solution.accuracy.rtol;
  summary.atol = solution.accuracy.atol;
  summary.step = solution.accuracy.step;
  summary.steps = solution.summary.steps;
  summary.rejected_steps = solution.summary.rejected_steps;
  summary.newton_iterations = solution.summary.newton_iterations;
  summary.function_evaluations = solution.summary.function_evaluations;
  summary.samples = solution.times.size();
  summary.max_servo_residual = solution.max_servo_residual;
  if (solution.window) {
    const StableInversionWindow& window = *solution.window;
    summary.window = ActuationWindow{window.start,
                                     window.end,
                                     window.pre_actuation_start,
                                     window.post_actuation_end,
                                     window.widenings,
                                     window.boundary_value_residual,
                                     long(window.mesh_points)};
  }
  summary.trajectory_note = std::move(trajectory_note);
  summary.warnings = solution.warnings;
  return summary;
}

}  // namespace

Feedforward Solve(const Model& model,
                  const OutputTrajectory& trajectory,
                  const SolveOptions& options) {
  const servokit::Model& multibody = MultibodyModel(model, "Solve");
  const InverseModelOptions inverse_options = ToInverseModelOptions(options);
  // Checked even without a file, so that a bad file_format is never silently ignored.
  const SolveFileFormat file_format = ChooseFileFormat(multibody, options);
  Workspace workspace(multibody);
  // The operating point is where the motion starts: the equilibrium holding y_d at the solve's
  // start, found by Newton from q_guess (else the model's q0, else 0). How smooth y_d must be
  // depends on the class found there, and the start of a sampled y_d on how smooth it is made:
  // a first y_d locates the point, and the point is classified again should the final y_d
  // start elsewhere (by round-off of the fit).
  std::string note;
  constexpr int kLocatingDerivatives = 0;
  std::unique_ptr<servokit::OutputTrajectory> desired =
      MakeTrajectory(trajectory, kLocatingDerivatives, note);
  RequireOutputCount(multibody, trajectory, *desired);
  const double start_time = MotionStartTime(*desired, options.t_start);
  ClassificationOptions classification_options;
  classification_options.operating_point.q_guess = options.q_guess;
  classification_options.operating_point.y0 = desired->Derivative(start_time, 0);
  Classification classification = Classify(multibody, workspace, classification_options);

  Feedforward result;
  const int needed_derivatives = classification.structure.differentiation_index - 1;
  if (!MadeAlike(trajectory, kLocatingDerivatives, needed_derivatives)) {
    note.clear();
    desired = MakeTrajectory(trajectory, needed_derivatives, note);
    const Eigen::VectorXd start_output = desired->Derivative(start_time, 0);
    if (start_output != *classification_options.operating_point.y0) {
      classification_options.operating_point.y0 = start_output;
      classification_options.operating_point.q_guess = classification.operating_point.q;
      classification = Classify(multibody, workspace, classification_options);
    }
  }
  if (!note.empty()) result.notes.push_back(note);

  const FeedforwardSolution solution =
      SolveInverseModel(multibody, *desired, classification, inverse_options);
  nlohmann::ordered_json report =
      SolveToJson(multibody, classification, classification_options, solution, note);
  SolveSummary& summary = result.summary;
  summary = FromSolution(solution, note);
  summary.classification = FromClassification(multibody, classification, classification_options);
  // Where the operating point is: it holds y_d at this time (the motion's start).
  summary.operating_point_time = start_time;
  report["classification"]["operating_point"]["t"] = start_time;
  result.usable = solution.summary.IsUsable();
  if (options.verify && solution.extension) {
    const servokit::Verification verification = VerifyFeedforward(multibody, *desired, solution);
    report["verification"] = VerificationToJson(verification);
    summary.verification = FromVerification(verification, multibody.num_outputs());
    summary.warnings.insert(summary.warnings.end(), verification.warnings.begin(),
                            verification.warnings.end());
    // An answer that fails its check is not within its tolerances: it is not "converged".
    if (result.usable && !verification.passed) {
      summary.status = SolveStatus::kVerificationFailed;
      summary.message = "the verification failed: " + VerificationFailure(verification);
      result.usable = false;
      report["status"] = ToString(summary.status);
      report["message"] = summary.message;
    }
  }
  report["warnings"] = summary.warnings;
  if (!options.out_file.empty()) {
    summary.out_file = options.out_file;
    report["out"] = options.out_file;
    // After the check: the MAT file's summary holds its verdict.
    WriteFeedforwardFile(options.out_file, file_format, multibody, *desired, solution, report);
  }
  summary.json = report.dump(2);

  result.t = solution.times;
  result.q = Rows(solution.q, multibody.dof());
  result.q_dot = Rows(solution.q_dot, multibody.dof());
  result.u = Rows(solution.u, multibody.num_inputs());
  result.multipliers = solution.multipliers.empty()
                           ? Eigen::MatrixXd(Eigen::Index(solution.times.size()), 0)
                           : Rows(solution.multipliers, multibody.num_constraints());
  result.y_d.resize(Eigen::Index(solution.times.size()), Eigen::Index(multibody.num_outputs()));
  result.y.resize(result.y_d.rows(), result.y_d.cols());
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    result.y_d.row(Eigen::Index(i)) = desired->Derivative(solution.times[i], 0);
    Evaluate(multibody, workspace, solution.q[i], Eigen::VectorXd::Zero(solution.q[i].size()),
             Quantity::kOutput);
    result.y.row(Eigen::Index(i)) = workspace.output.transpose();
  }
  result.breakpoints = desired->breakpoints();
  return result;
}

}  // namespace servokit::api

namespace servokit::api {

std::string SolveSummariesJson(const std::vector<SolveSummary>& summaries) {
  // Each object indented one level into the array: the text nlohmann's dump(2) gives an array of
  // the objects (a JSON string never holds a raw line break, so every line break is layout).
  std::string array = "[";
  for (std::size_t k = 0; k < summaries.size(); ++k) {
    array += k == 0 ? "\n" : ",\n";
    std::istringstream lines(summaries[k].json);
    std::string line;
    for (bool first = true; std::getline(lines, line); first = false) {
      array += (first ? "  " : "\n  ") + line;
    }
  }
  return array + (summaries.empty() ? "]" : "\n]");
}

}  // namespace servokit::api
