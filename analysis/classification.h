#pragma once
// What kind of servo-constraint problem a model is at an operating point: the answer of
// `servokit analyze` (docs/analyze.md), assembled from the analyses of this folder.
#include <complex>
#include <optional>
#include <string>
#include <vector>

#include "analysis/decoupling_matrix.h"
#include "analysis/linearization.h"
#include "analysis/nonlinear_structure.h"
#include "analysis/operating_point.h"
#include "analysis/options.h"
#include "analysis/output_structure.h"
#include "analysis/zero_dynamics.h"
#include "base/vocabulary.h"
#include "modeling/model.h"

namespace servokit {

/// The second route to the zero dynamics (invariant zeros by QZ) and how far it is from the first.
/// The verdict (Classification::zero_dynamics) is always the first route's, the normal form's:
/// it works on the time-scaled first-order form (ToStateSpace) and takes the number of zeros
/// from the structure at infinity, while QZ works on the unscaled pencil and counts as finite
/// the eigenvalues whose beta clears a threshold, so QZ is the one that fails on badly scaled
/// models (measured on the mass on car at masses, stiffnesses and dampings from 1e-300 to
/// 1e308: the normal form matched the closed form at 363 of 405 regular points, QZ at 66, and
/// QZ did not converge at 110). A sweep, which runs no QZ, decides as analyze does.
struct ZeroDynamicsCrossCheck {
  std::vector<std::complex<double>> invariant_zeros;  // empty when QZ failed
  // EigenvalueDistance to ZeroDynamics::eigenvalues; infinity when QZ failed.
  double max_difference = 0.0;
  bool agrees = false;  // max_difference <= ClassificationOptions::cross_check_tolerance
  // When !agrees, one line for the reports: what went wrong and that the zero dynamics shown
  // are the normal form's. Empty when the routes agree.
  std::string note;
};

struct Classification {
  OperatingPoint operating_point;
  Linearization linearization;
  DecouplingAnalysis decoupling;
  OutputStructure structure;
  ZeroDynamics zero_dynamics;
  std::optional<ZeroDynamicsCrossCheck> cross_check;  // when options.cross_check
  bool flat = false;                                  // no internal dynamics remain
  SolverMethod recommended_solver = SolverMethod::kAuto;
  // The ClassificationOptions::rank_tolerance this was decided with: the solvers' symbolic
  // inverses decide their relative degrees with the same, so that the two never disagree.
  double rank_tolerance = ClassificationOptions{}.rank_tolerance;
  // The structure algorithm on the nonlinear model (symbolic, so not part of Classify(): a
  // sweep does not pay for it); `analyze` fills it in.
  std::optional<NonlinearStructureSummary> nonlinear_structure;
};

/// Classifies the model at its operating point. Throws UsageError for bad options and
/// NoSolution when there is no equilibrium or no well-posed servo-constraint problem there. With
/// options.cross_check, a QZ route that fails or disagrees does not throw: cross_check records
/// it, with a note, and the verdict is the normal form's (ZeroDynamicsCrossCheck).
Classification Classify(const Model& model,
                        Workspace& workspace,
                        const ClassificationOptions& options = {});

/// Runs the structure algorithm on the nonlinear model (SummarizeNonlinearStructure) at the
/// classification's operating point, with its rank tolerance, and keeps the summary in
/// classification.nonlinear_structure: what `analyze` reports beyond Classify().
void DeriveNonlinearStructure(const Model& model, Classification& classification);

/// The solver that fits a class (paper Sect. 5): flat -> algebraic inversion; unstable zero
/// dynamics -> stable inversion; undamped (critical) -> the normal form with Dormand-Prince,
/// which adds no numerical damping (also for "undetermined", which may be critical);
/// asymptotically stable -> BDF when the projected DAE has
/// index 1, the input-output normal form of any vector relative degree otherwise. (The
/// solvers fall back to the next method that fits when this one does not: see
/// solvers/method_choice.h.)
SolverMethod RecommendSolver(bool flat, Stability stability, int projected_index);

}  // namespace servokit
