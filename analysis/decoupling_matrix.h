#pragma once
// P = H M^-1 B (paper Eq. 10), its rank, the tangent basis D (Eq. 11) and the realization.
#include <Eigen/Dense>

#include "analysis/linearization.h"
#include "analysis/options.h"
#include "base/vocabulary.h"

namespace servokit {

/// P = H M^-1 B (paper Eq. 10): the one place this formula is written. H is outputs x dof,
/// M^-1 B (the input accelerations) dof x inputs; writes outputs x inputs into `decoupling`
/// (resized only when its size differs, so that integrators' inner loops do not allocate).
void DecouplingMatrix(const Eigen::Ref<const Eigen::MatrixXd>& output_jacobian,
                      const Eigen::Ref<const Eigen::MatrixXd>& input_accelerations,
                      Eigen::MatrixXd& decoupling);

/// The same, returned.
Eigen::MatrixXd DecouplingMatrix(const Eigen::Ref<const Eigen::MatrixXd>& output_jacobian,
                                 const Eigen::Ref<const Eigen::MatrixXd>& input_accelerations);

/// An orthonormal D with H D = 0 (paper Eq. 11): dof x (dof - rank H).
Eigen::MatrixXd TangentBasis(const Eigen::MatrixXd& output_jacobian, double rank_tolerance);

struct DecouplingAnalysis {
  Eigen::MatrixXd decoupling_matrix;  // P, outputs x inputs
  Eigen::VectorXd singular_values;    // of P, descending
  double rank_threshold = 0.0;        // singular values at most this count as zero (absolute)
  Eigen::Index rank = 0;
  Eigen::Index rank_deficiency = 0;   // outputs - rank: how many outputs are realized tangentially
  Eigen::MatrixXd tangent_basis;      // D, dof x (dof - outputs)
  double tangential_input_share = 0;  // |D^T B| / |B|: 0 when B u is orthogonal to the manifold
  Realization realization = Realization::kTangential;
};

/// P at the operating point, its singular values and rank, D and the realization:
/// ideal orthogonal (rank P = m and D^T B = 0), non-ideal orthogonal (rank P = m),
/// tangential (rank P = 0), mixed (otherwise). Throws NoSolution if H has rank < m there.
DecouplingAnalysis AnalyzeDecouplingMatrix(const Linearization& linearization,
                                           const ClassificationOptions& options);

}  // namespace servokit
