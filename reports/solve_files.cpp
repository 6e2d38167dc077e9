#include "reports/solve_files.h"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "models/errors.h"
#include "reports/classification_report.h"
#include "reports/number_format.h"

namespace servokit {
namespace {

// JSON has no NaN: a number that does not exist (a stop time never reached) is null.
nlohmann::ordered_json NumberOrNull(double value) {
  if (!std::isfinite(value)) return nullptr;
  return WithoutNegativeZero(value);
}

void AppendRow(std::string& line, const Eigen::VectorXd& values) {
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    line += ',';
    AppendExact(line, WithoutNegativeZero(values(i)));
  }
}

}  // namespace

void WriteFeedforwardCsv(const std::string& path,
                         const Model& model,
                         const OutputTrajectory& trajectory,
                         const FeedforwardSolution& solution) {
  const std::string partial = path + ".partial";
  {
    std::ofstream file(partial);
    if (!file) throw Error("cannot write " + path + " (" + std::strerror(errno) + ")");
    std::string line = "t";
    for (const std::string& name : model.coordinates()) line += "," + name;
    for (const std::string& name : model.coordinates()) line += "," + name + "_dot";
    for (const std::string& name : model.inputs()) line += "," + name;
    for (const std::string& name : model.output_names()) line += "," + name + "_d";
    file << line << '\n';
    for (std::size_t i = 0; i < solution.times.size(); ++i) {
      line.clear();
      AppendExact(line, WithoutNegativeZero(solution.times[i]));
      AppendRow(line, solution.q[i]);
      AppendRow(line, solution.q_dot[i]);
      AppendRow(line, solution.u[i]);
      AppendRow(line, trajectory.Derivative(solution.times[i], 0));
      file << line << '\n';
    }
    file.flush();
    if (!file) throw Error("cannot write " + path);
  }
  std::error_code error;
  std::filesystem::rename(partial, path, error);
  if (error) throw Error("cannot write " + path + ": " + error.message());
}

nlohmann::ordered_json SolveToJson(const Model& model,
                                   const Classification& classification,
                                   const ClassificationOptions& classification_options,
                                   const FeedforwardSolution& solution,
                                   const std::string& trajectory_note) {
  const SolveSummary& summary = solution.summary;
  nlohmann::ordered_json json = {
      {"method", ToString(solution.method)},
      {"method_reason", solution.method_reason},
      {"status", ToString(summary.status)},
      {"message", summary.message},
      {"stop_time", NumberOrNull(summary.stop_time)},
      {"t_start", NumberOrNull(solution.t_start)},
      {"t_end", NumberOrNull(solution.t_end)},
      {"sample_time", NumberOrNull(solution.sample_time.value_or(NAN))},
      {"tolerances",
       {{"rtol", NumberOrNull(solution.accuracy.rtol)},
        {"atol", NumberOrNull(solution.accuracy.atol)},
        {"step", NumberOrNull(solution.accuracy.step.value_or(NAN))}}},
      {"steps", summary.steps},
      {"rejected_steps", summary.rejected_steps},
      {"newton_iterations", summary.newton_iterations},
      {"function_evaluations", summary.function_evaluations},
      {"samples", solution.times.size()},
      {"max_servo_residual", NumberOrNull(solution.max_servo_residual)},
  };
  if (solution.window) {  // stable inversion (DESIGN.md)
    const StableInversionWindow& window = *solution.window;
    json["pre_actuation_start"] = NumberOrNull(window.pre_actuation_start);
    json["post_actuation_end"] = NumberOrNull(window.post_actuation_end);
    json["window"] = {NumberOrNull(window.start), NumberOrNull(window.end)};
    json["window_widenings"] = window.widenings;
    json["boundary_value_residual"] = NumberOrNull(window.boundary_value_residual);
    json["mesh_points"] = window.mesh_points;
  }
  if (!trajectory_note.empty()) json["trajectory_note"] = trajectory_note;
  json["classification"] = ClassificationToJson(model, classification, classification_options);
  return json;
}

nlohmann::ordered_json VerificationToJson(const Verification& verification) {
  const bool restarted = verification.segments > 1;
  return {
      {"passed", verification.passed},
      {"max_tracking_error", NumberOrNull(verification.max_tracking_error)},
      {"bound", NumberOrNull(verification.bound)},
      {"bound_rule", verification.bound_rule},
      {"time_of_max_error", NumberOrNull(verification.time_of_max_error)},
      {"start", verification.start},
      {"solution_starts_at_rest", verification.solution_starts_at_rest},
      {"start_position_deviation", NumberOrNull(verification.start_position_deviation)},
      {"start_velocity_deviation", NumberOrNull(verification.start_velocity_deviation)},
      {"plant_growth_rate", NumberOrNull(verification.plant_growth_rate)},
      {"strategy", restarted ? "restarted from the solution's state at the start of each "
                               "segment (unstable plant)"
                             : "one forward run"},
      {"segment_length", NumberOrNull(verification.segment_length)},
      {"segments", verification.segments},
      {"forward_rtol", NumberOrNull(verification.forward_rtol)},
      {"forward_atol", NumberOrNull(verification.forward_atol)},
      {"status", ToString(verification.summary.status)},
      {"message", verification.summary.message},
      {"steps", verification.summary.steps},
  };
}

std::string VerificationFailure(const Verification& verification) {
  if (!verification.summary.IsUsable()) {
    return "the forward simulation stopped: " + verification.summary.message;
  }
  return "the largest output error " + FormatShort(verification.max_tracking_error) +
         " (at t = " + FormatShort(verification.time_of_max_error) + " s) exceeds the bound " +
         FormatShort(verification.bound) + " = " + verification.bound_rule;
}

}  // namespace servokit
