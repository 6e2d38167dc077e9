#include "analysis/output_structure.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <string>

#include "analysis/subspaces.h"
#include "base/errors.h"
#include "numerics/finite.h"

namespace servokit {
namespace {

// next = row A for the state matrix of ToStateSpace, A = [0, t I; A21, A22] (t the time
// scale): next = [b A21, t a + b A22] for row = [a b], without the products by the zero and
// identity blocks. Column by column: each entry is a dot product with a contiguous column
// piece, which for these few coordinates costs less than a general matrix-vector product.
void MultiplyByStateMatrix(const StateSpace& system,
                           const Eigen::RowVectorXd& row,
                           Eigen::RowVectorXd& next) {
  const Eigen::MatrixXd& A = system.state_matrix;
  const Eigen::Index dof = A.rows() / 2;
  const auto velocity_part = row.tail(dof).transpose();
  for (Eigen::Index j = 0; j < dof; ++j) {
    next(j) = velocity_part.dot(A.col(j).tail(dof));
    next(dof + j) = system.time_scale * row(j) + velocity_part.dot(A.col(dof + j).tail(dof));
  }
}

// Per-output relative degrees and the rows C_i A^(r_i - 1) B. A row counts as zero when it is
// at most rank_tolerance |C_i A^k| |B| (the size its factors allow).
void FindRelativeDegrees(const StateSpace& system,
                         double rank_tolerance,
                         OutputStructure& structure) {
  const Eigen::Index outputs = system.output_matrix.rows();
  const Eigen::Index states = system.state_matrix.rows();
  const Eigen::Index dof = states / 2;
  // The block structure of ToStateSpace that the products below rely on.
  assert(system.state_matrix.topLeftCorner(dof, dof).isZero(0.0));
  assert(system.input_matrix.topRows(dof).isZero(0.0));
  const double input_size = SafeNorm(system.input_matrix);
  structure.relative_degree.assign(std::size_t(outputs), 0);
  structure.decoupling_matrix = Eigen::MatrixXd::Zero(outputs, system.input_matrix.cols());
  Eigen::RowVectorXd output_row(states), next_row(states);  // C_i A^k, reused
  Eigen::RowVectorXd markov_row(system.input_matrix.cols());
  for (Eigen::Index i = 0; i < outputs; ++i) {
    output_row = system.output_matrix.row(i);
    for (Eigen::Index k = 0; k < states; ++k) {
      // B = [0; M^-1 B / t]: only the velocity part of the row meets it.
      for (Eigen::Index input = 0; input < markov_row.size(); ++input) {
        markov_row(input) =
            output_row.tail(dof).dot(system.input_matrix.col(input).tail(dof).transpose());
      }
      // SafeNorm: the squares of norm() overflow long before the entries do.
      const double allowed = rank_tolerance * SafeNorm(output_row) * input_size;
      if (!AllFinite(markov_row) || !std::isfinite(allowed)) {
        throw NoSolution("output y" + std::to_string(i + 1) + ": the Markov parameter C A^" +
                         std::to_string(k) +
                         " B overflows the range of double at the operating point (a "
                         "parameter near the end of the double range?)");
      }
      if (SafeNorm(markov_row) > allowed) {
        structure.relative_degree[std::size_t(i)] = static_cast<int>(k + 1);
        structure.decoupling_matrix.row(i) = markov_row;
        break;
      }
      MultiplyByStateMatrix(system, output_row, next_row);
      output_row.swap(next_row);
    }
    if (structure.relative_degree[std::size_t(i)] == 0) {
      throw NoSolution("output y" + std::to_string(i + 1) +
                       " is not influenced by the inputs at the operating point (infinite "
                       "relative degree): no input can make it follow a trajectory");
    }
  }
  const double scale = structure.decoupling_matrix.norm();
  structure.decoupling_matrix_regular =
      NumericalRank(SingularValues(structure.decoupling_matrix), rank_tolerance * scale) == outputs;
}

// Regular decoupling matrix (the vector relative degree r exists): V* is the kernel of the rows
// C_i A^k, k < r_i, which are independent, so dim V* = states - sum r_i; the infinite zeros have
// the orders r_i (Isidori 1995, Sect. 5.1; Falb & Wolovich). No iteration. Returns false when
// the numbers do not bear that out (sum r_i > states, or the kernel's numerical dimension is
// not states - sum r_i, both only inside the tolerance band of a singular point): the V*
// iteration decides then.
bool RegularStructure(const StateSpace& system, double rank_tolerance, OutputStructure& structure) {
  const Eigen::MatrixXd& A = system.state_matrix;
  const Eigen::MatrixXd& C = system.output_matrix;
  const Eigen::Index states = A.rows();
  Eigen::Index sum = 0;
  for (const int degree : structure.relative_degree) sum += degree;
  if (sum > states) return false;
  if (sum == states) {
    structure.zero_dynamics_subspace.resize(states, 0);  // flat: V* = {0}
  } else {
    // Each row scaled to unit size, so that one relative tolerance decides their rank.
    Eigen::MatrixXd rows(sum, states);
    Eigen::Index next = 0;
    for (Eigen::Index i = 0; i < C.rows(); ++i) {
      Eigen::RowVectorXd row = C.row(i);
      for (int k = 0; k < structure.relative_degree[std::size_t(i)]; ++k) {
        const double size = SafeNorm(row);
        if (!(size > 0.0) || !std::isfinite(size)) return false;
        rows.row(next++) = row / size;
        row = row * A;
      }
    }
    Eigen::MatrixXd kernel = NullSpaceBasis(rows, rank_tolerance * rows.norm());
    if (kernel.cols() != states - sum) return false;
    structure.zero_dynamics_subspace = std::move(kernel);
  }
  structure.internal_dynamics_order = static_cast<int>(states - sum);
  structure.infinite_zero_orders = structure.relative_degree;
  std::sort(structure.infinite_zero_orders.begin(), structure.infinite_zero_orders.end());
  const int highest_order = structure.infinite_zero_orders.back();
  structure.differentiation_index = highest_order + 1;
  structure.projected_index = highest_order - 1;
  return true;
}

}  // namespace

OutputStructure AnalyzeOutputStructure(const Linearization& linearization,
                                       const ClassificationOptions& options,
                                       StructureRoute route) {
  OutputStructure structure;
  structure.state_space = ToStateSpace(linearization);
  const StateSpace& system = structure.state_space;
  const Eigen::MatrixXd& A = system.state_matrix;
  const Eigen::MatrixXd& B = system.input_matrix;
  const Eigen::MatrixXd& C = system.output_matrix;
  const Eigen::Index states = A.rows();
  const double tolerance = options.rank_tolerance;

  FindRelativeDegrees(system, tolerance, structure);

  // Orthogonal realization (every output has relative degree 2, C A B = P regular): V* is
  // {dq in ker H, dq' in ker H} and every infinite zero has order 2 (paper Eq. 25: the internal
  // dynamics are the f - m second-order equations on the constraint manifold). No iteration.
  const bool orthogonal =
      structure.decoupling_matrix_regular &&
      std::all_of(structure.relative_degree.begin(), structure.relative_degree.end(),
                  [](int degree) { return degree == 2; });
  if (orthogonal) {
    const Eigen::Index dof = states / 2;
    const Eigen::MatrixXd tangent = NullSpaceBasis(C.leftCols(dof), tolerance * C.norm());
    structure.zero_dynamics_subspace = Eigen::MatrixXd::Zero(states, 2 * tangent.cols());
    structure.zero_dynamics_subspace.topLeftCorner(dof, tangent.cols()) = tangent;
    structure.zero_dynamics_subspace.bottomRightCorner(dof, tangent.cols()) = tangent;
    structure.internal_dynamics_order = static_cast<int>(2 * tangent.cols());
    structure.infinite_zero_orders.assign(std::size_t(C.rows()), 2);
    structure.differentiation_index = 3;
    structure.projected_index = 1;
    return structure;
  }
  if (route == StructureRoute::kDirect && structure.decoupling_matrix_regular &&
      RegularStructure(system, tolerance, structure)) {
    return structure;
  }

  // V* iteration; dimensions[k] = dim V_k. V_1 = ker C whatever B is, so start there.
  const Eigen::MatrixXd output_kernel = NullSpaceBasis(C, tolerance * C.norm());
  const Eigen::MatrixXd mapped_kernel = A * output_kernel;
  const double mapped_size = std::max(mapped_kernel.norm(), std::numeric_limits<double>::min());
  // B scaled to unit size, so that one relative tolerance decides the rank of [V_k, B].
  const Eigen::MatrixXd unit_input = B / std::max(B.norm(), std::numeric_limits<double>::min());
  std::vector<Eigen::Index> dimensions{states, output_kernel.cols()};
  Eigen::MatrixXd subspace = output_kernel;
  Eigen::Index sum_rank = 0;  // rank of [V*, B] at the end
  for (Eigen::Index step = 0; step <= states; ++step) {
    Eigen::MatrixXd subspace_and_inputs(states, subspace.cols() + B.cols());
    subspace_and_inputs << subspace, unit_input;
    // x in ker C with A x in V_k + im B: A x has no part in the complement of that sum.
    const Eigen::MatrixXd complement = ComplementBasis(subspace_and_inputs, tolerance);
    sum_rank = states - complement.cols();
    const Eigen::MatrixXd coefficients =
        NullSpaceBasis(complement.transpose() * mapped_kernel, tolerance * mapped_size);
    if (coefficients.cols() == subspace.cols()) break;  // nested and equal in size: V* found
    subspace = output_kernel * coefficients;  // orthonormal: a product of orthonormal bases
    dimensions.push_back(subspace.cols());
  }
  structure.zero_dynamics_subspace = subspace;
  structure.internal_dynamics_order = static_cast<int>(subspace.cols());

  // d_k = dim V_k - dim V_{k+1} infinite zeros have order > k.
  std::vector<int> orders;
  for (std::size_t k = 0; k + 1 < dimensions.size(); ++k) {
    const Eigen::Index above_k = dimensions[k] - dimensions[k + 1];
    const Eigen::Index above_next =
        k + 2 < dimensions.size() ? dimensions[k + 1] - dimensions[k + 2] : 0;
    for (Eigen::Index j = 0; j < above_k - above_next; ++j) orders.push_back(int(k + 1));
  }
  std::sort(orders.begin(), orders.end());
  structure.infinite_zero_orders = orders;
  const auto outputs = static_cast<std::size_t>(C.rows());
  if (orders.size() != outputs) {
    throw NoSolution("the structure at infinity has " + std::to_string(orders.size()) +
                     " infinite zeros for " + std::to_string(outputs) +
                     " outputs: the outputs are not independent under the dynamics");
  }

  // Left invertibility: on V* the input that keeps y = 0 must be unique, i.e. [V*, B] has
  // full column rank.
  if (sum_rank != subspace.cols() + B.cols()) {
    throw NoSolution(
        "the output does not determine the inputs (the linearization is not "
        "left-invertible): the servo-constraint problem has no unique solution");
  }

  const int highest_order = orders.empty() ? 0 : orders.back();
  structure.differentiation_index = highest_order + 1;
  structure.projected_index = highest_order - 1;
  return structure;
}

}  // namespace servokit
