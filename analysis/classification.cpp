#include "analysis/classification.h"

#include <cassert>
#include <limits>
#include <sstream>
#include <string>

#include "base/errors.h"
#include "base/number_format.h"

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

namespace {

// ZeroDynamicsCrossCheck::note of a check that does not agree: what QZ did, and which route
// the verdict is.
std::string CrossCheckNote(const ZeroDynamicsCrossCheck& check,
                           const ZeroDynamics& zero_dynamics,
                           const std::string& failure,
                           const ClassificationOptions& options) {
  std::ostringstream note;
  if (!failure.empty()) {
    note << failure;
  } else if (check.invariant_zeros.size() != zero_dynamics.eigenvalues.size()) {
    note << "QZ counts " << check.invariant_zeros.size()
         << " finite invariant zeros where the orders of the infinite zeros give "
         << zero_dynamics.eigenvalues.size();
  } else {
    note << "the invariant zeros by QZ differ from the normal form's by more than "
            "cross_check_tolerance = "
         << options.cross_check_tolerance;
  }
  note << "; the zero dynamics and stability shown are the normal form's, the more reliable "
          "route (time-scaled first-order form, number of zeros from the orders of the "
          "infinite zeros; QZ works on the unscaled pencil)";
  return note.str();
}

// The QZ route against the normal form (ZeroDynamicsCrossCheck). A failure of QZ is the
// cross-check's, not the analysis's: it is recorded, and the verdict stays the normal form's.
ZeroDynamicsCrossCheck CrossCheckZeroDynamics(const Linearization& linearization,
                                              const ZeroDynamics& zero_dynamics,
                                              const ClassificationOptions& options) {
  ZeroDynamicsCrossCheck check;
  std::string failure;
  try {
    check.invariant_zeros = InvariantZeros(linearization, options);
    check.max_difference = EigenvalueDistance(check.invariant_zeros, zero_dynamics.eigenvalues);
  } catch (const NoSolution& error) {
    failure = error.what();
    check.invariant_zeros.clear();
    check.max_difference = std::numeric_limits<double>::infinity();
  }
  check.agrees = check.max_difference <= options.cross_check_tolerance;
  if (!check.agrees) check.note = CrossCheckNote(check, zero_dynamics, failure, options);
  return check;
}

}  // namespace

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
  if (const std::optional<Eigen::VectorXd>& curve = result.operating_point.curve_direction) {
    std::string& note = result.zero_dynamics.stability_note;
    note =
        "the equilibrium is not isolated: a curve of equilibria passes through the operating "
        "point along dq = " +
        FormatList(*curve, 6) +
        ", classified at the point named (--q0); the motion along it is a zero at 0" +
        (note.empty() ? "" : "; " + note);
  }
  if (options.cross_check) {
    result.cross_check =
        CrossCheckZeroDynamics(result.linearization, result.zero_dynamics, options);
  }
  result.flat = result.structure.internal_dynamics_order == 0;
  result.recommended_solver = RecommendSolver(result.flat, result.zero_dynamics.stability,
                                              result.structure.projected_index);
  result.rank_tolerance = options.rank_tolerance;
  return result;
}

namespace {

// Where the relative degree is not defined at the operating point, no exact inverse passes
// through it and solve's auto refuses, pointing to the linearization's inverse: the
// recommendation is what solve does (issue #33).
void RecommendForStructure(Classification& classification) {
  const std::optional<NonlinearStructureSummary>& structure = classification.nonlinear_structure;
  if (structure && structure->derived && !structure->defined_at_operating_point) {
    classification.recommended_solver = SolverMethod::kLinearized;
  }
}

}  // namespace

void DeriveNonlinearStructure(const Model& model, Classification& classification) {
  NonlinearStructureOptions options;
  options.rank_tolerance = classification.rank_tolerance;
  options.reference_q = classification.operating_point.q;
  if (model.num_constraints() == 0) {
    classification.nonlinear_structure = SummarizeNonlinearStructure(model, options);
    RecommendForStructure(classification);
    return;
  }
  // A closed chain's structure along motions on c(q) = 0 is that of its loops held as servo
  // constraints, their multipliers as inputs: the DAE the solvers invert.
  NonlinearStructureSummary summary =
      SummarizeNonlinearStructure(LoopsAsServoConstraints(model), options);
  const std::string loops =
      "closed kinematic chain: derived with its " + std::to_string(model.num_constraints()) +
      " loop constraints held as servo constraints c(q) = 0 (their multipliers lambda as "
      "inputs), so the relative degrees are the outputs' and then the constraints'";
  summary.note = summary.note.empty() ? loops : loops + "; " + summary.note;
  classification.nonlinear_structure = std::move(summary);
  RecommendForStructure(classification);
}

}  // namespace servokit
