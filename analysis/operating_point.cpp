#include "analysis/operating_point.h"

#include <kinsol/kinsol.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <cassert>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "base/number_format.h"
#include "base/option_check.h"
#include "numerics/finite.h"
#include "numerics/sundials_support.h"

namespace servokit {
namespace {

// The equilibrium equations F(q, u, lambda) = [f(q,0) - B(q) u - C(q)^T lambda ; h(q) - y0 ;
// c(q)] = 0 and their Jacobian; without constraints, F(q, u) = [f(q,0) - B(q) u ; h(q) - y0].
struct EquilibriumProblem {
  const Model& model;
  Workspace& workspace;
  Eigen::VectorXd y0;
  Eigen::VectorXd zero_velocity;
  // Scratch, so that the residual and the Jacobian allocate nothing: B u and dB/dq_k u.
  Eigen::VectorXd input_force;
  Eigen::VectorXd input_force_change;
  // q of the last residual evaluated, if that residual was NaN or Inf (a finite one clears it:
  // KINSOL backtracked out of the overflow). When KINSOL gives up there, this is the reason to
  // report; its own flag for it is one SUNDIALS cannot name.
  std::optional<Eigen::VectorXd> non_finite_at;

  Eigen::Index dof() const { return static_cast<Eigen::Index>(model.dof()); }
  Eigen::Index inputs() const { return static_cast<Eigen::Index>(model.num_inputs()); }
  Eigen::Index loops() const { return static_cast<Eigen::Index>(model.num_constraints()); }
  Eigen::Index size() const { return dof() + inputs() + loops(); }
  // The unknowns are [q, u, lambda], the residuals [forces, outputs, constraints].

  void Residual(const Eigen::VectorXd& unknowns, Eigen::Ref<Eigen::VectorXd> residual) {
    const auto q = unknowns.head(dof());
    unsigned quantities = Quantity::kForces | Quantity::kInputMatrix | Quantity::kOutput;
    if (loops() > 0)
      quantities = quantities | Quantity::kConstraints | Quantity::kConstraintJacobian;
    Evaluate(model, workspace, q, zero_velocity, quantities);
    ResidualFromWorkspace(unknowns.tail(inputs() + loops()), residual);
  }

  // The residual from f, B and h (and c and C) already evaluated at q (and velocity 0);
  // `forces_unknowns` is [u, lambda].
  void ResidualFromWorkspace(const Eigen::Ref<const Eigen::VectorXd>& forces_unknowns,
                             Eigen::Ref<Eigen::VectorXd> residual) {
    input_force.noalias() = workspace.input_matrix * forces_unknowns.head(inputs());
    residual.head(dof()) = workspace.forces - input_force;
    if (loops() > 0) {
      residual.head(dof()).noalias() -=
          workspace.constraint_jacobian.transpose() * forces_unknowns.tail(loops());
      residual.tail(loops()) = workspace.constraints;
    }
    residual.segment(dof(), inputs()) = workspace.output - y0;
  }

  void Jacobian(const Eigen::VectorXd& unknowns, Eigen::Ref<Eigen::MatrixXd> jacobian) {
    const auto q = unknowns.head(dof());
    const auto u = unknowns.segment(dof(), inputs());
    unsigned quantities = Quantity::kForcesJacobians | Quantity::kInputMatrix |
                          Quantity::kInputMatrixDerivatives | Quantity::kOutputJacobian;
    if (loops() > 0) {
      quantities =
          quantities | Quantity::kConstraintJacobian | Quantity::kConstraintJacobianDerivatives;
    }
    Evaluate(model, workspace, q, zero_velocity, quantities);
    jacobian.setZero();
    EquilibriumStiffness(workspace, u, jacobian.topLeftCorner(dof(), dof()), input_force_change);
    jacobian.block(0, dof(), dof(), inputs()) = -workspace.input_matrix;
    jacobian.block(dof(), 0, inputs(), dof()) = workspace.output_jacobian;
    if (loops() > 0) {
      SubtractConstraintStiffness(workspace, unknowns.tail(loops()),
                                  jacobian.topLeftCorner(dof(), dof()));
      jacobian.topRightCorner(dof(), loops()) = -workspace.constraint_jacobian.transpose();
      jacobian.bottomLeftCorner(loops(), dof()) = workspace.constraint_jacobian;
    }
  }
};

int KinsolResidual(N_Vector unknowns, N_Vector residual, void* user_data) {
  auto& problem = *static_cast<EquilibriumProblem*>(user_data);
  problem.Residual(AsEigen(unknowns), AsEigen(residual));
  if (AllFinite(AsEigen(residual))) {
    problem.non_finite_at.reset();
    return 0;
  }
  problem.non_finite_at = AsEigen(unknowns).head(problem.dof());
  return 1;  // positive: recoverable, KINSOL backtracks
}

int KinsolJacobian(
    N_Vector unknowns, N_Vector, SUNMatrix jacobian, void* user_data, N_Vector, N_Vector) {
  auto& problem = *static_cast<EquilibriumProblem*>(user_data);
  const Eigen::Index size = static_cast<Eigen::Index>(SUNDenseMatrix_Rows(jacobian));
  Eigen::Map<Eigen::MatrixXd> view(SUNDenseMatrix_Data(jacobian), size, size);  // column-major
  problem.Jacobian(AsEigen(unknowns), view);
  return AllFinite(view) ? 0 : -1;
}

// KINSOL prints its errors to stderr by default; keep the last one for our message instead.
void KeepKinsolMessage(int, const char*, const char*, char* message, void* last_message) {
  *static_cast<std::string*>(last_message) = message;
}

// A scaled residual (units of q) still above this where Newton gave up is far from any
// equilibrium: a hint that there may be none.
constexpr double kStalledResidual = 1e-3;
// Digits of q and y0 in messages.
constexpr int kVectorDigits = 6;
// A loop counts as open at Newton's last iterate when |c_i| exceeds this relative to 1 + |q|:
// far above what Newton leaves of a closed one, far below an open joint.
constexpr double kOpenLoopTolerance = 1e-8;

// C = dc/dq of full row rank at q: else the first constraint that depends on those before it
// (redundant, or the loop at a singular configuration) is named. Rows are compared after scaling
// each to unit length, so that units do not decide.
// What a user can change when Newton finds no equilibrium.
constexpr std::string_view kStartAdvice =
    "give a starting point near the equilibrium (--q0, or q0: in the model file)";

// A closed chain whose loops Newton could not close: the constraint furthest from c = 0 at its
// last iterate, named (empty when every loop closed there, or for an open chain).
std::string OpenLoopNote(EquilibriumProblem& problem, const Eigen::VectorXd& unknowns) {
  if (problem.loops() == 0 || !AllFinite(unknowns)) return "";
  const Eigen::VectorXd q = unknowns.head(problem.dof());
  Evaluate(problem.model, problem.workspace, q, problem.zero_velocity,
           static_cast<unsigned>(Quantity::kConstraints));
  Eigen::Index worst = 0;
  const double gap = problem.workspace.constraints.cwiseAbs().maxCoeff(&worst);
  if (!(gap > kOpenLoopTolerance * (1.0 + q.lpNorm<Eigen::Infinity>()))) return "";
  return "; its loops stay open: " + problem.model.constraint_names()[std::size_t(worst)] + " = " +
         FormatSignificant(problem.workspace.constraints(worst), kVectorDigits) +
         " at q = " + FormatList(q, kVectorDigits);
}

void CheckConstraintRank(const Model& model,
                         const Eigen::MatrixXd& constraint_jacobian,
                         const Eigen::VectorXd& q) {
  constexpr double kRankTolerance = 1e-10;
  // One SVD of the rows scaled to unit size decides; only a deficient C (an error) is searched
  // row by row for the first dependent constraint, to name it. Sweeps take this at every point.
  Eigen::MatrixXd scaled = constraint_jacobian;
  bool zero_row = false;
  for (Eigen::Index i = 0; i < scaled.rows(); ++i) {
    const double norm = scaled.row(i).norm();
    zero_row = zero_row || norm == 0.0;
    if (norm > 0.0) scaled.row(i) /= norm;
  }
  if (!zero_row) {
    const Eigen::JacobiSVD<Eigen::MatrixXd> whole(scaled);
    const Eigen::VectorXd& singular = whole.singularValues();
    if (singular(singular.size() - 1) > kRankTolerance * singular(0)) return;
  }
  Eigen::MatrixXd rows(0, constraint_jacobian.cols());
  for (Eigen::Index i = 0; i < constraint_jacobian.rows(); ++i) {
    const double norm = constraint_jacobian.row(i).norm();
    Eigen::MatrixXd next(rows.rows() + 1, rows.cols());
    next << rows, constraint_jacobian.row(i) / (norm > 0.0 ? norm : 1.0);
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(next);
    const Eigen::VectorXd& singular = svd.singularValues();
    if (norm == 0.0 || singular(singular.size() - 1) <= kRankTolerance * singular(0)) {
      throw NoSolution(model.constraint_names()[std::size_t(i)] +
                       ": C = dc/dq is rank-deficient at q = " + FormatList(q, kVectorDigits) +
                       ": the constraint depends on the ones before it there (redundant, or the "
                       "loop is at a singular configuration)");
    }
    rows = std::move(next);
  }
}

// The rule of an options vector with one value per output or coordinate.
std::string ValueCount(std::size_t count, const std::string& per) {
  return "must have " + std::to_string(count) + (count == 1 ? " value" : " values") + ", one per " +
         per;
}

// Scales each residual by the inverse of its Jacobian row's largest entry, so that a force
// residual and an output residual are compared in units of q (documented in the options).
Eigen::VectorXd ResidualScaling(const Eigen::MatrixXd& jacobian) {
  Eigen::VectorXd scaling(jacobian.rows());
  for (Eigen::Index i = 0; i < jacobian.rows(); ++i) {
    const double row_size = jacobian.row(i).cwiseAbs().maxCoeff();
    scaling(i) = row_size > 0.0 ? 1.0 / row_size : 1.0;
  }
  return scaling;
}

// The Jacobian with its rows and then its columns scaled to a largest entry of 1, so that an
// invertibility test compares each pivot with its own row's and column's size, not with the
// largest entry of the whole matrix (which would make a test of isolation depend on units).
// `row_scaling`: ResidualScaling(jacobian).
Eigen::MatrixXd EquilibratedJacobian(const Eigen::MatrixXd& jacobian,
                                     const Eigen::VectorXd& row_scaling) {
  Eigen::MatrixXd scaled = row_scaling.asDiagonal() * jacobian;
  for (Eigen::Index j = 0; j < scaled.cols(); ++j) {
    const double column_size = scaled.col(j).cwiseAbs().maxCoeff();
    if (column_size > 0.0) scaled.col(j) /= column_size;
  }
  return scaled;
}

void RunKinsol(EquilibriumProblem& problem,
               Eigen::VectorXd& unknowns,
               const Eigen::VectorXd& scaling,
               const OperatingPointOptions& options,
               int& iterations) {
  const Eigen::Index size = unknowns.size();
  SundialsContext context;
  NVectorPtr solution = MakeSerialVector(size, context);
  NVectorPtr unknown_scale = MakeSerialVector(size, context);
  NVectorPtr residual_scale = MakeSerialVector(size, context);
  AsEigen(solution.get()) = unknowns;
  N_VConst(1.0, unknown_scale.get());
  AsEigen(residual_scale.get()) = scaling;
  SUNMatrixPtr matrix(
      SUNDenseMatrix(static_cast<sunindextype>(size), static_cast<sunindextype>(size), context));
  CheckSundialsPointer(matrix.get(), "SUNDenseMatrix");
  SUNLinearSolverPtr linear_solver(SUNLinSol_Dense(solution.get(), matrix.get(), context));
  CheckSundialsPointer(linear_solver.get(), "SUNLinSol_Dense");

  std::unique_ptr<void, void (*)(void*)> memory(KINCreate(context),
                                                [](void* kinsol) { KINFree(&kinsol); });
  CheckSundialsPointer(memory.get(), "KINCreate");
  std::string last_message;
  void* kinsol = memory.get();
  const SundialsFlagNamer namer = KINGetReturnFlagName;
  CheckSundialsCall(namer, KINSetErrHandlerFn(kinsol, KeepKinsolMessage, &last_message),
                    "KINSetErrHandlerFn");
  CheckSundialsCall(namer, KINInit(kinsol, KinsolResidual, solution.get()), "KINInit");
  CheckSundialsCall(namer, KINSetUserData(kinsol, &problem), "KINSetUserData");
  CheckSundialsCall(namer, KINSetLinearSolver(kinsol, linear_solver.get(), matrix.get()),
                    "KINSetLinearSolver");
  CheckSundialsCall(namer, KINSetJacFn(kinsol, KinsolJacobian), "KINSetJacFn");
  // A fresh Jacobian every iteration: exact Newton, since these systems are tiny.
  CheckSundialsCall(namer, KINSetMaxSetupCalls(kinsol, 1), "KINSetMaxSetupCalls");
  CheckSundialsCall(namer, KINSetFuncNormTol(kinsol, options.residual_tolerance),
                    "KINSetFuncNormTol");
  // Let the residual test decide convergence, not a small step.
  CheckSundialsCall(namer, KINSetScaledStepTol(kinsol, 0.0), "KINSetScaledStepTol");

  // KINSOL caps a Newton step at 1000 |u| of the point it starts from, but at no less than 1
  // (so at 1 from u = 0; KINSolInit sets the cap on every KINSol call): a guard against
  // leaping into another branch of a nonlinear model. A target farther away than five such
  // steps (y0 = 10 for the mass on the car, from q = 0) ends in KIN_MXNEWT_5X_EXCEEDED. Then
  // we go on from where it stopped, with the cap taken afresh from that point, so a far target
  // is reached in a few rounds, while whatever one round solves is solved exactly as before.
  int flag = KIN_MXNEWT_5X_EXCEEDED;
  iterations = 0;
  while (flag == KIN_MXNEWT_5X_EXCEEDED && iterations < options.max_iterations) {
    CheckSundialsCall(namer, KINSetNumMaxIters(kinsol, options.max_iterations - iterations),
                      "KINSetNumMaxIters");
    flag =
        KINSol(kinsol, solution.get(), KIN_LINESEARCH, unknown_scale.get(), residual_scale.get());
    long int newton_iterations = 0;
    KINGetNumNonlinSolvIters(kinsol, &newton_iterations);
    iterations += static_cast<int>(newton_iterations);
    if (!AllFinite(AsEigen(solution.get()))) break;
  }
  if (flag < 0 && problem.non_finite_at) {
    // A step so large that q itself overflowed says nothing by its value: name the overflow.
    const std::string where = AllFinite(*problem.non_finite_at)
                                  ? "at q = " + FormatList(*problem.non_finite_at, kVectorDigits)
                                  : "after a Newton step overflowed q";
    throw NoSolution("no equilibrium found for y0 = " + FormatList(problem.y0, kVectorDigits) +
                     ": the equilibrium equations became NaN or Inf " + where +
                     " (is y0 within the model's range?); " + std::string(kStartAdvice));
  }
  if (flag < 0) {
    // How far from an equilibrium Newton got: a residual that stays of order one (in units of
    // q, see ResidualScaling) says that there may be none to find, not only a poor start.
    double residual_norm = std::numeric_limits<double>::quiet_NaN();
    KINGetFuncNorm(kinsol, &residual_norm);
    const std::string stalled =
        std::isfinite(residual_norm) && residual_norm > kStalledResidual
            ? "; the scaled residual stayed at " + FormatSignificant(residual_norm, 3) +
                  ": there may be no equilibrium holding y0 (an output out of the model's "
                  "reach at rest), or none near the start"
            : "";
    throw NoSolution("no equilibrium found for y0 = " + FormatList(problem.y0, kVectorDigits) +
                     ": Newton (KINSOL) stopped with " + SundialsFlagName(namer, flag) +
                     (last_message.empty() ? "" : " (" + last_message + ")") +
                     OpenLoopNote(problem, AsEigen(solution.get())) + stalled + "; " +
                     std::string(kStartAdvice));
  }
  unknowns = AsEigen(solution.get());
}

}  // namespace

void OperatingPointOptions::Validate(const Model& model) const {
  constexpr const char* kOwner = "OperatingPointOptions";
  if (y0) {
    RequireOption(static_cast<std::size_t>(y0->size()) == model.num_outputs(), kOwner, "y0", *y0,
                  ValueCount(model.num_outputs(), "output"));
    RequireOption(AllFinite(*y0), kOwner, "y0", *y0, "must be finite");
  }
  if (q_guess) {
    RequireOption(static_cast<std::size_t>(q_guess->size()) == model.dof(), kOwner, "q_guess",
                  *q_guess, ValueCount(model.dof(), "coordinate"));
    RequireOption(AllFinite(*q_guess), kOwner, "q_guess", *q_guess, "must be finite");
  }
  RequireOption(residual_tolerance > 0.0, kOwner, "residual_tolerance", residual_tolerance,
                "must be > 0");
  RequireOption(max_iterations >= 1, kOwner, "max_iterations", max_iterations, "must be >= 1");
}

std::string DescribeParameters(const Model& model, const Workspace& workspace) {
  std::ostringstream text;
  text.precision(6);
  text << "parameters";
  const std::vector<std::string>& names = model.parameter_names();
  for (std::size_t i = 0; i < names.size(); ++i) {
    text << (i == 0 ? " " : ", ") << names[i] << " = "
         << workspace.parameters(static_cast<Eigen::Index>(i));
  }
  return text.str();
}

void SubtractConstraintStiffness(const Workspace& workspace,
                                 const Eigen::Ref<const Eigen::VectorXd>& multipliers,
                                 Eigen::Ref<Eigen::MatrixXd> stiffness) {
  // Column b of d(C^T lambda)/dq is (dC/dq_b)^T lambda.
  for (Eigen::Index b = 0; b < stiffness.cols(); ++b) {
    stiffness.col(b).noalias() -=
        workspace.constraint_jacobian_derivatives[std::size_t(b)].transpose() * multipliers;
  }
}

void EquilibriumStiffness(const Workspace& workspace,
                          const Eigen::Ref<const Eigen::VectorXd>& u,
                          Eigen::Ref<Eigen::MatrixXd> stiffness,
                          Eigen::VectorXd& input_force_change) {
  stiffness = workspace.forces_position_jacobian;
  input_force_change.resize(stiffness.rows());
  for (Eigen::Index k = 0; k < stiffness.cols(); ++k) {
    input_force_change.noalias() = workspace.input_matrix_derivatives[std::size_t(k)] * u;
    stiffness.col(k) -= input_force_change;
  }
}

OperatingPoint FindOperatingPoint(const Model& model,
                                  Workspace& workspace,
                                  const OperatingPointOptions& options) {
  assert(workspace.Fits(model));
  options.Validate(model);
  const auto dof = static_cast<Eigen::Index>(model.dof());
  const auto inputs = static_cast<Eigen::Index>(model.num_inputs());
  const auto loops = static_cast<Eigen::Index>(model.num_constraints());
  EquilibriumProblem problem{model,
                             workspace,
                             Eigen::VectorXd(),
                             Eigen::VectorXd::Zero(dof),
                             Eigen::VectorXd(dof),
                             Eigen::VectorXd(dof),
                             std::nullopt};
  const Eigen::VectorXd& zero = problem.zero_velocity;
  // Start from q_guess and the inputs that best balance the forces there. f, B and h at the
  // start are evaluated at once; without q_guess the start is the model's (its file's q0, else
  // q = 0), where h gives y0.
  const Eigen::VectorXd model_start =
      model.operating_point_start().size() > 0 ? model.operating_point_start() : zero;
  Eigen::VectorXd unknowns(problem.size());
  unknowns.head(dof) = options.q_guess.value_or(model_start);
  if (!options.y0 && options.q_guess) {
    Evaluate(model, workspace, model_start, zero, static_cast<unsigned>(Quantity::kOutput));
    problem.y0 = workspace.output;
  }
  unsigned start_quantities = Quantity::kForces | Quantity::kInputMatrix | Quantity::kOutput;
  if (loops > 0) {
    start_quantities = start_quantities | Quantity::kConstraints | Quantity::kConstraintJacobian;
  }
  Evaluate(model, workspace, unknowns.head(dof), zero, start_quantities);
  if (options.y0) {
    problem.y0 = *options.y0;
  } else if (!options.q_guess) {
    problem.y0 = workspace.output;
  }
  if (!options.y0 && !AllFinite(problem.y0)) {
    throw NoSolution(std::string("the output h(") +
                     (model.operating_point_start().size() > 0 ? "q0" : "0") +
                     ") is not finite: give y0, the output to hold");
  }
  // Least squares [u; lambda] for [B, C^T] [u; lambda] = f; [B, C^T] has full column rank in
  // any sensible model, and the complete orthogonal decomposition handles one that has not.
  Eigen::MatrixXd force_directions(dof, inputs + loops);
  force_directions << workspace.input_matrix, workspace.constraint_jacobian.transpose();
  const Eigen::LLT<Eigen::MatrixXd> normal(force_directions.transpose() * force_directions);
  unknowns.tail(inputs + loops) =
      normal.info() == Eigen::Success
          ? Eigen::VectorXd(normal.solve(force_directions.transpose() * workspace.forces))
          : Eigen::VectorXd(
                force_directions.completeOrthogonalDecomposition().solve(workspace.forces));

  Eigen::MatrixXd jacobian(problem.size(), problem.size());
  problem.Jacobian(unknowns, jacobian);
  if (!AllFinite(jacobian)) {
    std::string quantities;
    for (const auto& [name, finite] :
         {std::pair{"df/dq", AllFinite(workspace.forces_position_jacobian)},
          std::pair{"B", AllFinite(workspace.input_matrix)},
          std::pair{"H = dh/dq", AllFinite(workspace.output_jacobian)},
          std::pair{"C = dc/dq", AllFinite(workspace.constraint_jacobian)}}) {
      if (!finite) quantities += (quantities.empty() ? "" : ", ") + std::string(name);
    }
    throw NoSolution(
        "the model is not finite at q0 = " + FormatList(unknowns.head(dof), kVectorDigits) +
        ": NaN or Inf in " + (quantities.empty() ? "the forces" : quantities) + " (" +
        DescribeParameters(model, workspace) + ")");
  }
  Eigen::VectorXd scaling = ResidualScaling(jacobian);
  Eigen::VectorXd residual(problem.size());
  // f, h and c at the start are in the workspace, and B and C (evaluated again by the Jacobian
  // at the same q) are unchanged: the residual needs no evaluation.
  problem.ResidualFromWorkspace(unknowns.tail(inputs + loops), residual);

  OperatingPoint point;
  // Most operating points are the starting point itself (q = 0 and y0 = h(0)); then Newton
  // has nothing to do, which keeps sweeps fast.
  if (!AllFinite(residual) ||
      residual.cwiseProduct(scaling).lpNorm<Eigen::Infinity>() > options.residual_tolerance) {
    RunKinsol(problem, unknowns, scaling, options, point.newton_iterations);
    problem.Residual(unknowns, residual);
    if (!AllFinite(unknowns) || !AllFinite(residual)) {
      throw NoSolution("no equilibrium found for y0 = " + FormatList(problem.y0, kVectorDigits) +
                       ": the iteration left the domain where the model is finite");
    }
    problem.Jacobian(unknowns, jacobian);
    scaling = ResidualScaling(jacobian);  // of the Jacobian at the equilibrium found
  }
  // Decided on the equilibrated Jacobian: unscaled, one huge entry (k = 1e308, say) sets
  // FullPivLU's threshold and every other pivot looks like zero.
  if (loops > 0) CheckConstraintRank(model, workspace.constraint_jacobian, unknowns.head(dof));
  const Eigen::FullPivLU<Eigen::MatrixXd>& lu =
      workspace.equilibrium_factor.compute(EquilibratedJacobian(jacobian, scaling));
  if (!lu.isInvertible()) {
    // The Jacobian's null space, in the unknowns' own units (undoing the column scaling), is
    // the curve of equilibria through the point: its q part is the curve's direction.
    Eigen::VectorXd direction = lu.kernel().col(0);
    const Eigen::MatrixXd row_scaled = scaling.asDiagonal() * jacobian;
    for (Eigen::Index j = 0; j < direction.size(); ++j) {
      const double column_size =
          row_scaled.col(j).cwiseAbs().maxCoeff();  // as EquilibratedJacobian
      if (column_size > 0.0) direction(j) /= column_size;
    }
    Eigen::VectorXd curve = direction.head(dof);
    const double curve_size = curve.norm();
    if (!options.q_guess || !(curve_size > 0.0)) {
      throw NoSolution("the equilibrium at q = " + FormatList(unknowns.head(dof), kVectorDigits) +
                       " is not isolated: the Jacobian of f(q,0) - B(q) u" +
                       std::string(loops > 0 ? " - C(q)^T lambda = 0, c(q) = 0" : " = 0") +
                       ", h(q) = y0 is singular (a free coordinate the output does not fix?)" +
                       (curve_size > 0.0 ? "; a curve of equilibria passes through it along dq = " +
                                               FormatList(curve / curve_size, kVectorDigits) +
                                               ": name a point on it with --q0 to classify there"
                                         : ""));
    }
    point.curve_direction = curve / curve_size;
  }
  point.q = unknowns.head(dof);
  point.u = unknowns.segment(dof, inputs);
  point.multipliers = unknowns.tail(loops);
  // h(q) at these very unknowns: the last residual evaluated it, and the Jacobian after it
  // evaluates no output (Evaluate writes only the quantities asked for).
  point.y = workspace.output;
  return point;
}

OperatingPoint FindRestPoint(const Model& model,
                             const Eigen::VectorXd& y0,
                             const Eigen::VectorXd& q_guess) {
  Workspace workspace(model);
  OperatingPointOptions options;
  options.y0 = y0;
  options.q_guess = q_guess;
  return FindOperatingPoint(model, workspace, options);
}

}  // namespace servokit
