#pragma once
// What `servokit solve` writes (DESIGN.md "solve"): the CSV of the feedforward and the JSON
// object on stdout.
#include <nlohmann/json.hpp>

#include <string>

#include "analysis/classification.h"
#include "models/model.h"
#include "solvers/inverse_model.h"
#include "solvers/trajectory.h"

namespace servokit {

/// Writes t, each coordinate, each <coordinate>_dot, each input, y1_d, ... one row per sample,
/// numbers exact (shortest round-trip form). Written to FILE.partial and renamed, so an
/// interrupted write never leaves a truncated FILE. Throws Error when the file cannot be written.
void WriteFeedforwardCsv(const std::string& path,
                         const Model& model,
                         const OutputTrajectory& trajectory,
                         const FeedforwardSolution& solution);

/// method, method_reason, status, message, stop_time, the counters, max_servo_residual,
/// samples, trajectory_note (when the trajectory was raised in order) and classification (the
/// analyze object).
nlohmann::ordered_json SolveToJson(const Model& model,
                                   const Classification& classification,
                                   const ClassificationOptions& classification_options,
                                   const FeedforwardSolution& solution,
                                   const std::string& trajectory_note);

/// max_tracking_error, time_of_max_error, status, message, steps.
nlohmann::ordered_json VerificationToJson(const Verification& verification);

}  // namespace servokit
