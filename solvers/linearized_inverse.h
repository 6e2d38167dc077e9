#pragma once
// The method `linearized`: the exact inverse of the model's linearization at the operating point,
// applied to the nonlinear model. For problems whose relative degree is not defined at the
// operating point (P, or the extended decoupling matrix, vanishes there but not nearby: a
// crane with a fixed rope observed at its load, a cart-pole observed at its centre of
// oscillation) no exact inverse passes through that point; the linearization's is the
// feedforward such users design today. It is an approximation: the forward check
// (solvers/verification.h) drives the nonlinear model with it and reports the true tracking error.
//
// The pieces, which the dispatcher (solvers/inverse_model.cpp) puts together: the deviation
// problem (the linearization as a model of its own, y_d - y0, and its class), the exact linear
// method that fits it (ExactLinearInverseMethod, solvers/method_choice.h), and the shift of its
// answer back to the operating point.
#include <memory>

#include "analysis/classification.h"
#include "modeling/model.h"
#include "solvers/feedforward_solution.h"
#include "trajectories/trajectory.h"

namespace servokit {

/// The linearization M dq'' + D dq' + K dq = B du, dy = H dq at classification's operating
/// point written as a model of its own (numeric matrices, the model's coordinate, input and
/// output names), in the deviations from (q0, u0, y0). Built from the matrices themselves
/// (ModelFromLinearEquations), not from a text of them.
Model LinearizedModel(const Model& model, const Classification& classification);

/// What the exact inverse of the linearization solves: the linearized model, its class at
/// q = 0, and y_d - y0 (which refers to the caller's trajectory: that must outlive it).
struct DeviationProblem {
  Model model;
  Classification classification;
  std::unique_ptr<OutputTrajectory> trajectory;
};

std::shared_ptr<DeviationProblem> MakeDeviationProblem(const Model& model,
                                                       const OutputTrajectory& trajectory,
                                                       const Classification& classification);

/// The deviation problem's solution shifted back by the operating point (q0, u0): its rows and
/// its extension (which keeps `deviation` alive), named kLinearized, with its reason (the
/// linear method used) and the warning that it inverts the linearization, not the model.
void ShiftToOperatingPoint(std::shared_ptr<const DeviationProblem> deviation,
                           const Classification& classification,
                           FeedforwardSolution& solution);

}  // namespace servokit
