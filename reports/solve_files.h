#pragma once
// What `servokit solve` writes (docs/solve.md): the file of the feedforward (CSV, MAT or a
// Modelica table) and the JSON object on stdout.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/classification.h"
#include "base/vocabulary.h"
#include "modeling/model.h"
#include "solvers/inverse_model.h"
#include "solvers/verification.h"
#include "trajectories/trajectory.h"

namespace servokit {

/// The format a file name asks for when none is given: a name ending in .mat (any case) is a MAT
/// file, any other CSV (what every name meant before there were formats).
SolveFileFormat SolveFileFormatOfName(const std::string& path);

/// Why `format` cannot be written to `path`, or nullopt. The endings .csv and .mat belong to
/// their formats: a MAT file must end in .mat (MATLAB's `load` reads any other name as text),
/// and neither CSV nor a Modelica table may be named .mat, nor a Modelica table .csv.
std::optional<std::string> SolveFileNameProblem(const std::string& path, SolveFileFormat format);

/// The columns of a solve's file: t, each coordinate, each <coordinate>_dot, each input, y1_d,
/// ..., and for a closed chain its multipliers lambda1, ... (docs/solve.md, "The file: CSV, MAT
/// or a Modelica table"); the one list every format writes.
std::vector<std::string> FeedforwardColumns(const Model& model);

/// Why the columns of `model` cannot be MAT variables (a name that is not a MATLAB name, a
/// keyword, twice the same, or the summary's `solve`), or nullopt. Asked before solving.
std::optional<std::string> MatColumnsProblem(const Model& model);

/// Writes the feedforward in `format` (see WriteFeedforwardCsv, WriteFeedforwardMat,
/// WriteFeedforwardModelica); `summary` is the JSON object `servokit solve` prints.
void WriteFeedforwardFile(const std::string& path,
                          SolveFileFormat format,
                          const Model& model,
                          const OutputTrajectory& trajectory,
                          const FeedforwardSolution& solution,
                          const nlohmann::ordered_json& summary);

/// Writes t, each coordinate, each <coordinate>_dot, each input, y1_d, ... one row per sample,
/// numbers exact (shortest round-trip form). Written to FILE.partial and renamed, so an
/// interrupted write never leaves a truncated FILE. Throws Error when the file cannot be written.
void WriteFeedforwardCsv(const std::string& path,
                         const Model& model,
                         const OutputTrajectory& trajectory,
                         const FeedforwardSolution& solution);

/// Writes a MAT v5 file (MATLAB's `load`, scipy.io.loadmat): one double column vector per CSV
/// column, named as the column and holding the same numbers, then the struct `solve`: every
/// field of `summary` but `classification` and `out` (numbers as doubles, null as [], text as char,
/// see MatFileWriter::WriteStruct) and `columns`, a cell row of the column names in order. Written
/// to FILE.partial and renamed; byte-identical run to run. Throws UsageError when a column is
/// not a MATLAB name (MatColumnsProblem), Error when the file cannot be written.
void WriteFeedforwardMat(const std::string& path,
                         const Model& model,
                         const OutputTrajectory& trajectory,
                         const FeedforwardSolution& solution,
                         const nlohmann::ordered_json& summary);

/// Writes the tables for Modelica.Blocks.Sources.CombiTimeTable (text format "#1"): a comment
/// header naming the model, the method and status of `summary` (the JSON object `servokit
/// solve` prints), where the tables start (before 0 for stable inversion) and the columns, then
/// `double u_d(N, 1 + inputs)` (t u1 ... um), `double q_d(N, 1 + 2 dof)` (t q q_dot: its first
/// row the initial state) and `double y_d(N, 1 + outputs)`, one row per sample, values exact
/// (shortest round-trip form). The times are the CSV's, which increase strictly, written on a
/// sample grid to 15 significant digits (-2.02, not -2.0200000000000005). Written to
/// FILE.partial and renamed. Throws Error when the file cannot be written or u_d is not finite.
void WriteFeedforwardModelica(const std::string& path,
                              const Model& model,
                              const OutputTrajectory& trajectory,
                              const FeedforwardSolution& solution,
                              const nlohmann::ordered_json& summary);

/// method, method_reason, status, message, stop_time, t_start, t_end, sample_time, tolerances,
/// the counters, max_servo_residual, samples, trajectory_note (when the trajectory was raised
/// in order), stable inversion's window, and classification (the analyze object).
nlohmann::ordered_json SolveToJson(const Model& model,
                                   const Classification& classification,
                                   const ClassificationOptions& classification_options,
                                   const FeedforwardSolution& solution,
                                   const std::string& trajectory_note);

/// passed, max_tracking_error, bound, bound_rule, time_of_max_error, start,
/// solution_starts_at_rest with the deviations, plant_growth_rate, strategy, segment_length,
/// segments, forward tolerances, status, message, steps.
nlohmann::ordered_json VerificationToJson(const Verification& verification);

/// One line: why a verification failed.
std::string VerificationFailure(const Verification& verification);

}  // namespace servokit
