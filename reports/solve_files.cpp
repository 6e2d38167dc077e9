#include "reports/solve_files.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <optional>
#include <set>
#include <utility>

#include "base/errors.h"
#include "base/number_format.h"
#include "files/output_file.h"
#include "modeling/units.h"
#include "reports/classification_report.h"
#include "reports/escaping.h"
#include "reports/mat_file.h"

namespace servokit {
namespace {

// JSON has no NaN: a number that does not exist (a stop time never reached) is null.
nlohmann::ordered_json NumberOrNull(double value) {
  if (!std::isfinite(value)) return nullptr;
  return WithoutNegativeZero(value);
}

// The formats' names (--format, SolveOptions::file_format), one table both ways.
// The name of the MAT file's summary struct and of the Modelica table (docs/solve.md, "The file:
// CSV, MAT or a Modelica table").
constexpr const char* kMatSummaryName = "solve";
constexpr const char* kModelicaTableName = "u_d";
// Significant digits of a Modelica table's time on a sample grid (TableTime).
constexpr int kGridTimeDigits = 15;

// The JSON summary's members left out of the MAT file: the analyze object, whose keys include
// the model's parameter names (not always MATLAB names; `servokit analyze` gives it), and the
// file's own name, so that the bytes do not depend on where the file was written.
constexpr std::array<const char*, 2> kKeysNotInMat = {"classification", "out"};

std::string LowerCaseExtension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

// Row `i` of the file: t, q, q', u, y_d and a closed chain's lambda (the order of
// FeedforwardColumns).
Eigen::VectorXd FeedforwardRow(const OutputTrajectory& trajectory,
                               const FeedforwardSolution& solution,
                               std::size_t i) {
  const Eigen::Index dof = solution.q[i].size(), inputs = solution.u[i].size();
  const Eigen::VectorXd multipliers =
      solution.multipliers.empty() ? Eigen::VectorXd() : solution.multipliers[i];
  Eigen::VectorXd row(1 + 2 * dof + inputs + trajectory.outputs() + multipliers.size());
  row << solution.times[i], solution.q[i], solution.q_dot[i], solution.u[i],
      trajectory.Derivative(solution.times[i], 0), multipliers;
  return row;
}

// Writes what `write_text` writes to a temporary file and renames it to FILE
// (files/output_file.h), so that an interrupted or failed write never leaves a truncated FILE.
template <typename WriteText>
void WriteAndRename(const std::string& path, WriteText write_text) {
  OutputFile file(path);
  write_text(file.stream());
  file.Commit();
}

}  // namespace

SolveFileFormat SolveFileFormatOfName(const std::string& path) {
  return LowerCaseExtension(path) == ".mat" ? SolveFileFormat::kMat : SolveFileFormat::kCsv;
}

std::optional<std::string> SolveFileNameProblem(const std::string& path, SolveFileFormat format) {
  const std::string extension = LowerCaseExtension(path);
  if (format == SolveFileFormat::kMat && extension != ".mat") {
    return std::string(
        "a MAT file's name must end in .mat (MATLAB's load reads any other name "
        "as text)");
  }
  if (format != SolveFileFormat::kMat && extension == ".mat") {
    return "a name ending in .mat is for a MAT file, not " + std::string(ToString(format));
  }
  if (format == SolveFileFormat::kModelica && extension == ".csv") {
    return std::string("a name ending in .csv is for CSV, not a Modelica table (use .txt)");
  }
  return std::nullopt;
}

std::vector<std::string> FeedforwardColumns(const Model& model) {
  std::vector<std::string> columns = {"t"};
  for (const std::string& name : model.coordinates()) columns.push_back(name);
  for (const std::string& name : model.coordinates()) columns.push_back(name + "_dot");
  for (const std::string& name : model.inputs()) columns.push_back(name);
  for (const std::string& name : model.output_names()) columns.push_back(name + "_d");
  for (std::size_t k = 0; k < model.num_constraints(); ++k) columns.push_back(MultiplierName(k));
  return columns;
}

std::optional<std::string> MatColumnsProblem(const Model& model) {
  std::set<std::string> seen = {kMatSummaryName};
  for (const std::string& column : FeedforwardColumns(model)) {
    if (const std::optional<std::string> problem = MatlabNameProblem(column)) {
      return "the column '" + column + "' cannot be a MAT variable: " + *problem +
             "; rename it in the model file or write CSV";
    }
    if (!seen.insert(column).second) {
      return "the column '" + column + "' cannot be a MAT variable: " +
             (column == kMatSummaryName ? std::string("the summary struct has that name")
                                        : std::string("two columns have that name")) +
             "; rename it in the model file or write CSV";
    }
  }
  return std::nullopt;
}

void WriteFeedforwardFile(const std::string& path,
                          SolveFileFormat format,
                          const Model& model,
                          const OutputTrajectory& trajectory,
                          const FeedforwardSolution& solution,
                          const nlohmann::ordered_json& summary) {
  switch (format) {
    case SolveFileFormat::kCsv:
      WriteFeedforwardCsv(path, model, trajectory, solution);
      return;
    case SolveFileFormat::kMat:
      WriteFeedforwardMat(path, model, trajectory, solution, summary);
      return;
    case SolveFileFormat::kModelica:
      WriteFeedforwardModelica(path, model, trajectory, solution, summary);
      return;
  }
}

void WriteFeedforwardCsv(const std::string& path,
                         const Model& model,
                         const OutputTrajectory& trajectory,
                         const FeedforwardSolution& solution) {
  WriteAndRename(path, [&](std::ostream& file) {
    std::string line;
    for (const std::string& column : FeedforwardColumns(model)) {
      line += (line.empty() ? "" : ",") + column;
    }
    file << line << '\n';
    for (std::size_t i = 0; i < solution.times.size(); ++i) {
      const Eigen::VectorXd row = FeedforwardRow(trajectory, solution, i);
      line.clear();
      for (Eigen::Index j = 0; j < row.size(); ++j) {
        if (j > 0) line += ',';
        AppendExact(line, row(j));
      }
      file << line << '\n';
    }
  });
}

void WriteFeedforwardMat(const std::string& path,
                         const Model& model,
                         const OutputTrajectory& trajectory,
                         const FeedforwardSolution& solution,
                         const nlohmann::ordered_json& summary) {
  if (const std::optional<std::string> problem = MatColumnsProblem(model)) {
    throw UsageError(path + ": " + *problem);
  }
  const std::vector<std::string> columns = FeedforwardColumns(model);
  Eigen::MatrixXd values(Eigen::Index(solution.times.size()), Eigen::Index(columns.size()));
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    values.row(Eigen::Index(i)) = FeedforwardRow(trajectory, solution, i).transpose();
  }
  // The CSV's numbers: -0 is written as 0 there (WithoutNegativeZero), so here too.
  values = values.unaryExpr([](double value) { return WithoutNegativeZero(value); });

  const std::unique_ptr<MatFileWriter> file = CreateMatFile(path);
  for (std::size_t j = 0; j < columns.size(); ++j) {
    file->WriteColumn(columns[j], values.col(Eigen::Index(j)));
  }
  nlohmann::ordered_json facts = summary;
  for (const char* key : kKeysNotInMat) facts.erase(key);
  facts["columns"] = columns;
  // What the numbers are of (issue #34): the model, its parameter values (SI) with the unit each
  // is shown in, and where y_d's motion starts and ends.
  facts["model"] = model.name();
  nlohmann::ordered_json parameters = nlohmann::ordered_json::object();
  nlohmann::ordered_json units = nlohmann::ordered_json::object();
  for (std::size_t i = 0; i < model.num_parameters(); ++i) {
    parameters[model.parameter_names()[i]] = model.parameters()(Eigen::Index(i));
    units[model.parameter_names()[i]] = ToString(model.parameter_display_units()[i]);
  }
  facts["parameters"] = parameters;
  facts["parameter_units"] = units;
  facts["trajectory_breakpoints"] = trajectory.breakpoints();
  file->WriteStruct(kMatSummaryName, facts);
  file->Commit();
}

namespace {

// A time of a Modelica table: on a sample grid, to 15 significant digits, which drops the
// round-off of t_start + k dt (-2.0200000000000005 is -2.02); else exact, as the CSV's.
std::string TableTime(double t, const std::optional<double>& sample_time) {
  if (sample_time) return FormatSignificant(t, kGridTimeDigits);
  std::string text;
  AppendExact(text, t);
  return text;
}

// One CombiTimeTable matrix: "double NAME(rows, 1 + count)" and a row "t v1 ..." per time, the
// values the columns first .. first + count - 1 of the file's rows (FeedforwardRow's layout).
void WriteModelicaTable(std::ostream& file,
                        const std::string& name,
                        const FeedforwardSolution& solution,
                        const std::vector<Eigen::VectorXd>& rows,
                        Eigen::Index first,
                        Eigen::Index count) {
  file << "double " << name << "(" << rows.size() << ", " << count + 1 << ")\n";
  std::string line;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    line = TableTime(solution.times[i], solution.sample_time);
    for (Eigen::Index k = first; k < first + count; ++k) {
      line += ' ';
      AppendExact(line, rows[i](k));
    }
    file << line << '\n';
  }
}

}  // namespace

void WriteFeedforwardModelica(const std::string& path,
                              const Model& model,
                              const OutputTrajectory& trajectory,
                              const FeedforwardSolution& solution,
                              const nlohmann::ordered_json& summary) {
  const std::size_t rows = solution.times.size();
  // CombiTimeTable needs increasing times, at most two equal in a row (a jump); the solvers'
  // rows increase strictly, so anything else is a broken invariant, reported, not written.
  for (std::size_t i = 1; i < rows; ++i) {
    const bool repeated_twice = i >= 2 && solution.times[i] == solution.times[i - 2];
    if (solution.times[i] < solution.times[i - 1] || repeated_twice) {
      throw Error("cannot write " + path + ": the times do not increase at t = " +
                  FormatExact(solution.times[i]) + " (CombiTimeTable needs them increasing)");
    }
  }
  for (std::size_t i = 0; i < rows; ++i) {
    if (!solution.u[i].allFinite()) {
      throw Error("cannot write " + path +
                  ": u_d is not a number at t = " + FormatExact(solution.times[i]));
    }
  }
  const std::vector<std::string>& inputs = model.inputs();
  const std::vector<std::string>& coordinates = model.coordinates();
  const std::vector<std::string> outputs = model.output_names();
  const auto dof = Eigen::Index(model.dof());
  const auto num_inputs = Eigen::Index(inputs.size());
  // The CSV's rows (t, q, q_dot, u, y_d, ...), cut into the three tables below.
  std::vector<Eigen::VectorXd> values;
  values.reserve(rows);
  for (std::size_t i = 0; i < rows; ++i) values.push_back(FeedforwardRow(trajectory, solution, i));
  WriteAndRename(path, [&](std::ostream& file) {
    file << "#1\n"
         << "# servokit solve: the feedforward u_d(t) of the model " << PlainText(model.name())
         << " (" << summary.at("method").get<std::string>() << ", "
         << summary.at("status").get<std::string>() << "), with the motion q_d and the output "
         << "y_d\n"
         << "# for Modelica.Blocks.Sources.CombiTimeTable(tableOnFile = true, tableName = \""
         << kModelicaTableName << "\", columns = 2:" << inputs.size() + 1 << ")\n"
         << (rows == 0 ? "# no rows"
                       : "# the tables start at t = " +
                             TableTime(solution.times.front(), solution.sample_time) + " s")
         << (rows > 0 && solution.times.front() < 0.0
                 ? " (before 0: stable inversion's pre-actuation; start the simulation there or "
                   "shift the table)"
                 : "")
         << "; every value in the model's SI units\n"
         << "# table u_d: column 1 t [s]";
    for (std::size_t k = 0; k < inputs.size(); ++k) {
      file << ", " << k + 2 << " " << PlainText(inputs[k]);
    }
    file << "\n# table q_d: column 1 t [s]";
    for (Eigen::Index k = 0; k < dof; ++k) {
      file << ", " << k + 2 << " " << PlainText(coordinates[std::size_t(k)]);
    }
    for (Eigen::Index k = 0; k < dof; ++k) {
      file << ", " << dof + k + 2 << " " << PlainText(coordinates[std::size_t(k)]) << "_dot";
    }
    file << " (the initial state: its first row)\n# table y_d: column 1 t [s]";
    for (std::size_t k = 0; k < outputs.size(); ++k) file << ", " << k + 2 << " " << outputs[k];
    file << "\n";
    WriteModelicaTable(file, kModelicaTableName, solution, values, 1 + 2 * dof, num_inputs);
    WriteModelicaTable(file, "q_d", solution, values, 1, 2 * dof);
    WriteModelicaTable(file, "y_d", solution, values, 1 + 2 * dof + num_inputs,
                       Eigen::Index(outputs.size()));
  });
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
  if (solution.window) {  // stable inversion (docs/solve.md)
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
  const bool open_loop = verification.segmented_tracking_error.has_value();
  nlohmann::ordered_json json = {
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
      {"strategy", open_loop   ? "one open-loop run over the whole span (an approximate "
                                 "inverse: restarts from q_d would hide its drift)"
                   : restarted ? "restarted from the solution's state at the start of each "
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
  if (verification.solve_stopped_at) json["solve_stopped_at"] = *verification.solve_stopped_at;
  if (open_loop) {  // beside the open-loop error that decides, the restarted runs' error
    json["segmented_tracking_error"] = NumberOrNull(*verification.segmented_tracking_error);
  }
  if (verification.max_constraint_violation) {  // a closed chain's loops, after max error
    nlohmann::ordered_json with_loops;
    for (const auto& [key, value] : json.items()) {
      with_loops[key] = value;
      if (key == "max_tracking_error") {
        with_loops["max_constraint_violation"] =
            NumberOrNull(*verification.max_constraint_violation);
      }
    }
    json = std::move(with_loops);
  }
  return json;
}

std::string VerificationFailure(const Verification& verification) {
  if (!verification.summary.IsUsable()) {
    return "the forward simulation stopped: " + verification.summary.message;
  }
  if (verification.solve_stopped_at) {
    return "the solve stopped at t = " + FormatShort(*verification.solve_stopped_at) +
           " s, so the check covers the span up to there only";
  }
  if (verification.max_tracking_error <= verification.bound) {
    return "the loops open by " + FormatShort(verification.max_constraint_violation.value_or(0.0)) +
           " (max |c(q)|), beyond the bound " + FormatShort(verification.bound) + " = " +
           verification.bound_rule;
  }
  return "the largest output error " + FormatShort(verification.max_tracking_error) +
         " (at t = " + FormatShort(verification.time_of_max_error) + " s) exceeds the bound " +
         FormatShort(verification.bound) + " = " + verification.bound_rule;
}

}  // namespace servokit
