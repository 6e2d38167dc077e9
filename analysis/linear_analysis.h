#pragma once
// The analyses of `servokit analyze` for a large sparse linear model M q'' + D q' + K q = B u,
// y = C q (issue #6), at its operating point q = 0, q' = 0, u = 0, y = 0 (a linear model is its
// own linearization there, and every point gives the same classification):
//  - P = C M^-1 B (paper Eq. 10) with one sparse LU of M, its singular values, rank and the
//    realization, decided by AnalyzeDecouplingMatrix (analysis/decoupling_matrix.h) on an exact
//    reduction of the model to span{C^T, B, M^-1 B} (see ReducedLinearization);
//  - the relative degree of each output from the Markov rows of the first-order form with
//    sparse solves (see ComputeLinearRelativeDegrees), the differentiation index, the order of
//    the internal dynamics 2n - sum r and flatness, as analysis/output_structure.h defines them
//    for a regular decoupling matrix;
//  - the zero dynamics (analysis/linear_zero_dynamics.h) and RecommendSolver.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "analysis/classification.h"
#include "analysis/decoupling_matrix.h"
#include "analysis/linear_zero_dynamics.h"
#include "analysis/linearization.h"

namespace servokit {

struct LinearAnalysisOptions {
  // Rank decisions (P, Markov rows), as ClassificationOptions::rank_tolerance and for the same
  // reason: relative to the sizes of the factors, far above round-off, far below coupling.
  double rank_tolerance = 1e-10;
  LinearZeroDynamicsOptions zero_dynamics;
  /// Throws UsageError naming the field, its value and the rule it breaks.
  void Validate() const;
};

/// Relative degrees and the decoupling matrix of a linear model.
struct LinearRelativeDegrees {
  // Per output: the least r with C_i A^(r-1) B != 0 for the first-order form x = (q, q'),
  // A = [[0, I], [-M^-1 K, -M^-1 D]], B = [0; M^-1 B]: the first derivative of y_i that u enters.
  std::vector<int> relative_degree;
  Eigen::MatrixXd decoupling_matrix;  // rows C_i A^(r_i - 1) B, outputs x inputs
  bool decoupling_matrix_regular = false;
  // False when an output's Markov rows stay below the rank tolerance for all
  // kMaxRelativeDegreeSearch derivatives of a model with more coordinates than that: the
  // relative degrees are then not determined numerically (relative_degree holds 0 from that
  // output on) and `note` says which output and why.
  bool determined = true;
  std::string note;
};

/// Derivatives searched for the relative degree of a large model (all 2n when 2n is smaller).
inline constexpr Eigen::Index kMaxRelativeDegreeSearch = 60;

/// The relative degrees by the row recursion (a, b) -> (a, b) A = (-w^T K, a^T - w^T D) with
/// w = M^-T b (one sparse solve per derivative; Markov row w^T B), started at (C_i, 0). A row
/// counts as zero when its norm is at most rank_tolerance |(a, b)| |M^-1 B|. Cost: r_i solves per
/// output (at most kMaxRelativeDegreeSearch). Throws NoSolution for an output that no input
/// reaches within all 2n derivatives; when 2n exceeds the search, says `determined = false`.
LinearRelativeDegrees ComputeLinearRelativeDegrees(const LinearSystem& system,
                                                   double rank_tolerance);

/// A dense Linearization of size p <= 3m with the same P, the same rank of H, the same norms
/// |H|, |B|, |M^-1 B| and the same |D^T B| as the model: coordinates U^T q with U an orthonormal
/// basis of span{C^T, B, M^-1 B}, H = C U, B = U^T B, mass_inverse = U^T M^-1 U. Then
/// H mass_inverse B = C U U^T M^-1 U U^T B = C M^-1 B because B and M^-1 B lie in span U, and the
/// part of B orthogonal to ker C is the same in both. Lets AnalyzeDecouplingMatrix decide the
/// realization of a large model without an n x n matrix. Damping and stiffness are left empty.
Linearization ReducedLinearization(const LinearSystem& system, double rank_tolerance);

struct LinearAnalysis {
  // P, singular values, rank, realization. tangent_basis is in the reduced coordinates of
  // ReducedLinearization (p x (p - m)), not n x (n - m).
  DecouplingAnalysis decoupling;
  LinearRelativeDegrees relative_degrees;
  int differentiation_index = 0;             // max r + 1 (analysis/output_structure.h)
  int projected_index = 0;                   // max r - 1
  Eigen::Index internal_dynamics_order = 0;  // 2n - sum r; -1 when not determined
  bool flat = false;                         // no internal dynamics
  LinearZeroDynamics zero_dynamics;
  SolverMethod recommended_solver = SolverMethod::kAuto;
};

/// Analyses `system` at q = 0, u = 0. `workspace` holds the LU of the Rosenbrock matrix and can
/// be reused for the next parameter point. When the relative degrees are not determined
/// numerically (relative_degrees.determined), the indices and the internal order stay unknown
/// (0, 0, -1) and the zero dynamics are the eigenvalues asked for, of an unknown total.
/// Throws UsageError for bad options or shapes,
/// NoSolution if M is singular, C has rank < m, an output has infinite relative degree, the
/// decoupling matrix is singular (the structure at infinity of large models is computed only
/// for a regular one), or an eigensolver fails.
LinearAnalysis AnalyzeLinearSystem(const LinearSystem& system,
                                   LinearZeroDynamicsWorkspace& workspace,
                                   const LinearAnalysisOptions& options = {});

}  // namespace servokit
