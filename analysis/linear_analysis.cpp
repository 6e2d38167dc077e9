#include "analysis/linear_analysis.h"

#include <Eigen/SparseLU>
#include <algorithm>
#include <limits>
#include <numeric>
#include <optional>
#include <string>

#include "analysis/subspaces.h"
#include "base/errors.h"
#include "base/option_check.h"
#include "numerics/sparse_structure.h"

namespace servokit {
namespace {

using MassSolver = Eigen::SparseLU<SparseMatrix, Eigen::COLAMDOrdering<int>>;

// The sparse LU of M and M^-1 B, which both the relative degrees and the reduced model need:
// AnalyzeLinearSystem factors M once for the two.
struct FactoredMass {
  MassSolver solver;
  Eigen::MatrixXd input;                // B, dense (n x m, m small)
  Eigen::MatrixXd input_accelerations;  // M^-1 B
};

void FactorMass(const LinearSystem& system, FactoredMass& factored) {
  // Before the LU, which never returns for a large M with too few entries (FindZeroColumn).
  if (const std::optional<Eigen::Index> column = FindZeroColumn(system.mass)) {
    throw NoSolution("the mass matrix M is singular: its column " + std::to_string(*column + 1) +
                     " is zero");
  }
  SparseMatrix compressed = system.mass;
  compressed.makeCompressed();
  factored.solver.compute(compressed);
  if (factored.solver.info() != Eigen::Success) {
    throw NoSolution("the mass matrix M is singular: " + factored.solver.lastErrorMessage());
  }
  factored.input = Eigen::MatrixXd(system.input_matrix);
  factored.input_accelerations = factored.solver.solve(factored.input);
}

// An orthonormal basis of the column space of a tall n x p matrix (p small): column-pivoted
// Householder QR, O(n p^2), never an n x n factor.
Eigen::MatrixXd TallColumnSpaceBasis(const Eigen::MatrixXd& matrix, double relative_tolerance) {
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(matrix);
  qr.setThreshold(relative_tolerance);
  const Eigen::Index rank = qr.rank();
  Eigen::MatrixXd basis = Eigen::MatrixXd::Identity(matrix.rows(), rank);
  basis.applyOnTheLeft(qr.householderQ());
  return basis;
}

}  // namespace

void LinearAnalysisOptions::Validate() const {
  RequireOption(rank_tolerance > 0.0 && rank_tolerance < 1.0, "LinearAnalysisOptions",
                "rank_tolerance", rank_tolerance, "must be > 0 and < 1");
  zero_dynamics.Validate();
}

namespace {

LinearRelativeDegrees RelativeDegrees(const LinearSystem& system,
                                      FactoredMass& factored,
                                      double rank_tolerance) {
  const Eigen::Index n = system.dof();
  const Eigen::Index m = system.num_inputs();
  MassSolver& mass_solver = factored.solver;
  const Eigen::MatrixXd& input_accelerations = factored.input_accelerations;
  const double input_size = input_accelerations.norm();  // |B| of the first-order form
  const SparseMatrix stiffness_transpose = system.stiffness.transpose();
  const SparseMatrix damping_transpose = system.damping.transpose();
  const SparseMatrix input_transpose = system.input_matrix.transpose();

  LinearRelativeDegrees result;
  result.relative_degree.assign(std::size_t(m), 0);
  result.decoupling_matrix = Eigen::MatrixXd::Zero(m, m);
  // Beyond kMaxRelativeDegreeSearch derivatives the Markov rows of a real model have fallen
  // below round-off anyway (and each derivative costs a sparse solve of size n).
  const Eigen::Index search = std::min<Eigen::Index>(2 * n, kMaxRelativeDegreeSearch);
  for (Eigen::Index i = 0; i < m; ++i) {
    Eigen::VectorXd position_part = Eigen::VectorXd(system.output_matrix.row(i).transpose());
    Eigen::VectorXd velocity_part = Eigen::VectorXd::Zero(n);
    for (Eigen::Index k = 0; k < search; ++k) {
      const double row_size = std::hypot(position_part.norm(), velocity_part.norm());
      // (a, b) B_state = b^T M^-1 B = w^T B with w = M^-T b.
      const Eigen::VectorXd w = mass_solver.transpose().solve(velocity_part);
      const Eigen::VectorXd markov = input_transpose * w;
      if (markov.norm() > rank_tolerance * row_size * input_size) {
        result.relative_degree[std::size_t(i)] = static_cast<int>(k + 1);
        result.decoupling_matrix.row(i) = markov.transpose();
        break;
      }
      // (a, b) A_state = (-K^T w, a - D^T w).
      Eigen::VectorXd next_velocity_part = position_part - damping_transpose * w;
      position_part = -(stiffness_transpose * w);
      velocity_part = std::move(next_velocity_part);
    }
    if (result.relative_degree[std::size_t(i)] == 0) {
      if (search == 2 * n) {
        throw NoSolution("output y" + std::to_string(i + 1) +
                         " is not influenced by the inputs (infinite relative degree): every "
                         "Markov parameter C A^k B up to k = 2n is below rank_tolerance times "
                         "its factors; no input can make it follow a trajectory");
      }
      result.determined = false;
      result.note = "output y" + std::to_string(i + 1) +
                    ": every Markov parameter C A^k B up to k = " + std::to_string(search) +
                    " is below rank_tolerance times its factors, so the relative degree is not "
                    "determined numerically (a fine mesh of a continuum, whose coupling decays "
                    "exponentially along the mesh, looks like this: e.g. the tip of a flexible "
                    "link driven at the hub)";
      return result;
    }
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(result.decoupling_matrix);
  result.decoupling_matrix_regular =
      NumericalRank(svd.singularValues(), rank_tolerance * result.decoupling_matrix.norm()) == m;
  return result;
}

Linearization Reduced(const LinearSystem& system, FactoredMass& factored, double rank_tolerance) {
  const Eigen::Index n = system.dof();
  const Eigen::Index m = system.num_inputs();
  MassSolver& mass_solver = factored.solver;
  const Eigen::MatrixXd& input = factored.input;
  const Eigen::MatrixXd& input_accelerations = factored.input_accelerations;
  const Eigen::MatrixXd output_transpose = Eigen::MatrixXd(system.output_matrix.transpose());
  Eigen::MatrixXd spanning(n, 3 * m);
  spanning << output_transpose, input, input_accelerations;
  // Columns scaled to unit size so that one relative threshold decides the rank.
  for (Eigen::Index j = 0; j < spanning.cols(); ++j) {
    const double size = spanning.col(j).norm();
    if (size > 0.0) spanning.col(j) /= size;
  }
  const Eigen::MatrixXd basis = TallColumnSpaceBasis(spanning, rank_tolerance);
  const Eigen::MatrixXd mass_inverse_basis = mass_solver.solve(basis);

  Linearization reduced;
  reduced.output_jacobian = Eigen::MatrixXd(system.output_matrix * basis);
  reduced.input_matrix = basis.transpose() * input;
  reduced.mass_inverse = basis.transpose() * mass_inverse_basis;
  reduced.mass_inverse = 0.5 * (reduced.mass_inverse + reduced.mass_inverse.transpose()).eval();
  reduced.mass_matrix = reduced.mass_inverse.inverse();
  reduced.input_acceleration = reduced.mass_inverse * reduced.input_matrix;
  return reduced;
}

}  // namespace

LinearRelativeDegrees ComputeLinearRelativeDegrees(const LinearSystem& system,
                                                   double rank_tolerance) {
  system.Validate();
  FactoredMass factored;
  FactorMass(system, factored);
  return RelativeDegrees(system, factored, rank_tolerance);
}

Linearization ReducedLinearization(const LinearSystem& system, double rank_tolerance) {
  system.Validate();
  FactoredMass factored;
  FactorMass(system, factored);
  return Reduced(system, factored, rank_tolerance);
}

LinearAnalysis AnalyzeLinearSystem(const LinearSystem& system,
                                   LinearZeroDynamicsWorkspace& workspace,
                                   const LinearAnalysisOptions& options) {
  options.Validate();
  system.Validate();
  LinearAnalysis result;
  ClassificationOptions classification_options;
  classification_options.rank_tolerance = options.rank_tolerance;
  classification_options.imaginary_axis_tolerance = options.zero_dynamics.imaginary_axis_tolerance;
  FactoredMass factored;
  FactorMass(system, factored);
  result.decoupling = AnalyzeDecouplingMatrix(Reduced(system, factored, options.rank_tolerance),
                                              classification_options);
  result.relative_degrees = RelativeDegrees(system, factored, options.rank_tolerance);
  if (!result.relative_degrees.determined) {
    // Without the structure at infinity the number of zeros is unknown: the eigensolver gives
    // the zeros it is asked for (nearest the shift, or rightmost), and says so in its scope.
    result.internal_dynamics_order = -1;
    result.zero_dynamics =
        ComputeLinearZeroDynamics(system, workspace, kUnknownZeroCount, options.zero_dynamics);
    // The index is unknown too: Radau, the general method, unless stability decides.
    result.recommended_solver =
        RecommendSolver(false, result.zero_dynamics.stability, std::numeric_limits<int>::max());
    return result;
  }
  if (!result.relative_degrees.decoupling_matrix_regular) {
    throw NoSolution(
        "the decoupling matrix (rows C_i A^(r_i - 1) B) is singular: no vector relative degree; "
        "the structure at infinity of a large linear model is computed only for a regular one");
  }
  const std::vector<int>& degrees = result.relative_degrees.relative_degree;
  const int highest = *std::max_element(degrees.begin(), degrees.end());
  const long total = std::accumulate(degrees.begin(), degrees.end(), 0L);
  // The same definitions as AnalyzeOutputStructure for a regular decoupling matrix, where the
  // orders of the infinite zeros are the relative degrees.
  result.differentiation_index = highest + 1;
  result.projected_index = highest - 1;
  result.internal_dynamics_order = 2 * system.dof() - total;
  result.flat = result.internal_dynamics_order == 0;
  result.zero_dynamics = ComputeLinearZeroDynamics(
      system, workspace, result.internal_dynamics_order, options.zero_dynamics);
  result.recommended_solver =
      RecommendSolver(result.flat, result.zero_dynamics.stability, result.projected_index);
  return result;
}

}  // namespace servokit
