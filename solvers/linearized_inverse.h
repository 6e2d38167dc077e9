#pragma once
// The method `linearized`: the exact inverse of the model's linearization at the operating point,
// applied to the nonlinear model. For problems whose relative degree is not defined at the
// operating point (P, or the extended decoupling matrix, vanishes there but not nearby: a
// crane with a fixed rope observed at its load, a cart-pole observed at its centre of
// oscillation) no exact inverse passes through that point; the linearization's is the
// feedforward such users design today. It is an approximation: the forward check
// (solvers/verification.h) drives the nonlinear model with it and reports the true tracking error.
#include "analysis/classification.h"
#include "models/model.h"
#include "solvers/inverse_model.h"
#include "trajectories/trajectory.h"

namespace servokit {

/// The linearization M dq'' + D dq' + K dq = B du, dy = H dq at classification's operating
/// point written as a model of its own (numeric matrices, the model's coordinate, input and
/// output names), in the deviations from (q0, u0, y0).
Model LinearizedModel(const Model& model, const Classification& classification);

/// Solves the linearized model's inverse for y_d - y0 (algebraic when it is flat, stable
/// inversion otherwise; normal form when its zero dynamics are critical) and shifts the answer
/// back by (q0, u0). `options` as for SolveInverseModel (method ignored). The solution names
/// the method kLinearized, its reason the linear method used.
FeedforwardSolution SolveLinearizedInverse(const Model& model,
                                           const OutputTrajectory& trajectory,
                                           const Classification& classification,
                                           const InverseModelOptions& options);

}  // namespace servokit
