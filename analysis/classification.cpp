#include "analysis/classification.h"

#include <cassert>

namespace servokit {

SolverMethod RecommendSolver(bool flat, Stability stability, int projected_index) {
  if (flat) return SolverMethod::kAlgebraic;
  switch (stability) {
    case Stability::kUnstable:
      return SolverMethod::kStableInversion;
    case Stability::kCritical:
    case Stability::kUndetermined:  // may be critical: no method that needs a hyperbolic split
      return SolverMethod::kNormalForm;
    case Stability::kAsymptoticallyStable:
    case Stability::kNone:
      break;
  }
  // P regular (projected index 1): BDF on the projected DAE; otherwise the input-output
  // normal form of any vector relative degree, whose input is exact up to the tolerance
  // (Radau IIA resolves the index-3 input only to O(h^2)).
  return projected_index <= 1 ? SolverMethod::kBdf : SolverMethod::kNormalForm;
}

Classification Classify(const Model& model,
                        Workspace& workspace,
                        const ClassificationOptions& options) {
  assert(workspace.Fits(model));
  options.Validate(model);
  Classification result;
  result.operating_point = FindOperatingPoint(model, workspace, options.operating_point);
  // FindOperatingPoint leaves the Jacobians at the point in the workspace.
  result.linearization =
      Linearize(model, workspace, result.operating_point, /*workspace_holds_jacobians=*/true);
  result.decoupling = AnalyzeDecouplingMatrix(result.linearization, options);
  result.structure = AnalyzeOutputStructure(result.linearization, options);
  result.zero_dynamics = ComputeZeroDynamics(result.structure, options);
  if (options.cross_check) {
    ZeroDynamicsCrossCheck check;
    check.invariant_zeros = InvariantZeros(result.linearization, options);
    check.max_difference =
        EigenvalueDistance(check.invariant_zeros, result.zero_dynamics.eigenvalues);
    check.agrees = check.max_difference <= options.cross_check_tolerance;
    result.cross_check = std::move(check);
  }
  result.flat = result.structure.internal_dynamics_order == 0;
  result.recommended_solver = RecommendSolver(result.flat, result.zero_dynamics.stability,
                                              result.structure.projected_index);
  result.rank_tolerance = options.rank_tolerance;
  return result;
}

void DeriveNonlinearStructure(const Model& model, Classification& classification) {
  NonlinearStructureOptions options;
  options.rank_tolerance = classification.rank_tolerance;
  options.reference_q = classification.operating_point.q;
  classification.nonlinear_structure = SummarizeNonlinearStructure(model, options);
}

}  // namespace servokit
