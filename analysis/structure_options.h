#pragma once
// What both routes of the structure algorithm share (analysis/nonlinear_structure.h, symbolic;
// analysis/numeric_structure.h, numeric): their options and the errors they raise, worded once.
#include <Eigen/Dense>
#include <cstddef>
#include <vector>

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

/// The relative degree (or the rows a dynamic extension keeps) is not defined at the reference
/// state: the inputs' coefficient matrix is singular there but not nearby. No exact inverse
/// passes through that point.
class UndefinedRelativeDegree : public NoSolution {
 public:
  using NoSolution::NoSolution;
};

// One step of the structure algorithm at which the inputs' coefficient matrix had rank < m on
// a neighbourhood.
struct StructureStep {
  std::size_t rank = 0;
  std::vector<std::size_t> kept_rows;       // outputs whose input equation stays
  std::vector<std::size_t> combined_rows;   // replaced by g_d and differentiated further
  std::vector<std::size_t> delayed_inputs;  // the columns C: delayed by the dynamic extension
};

/// The rows and columns a step keeps (combined_rows left empty): the pivots of a full-pivoting
/// LU of `reference` (the inputs' coefficient matrix at the reference state), rows scaled to
/// unit size so that units do not choose. Throws UndefinedRelativeDegree when its rank there,
/// `reference_rank`, is below `rank` (the rank nearby) or `rank` is 0.
StructureStep KeptRowsAndColumns(const Eigen::MatrixXd& reference,
                                 std::size_t reference_rank,
                                 std::size_t rank);

/// The generic decision points both routes decide at (point 1 or 2; point 0 is the reference
/// state): small, unrelated values, no multiple of pi/2, no symmetry between coordinates.
/// Coordinate j's value and velocity, and output i's desired k-th derivative.
double GenericCoordinate(std::size_t point, std::size_t j);
double GenericVelocity(std::size_t point, std::size_t j);
double GenericDesiredDerivative(std::size_t point, std::size_t i, std::size_t k);

/// More than 2 dof constraints on the state: the outputs are not independent.
NoSolution OutputsNotIndependent(std::size_t output, std::size_t states);
/// No derivative up to 2 dof depends on the inputs.
NoSolution OutputNeverDependsOnInputs(std::size_t output, std::size_t max_order);
/// The inputs' coefficients in output `output`'s equation did not vanish after its combination
/// with the kept rows.
NoSolution InputsNotRemoved(std::size_t output);

}  // namespace servokit
