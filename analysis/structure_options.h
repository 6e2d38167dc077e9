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
};

/// More than 2 dof constraints on the state: the outputs are not independent.
NoSolution OutputsNotIndependent(std::size_t output, std::size_t states);
/// No derivative up to 2 dof depends on the inputs.
NoSolution OutputNeverDependsOnInputs(std::size_t output, std::size_t max_order);

}  // namespace servokit
