#pragma once
// What both routes of the structure algorithm share (analysis/nonlinear_structure.h, symbolic;
// analysis/numeric_structure.h, numeric): their options and the errors they raise, worded once.
#include <Eigen/Dense>
#include <cstddef>

#include "base/errors.h"

namespace servokit {

struct NonlinearStructureOptions {
  // As ClassificationOptions::rank_tolerance.
  double rank_tolerance = 1e-10;
  // q at the reference state (q' = 0, y_d at rest there): where the kept rows are chosen. Empty:
  // q = 0.
  Eigen::VectorXd reference_q;
  // The most work the numeric route's motions may take (MotionSeries::Scratch::work: program
  // instructions times (degree + 1)^2, some 10 ns each): past it the algorithm stops with
  // NoSolution instead of going on to ever dearer derivatives. The shipped models need at most
  // 5e5, a chain of 100 pendulums 7e7 (0.6 s); a 50-link arm whose tip barely feels the base
  // (P = 6e-15, below the rank tolerance) would go on to order 100.
  double max_work = 1e9;
};

/// More than 2 dof constraints on the state: the outputs are not independent.
NoSolution OutputsNotIndependent(std::size_t output, std::size_t states);
/// No derivative up to 2 dof depends on the inputs.
NoSolution OutputNeverDependsOnInputs(std::size_t output, std::size_t max_order);

}  // namespace servokit
