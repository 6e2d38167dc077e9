#include "analysis/structure_options.h"

#include <algorithm>
#include <string>

namespace servokit {
namespace {

std::string OutputName(std::size_t output) { return "y" + std::to_string(output + 1); }

}  // namespace

double GenericCoordinate(std::size_t point, std::size_t j) {
  const double jj = double(j);
  return point == 1 ? 0.137 + 0.071 * jj : -0.211 + 0.053 * jj;
}

double GenericVelocity(std::size_t point, std::size_t j) {
  const double jj = double(j);
  return point == 1 ? 0.093 - 0.041 * jj : 0.177 + 0.029 * jj;
}

double GenericDesiredDerivative(std::size_t point, std::size_t i, std::size_t k) {
  const double ii = double(i), kk = double(k);
  return point == 1 ? 0.31 - 0.13 * kk + 0.07 * ii : -0.23 + 0.11 * kk - 0.05 * ii;
}

NoSolution OutputsNotIndependent(std::size_t output, std::size_t states) {
  return NoSolution("the outputs do not determine the inputs: with output " + OutputName(output) +
                    " the structure algorithm needs more than 2 dof = " + std::to_string(states) +
                    " constraints on the state (the outputs are not independent; no left "
                    "inverse exists)");
}

NoSolution OutputNeverDependsOnInputs(std::size_t output, std::size_t max_order) {
  return NoSolution("output " + OutputName(output) +
                    " never depends on the inputs (checked up to its derivative of order " +
                    std::to_string(max_order) + " = 2 dof), so it cannot be tracked");
}

NoSolution InputsNotRemoved(std::size_t output) {
  return NoSolution("the structure algorithm could not remove the inputs from output " +
                    OutputName(output) + "'s equation (rank decision failed)");
}

StructureStep KeptRowsAndColumns(const Eigen::MatrixXd& reference,
                                 std::size_t reference_rank,
                                 std::size_t rank) {
  const auto m = std::size_t(reference.rows());
  if (rank == 0 || reference_rank < rank) {
    throw UndefinedRelativeDegree(
        "the inputs' coefficients in the outputs' derivatives form a matrix of rank " +
        std::to_string(rank) + " of " + std::to_string(m) +
        " near the reference state but of lower rank there: the rows a dynamic extension "
        "would keep are not defined at the operating point");
  }
  Eigen::VectorXd row_size = reference.rowwise().norm();
  for (Eigen::Index i = 0; i < row_size.size(); ++i) {
    if (row_size[i] == 0) row_size[i] = 1;
  }
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(row_size.cwiseInverse().asDiagonal() * reference);
  StructureStep step;
  step.rank = rank;
  // P A Q = L U: P's indices say where each row of A went, so the row at pivot k is found by
  // P's inverse; Q's indices name the column at pivot k directly (A Q takes them in that order).
  const Eigen::PermutationMatrix<Eigen::Dynamic> rows_at_pivots(lu.permutationP().inverse());
  for (std::size_t k = 0; k < rank; ++k) {
    const auto pivot = Eigen::Index(k);
    step.kept_rows.push_back(std::size_t(rows_at_pivots.indices()[pivot]));
    step.delayed_inputs.push_back(std::size_t(lu.permutationQ().indices()[pivot]));
  }
  std::sort(step.kept_rows.begin(), step.kept_rows.end());
  std::sort(step.delayed_inputs.begin(), step.delayed_inputs.end());
  return step;
}

}  // namespace servokit
