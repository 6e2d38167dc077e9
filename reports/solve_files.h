#pragma once
// What `servokit solve` writes (DESIGN.md "solve"): the CSV of the feedforward and the JSON
// object on stdout.
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/classification.h"
#include "models/model.h"
#include "solvers/inverse_model.h"
#include "solvers/trajectory.h"
#include "solvers/verification.h"

namespace servokit {

/// Writes t, each coordinate, each <coordinate>_dot, each input, y1_d, ... one row per sample,
/// numbers exact (shortest round-trip form). Written to FILE.partial and renamed, so an
/// interrupted write never leaves a truncated FILE. Throws Error when the file cannot be written.
void WriteFeedforwardCsv(const std::string& path,
                         const Model& model,
                         const OutputTrajectory& trajectory,
                         const FeedforwardSolution& solution);

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
