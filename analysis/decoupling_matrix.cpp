#include "analysis/decoupling_matrix.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "analysis/subspaces.h"
#include "base/errors.h"

namespace servokit {

void DecouplingMatrix(const Eigen::Ref<const Eigen::MatrixXd>& output_jacobian,
                      const Eigen::Ref<const Eigen::MatrixXd>& input_accelerations,
                      Eigen::MatrixXd& decoupling) {
  decoupling.noalias() = output_jacobian * input_accelerations;
}

Eigen::MatrixXd DecouplingMatrix(const Eigen::Ref<const Eigen::MatrixXd>& output_jacobian,
                                 const Eigen::Ref<const Eigen::MatrixXd>& input_accelerations) {
  Eigen::MatrixXd decoupling;
  DecouplingMatrix(output_jacobian, input_accelerations, decoupling);
  return decoupling;
}

Eigen::MatrixXd TangentBasis(const Eigen::MatrixXd& output_jacobian, double rank_tolerance) {
  return NullSpaceBasis(output_jacobian, rank_tolerance * output_jacobian.norm());
}

DecouplingAnalysis AnalyzeDecouplingMatrix(const Linearization& linearization,
                                           const ClassificationOptions& options) {
  const Eigen::MatrixXd& output_jacobian = linearization.output_jacobian;
  const Eigen::MatrixXd& input_matrix = linearization.input_matrix;
  const Eigen::Index outputs = output_jacobian.rows();

  DecouplingAnalysis result;
  result.tangent_basis = TangentBasis(output_jacobian, options.rank_tolerance);
  if (result.tangent_basis.cols() != linearization.dof() - outputs) {
    throw NoSolution("the outputs are not independent at the operating point: H = dh/dq has rank " +
                     std::to_string(linearization.dof() - result.tangent_basis.cols()) + " < " +
                     std::to_string(outputs));
  }

  const Eigen::MatrixXd& input_accelerations = linearization.input_acceleration;
  result.decoupling_matrix = DecouplingMatrix(output_jacobian, input_accelerations);
  result.singular_values = SingularValues(result.decoupling_matrix);
  // Scale: |H| |M^-1 B| bounds sigma_max(P); see ClassificationOptions::rank_tolerance.
  result.rank_threshold =
      options.rank_tolerance * output_jacobian.norm() * input_accelerations.norm();
  // A threshold below the smallest normal double has lost its digits to underflow (and an
  // infinite one means |H| |M^-1 B| overflowed): the rank of P cannot be decided then, and a
  // verdict would be an artefact of the number format (e.g. m2 = 1e308 in the mass on car).
  const double scale = output_jacobian.norm() * input_accelerations.norm();
  if (!std::isfinite(result.rank_threshold) ||
      (scale > 0.0 && result.rank_threshold < std::numeric_limits<double>::min())) {
    std::ostringstream message;
    message << "the rank of P = H M^-1 B cannot be decided in double precision: its scale |H| "
               "|M^-1 B| = "
            << scale << " puts the rank threshold " << result.rank_threshold
            << " outside the range of normal doubles (parameters near 0 or huge?)";
    throw NoSolution(message.str());
  }
  result.rank = NumericalRank(result.singular_values, result.rank_threshold);
  result.rank_deficiency = outputs - result.rank;

  const double input_size = input_matrix.norm();
  result.tangential_input_share =
      input_size > 0.0 ? (result.tangent_basis.transpose() * input_matrix).norm() / input_size
                       : 0.0;
  if (result.rank == outputs) {
    result.realization = result.tangential_input_share <= options.rank_tolerance
                             ? Realization::kIdealOrthogonal
                             : Realization::kNonIdealOrthogonal;
  } else if (result.rank == 0) {
    result.realization = Realization::kTangential;
  } else {
    result.realization = Realization::kMixed;
  }
  return result;
}

}  // namespace servokit
