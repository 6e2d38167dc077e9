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
      {"steps", summary.steps},
      {"rejected_steps", summary.rejected_steps},
      {"newton_iterations", summary.newton_iterations},
      {"function_evaluations", summary.function_evaluations},
      {"samples", solution.times.size()},
      {"max_servo_residual", NumberOrNull(solution.max_servo_residual)},
  };
  if (solution.pre_actuation_start) {  // stable inversion (DESIGN.md)
    json["pre_actuation_start"] = NumberOrNull(*solution.pre_actuation_start);
    json["post_actuation_end"] = NumberOrNull(solution.post_actuation_end.value_or(NAN));
    json["window"] = {NumberOrNull(solution.window_start.value_or(NAN)),
                      NumberOrNull(solution.window_end.value_or(NAN))};
    json["window_widenings"] = solution.window_widenings;
    json["boundary_value_residual"] = NumberOrNull(solution.boundary_value_residual.value_or(NAN));
    json["mesh_points"] = solution.times.size();
  }
  if (!trajectory_note.empty()) json["trajectory_note"] = trajectory_note;
  json["classification"] = ClassificationToJson(model, classification, classification_options);
  return json;
}

nlohmann::ordered_json VerificationToJson(const Verification& verification) {
  return {
      {"max_tracking_error", NumberOrNull(verification.max_tracking_error)},
      {"time_of_max_error", NumberOrNull(verification.time_of_max_error)},
      {"status", ToString(verification.summary.status)},
      {"message", verification.summary.message},
      {"steps", verification.summary.steps},
  };
}

}  // namespace servokit
