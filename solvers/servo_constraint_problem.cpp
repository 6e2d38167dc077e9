#include "solvers/servo_constraint_problem.h"

#include <cassert>
#include <cmath>
#include <string>

#include "analysis/decoupling_matrix.h"
#include "base/errors.h"
#include "base/option_check.h"
#include "modeling/symbolic_lock.h"
#include "modeling/symbolic_model.h"

namespace servokit {
namespace {

// Solves M x = b for every column b of `columns`, in place, with M = L L^T from `factor`, by
// plain substitution. Eigen's solveInPlace on a matrix right-hand side goes through its blocked
// triangular-matrix kernel, whose setup costs more than the arithmetic at the few coordinates
// of a multibody model (measured: a quarter of the normal form's right-hand side).
void SolveColumnsWithFactor(const Eigen::LLT<Eigen::MatrixXd>& factor, Eigen::MatrixXd& columns) {
  const Eigen::MatrixXd& lower = factor.matrixLLT();  // L in the lower triangle
  const Eigen::Index n = lower.rows();
  for (Eigen::Index c = 0; c < columns.cols(); ++c) {
    double* x = columns.col(c).data();
    for (Eigen::Index i = 0; i < n; ++i) {  // L y = b
      double sum = x[i];
      for (Eigen::Index k = 0; k < i; ++k) sum -= lower(i, k) * x[k];
      x[i] = sum / lower(i, i);
    }
    for (Eigen::Index i = n - 1; i >= 0; --i) {  // L^T x = y
      double sum = x[i];
      for (Eigen::Index k = i + 1; k < n; ++k) sum -= lower(k, i) * x[k];
      x[i] = sum / lower(i, i);
    }
  }
}

constexpr unsigned kDynamics = Quantity::kMassMatrix | Quantity::kForces | Quantity::kInputMatrix |
                               Quantity::kOutput | Quantity::kOutputJacobian |
                               Quantity::kOutputBias;
constexpr unsigned kOutputGeometry = Quantity::kOutput | Quantity::kOutputJacobian;

// [H; C^T] counts as invertible for choosing C = q_u when its reciprocal condition number is
// above this; below it, the unactuated coordinates are a poor chart of the constraint manifold
// (H_a nearly singular, paper Sect. 2.4) and the tangent basis D_0 is used instead.
constexpr double kMinChartReciprocalCondition = 1e-8;
// Along the motion the chart is re-checked by its LU pivots only, which come free with the
// factorisation: their spread bounds the condition number from below and may understate it by
// orders of magnitude, so the check refuses only what is singular to round-off (1e-12), four
// orders below the choice at the start, lest a chart chosen well there be refused on the way.
constexpr double kMinChartPivotRatio = 1e-4 * kMinChartReciprocalCondition;

}  // namespace

void ServoProblemOptions::Validate() const {
  constexpr const char* kOwner = "ServoProblemOptions";
  for (const auto& [value, field] :
       {std::pair{min_mass_reciprocal_condition, "min_mass_reciprocal_condition"},
        std::pair{rank_tolerance, "rank_tolerance"},
        std::pair{coordinate_tolerance, "coordinate_tolerance"}}) {
    RequireOption(value > 0.0 && std::isfinite(value), kOwner, field, value,
                  "must be a finite number > 0");
  }
  RequireOption(max_coordinate_iterations >= 1, kOwner, "max_coordinate_iterations",
                max_coordinate_iterations, "must be >= 1");
}

ServoConstraintProblem::ServoConstraintProblem(const Model& model,
                                               const OutputTrajectory& trajectory,
                                               const Eigen::VectorXd& reference_q,
                                               const ServoProblemOptions& options)
    : model_(model), trajectory_(trajectory), options_(options), workspace_(model) {
  options_.Validate();
  if (trajectory.outputs() != num_outputs()) {
    throw UsageError("the trajectory has " + std::to_string(trajectory.outputs()) +
                     " outputs, the model " + std::to_string(num_outputs()));
  }
  if (reference_q.size() != dof()) {
    throw UsageError("reference q has " + std::to_string(reference_q.size()) +
                     " entries, the model has " + std::to_string(dof()) + " coordinates");
  }
  zero_velocity_ = Eigen::VectorXd::Zero(dof());
  chart_.resize(dof(), dof());
  chart_residual_.resize(dof());
  velocity_targets_.resize(dof());
  Evaluate(model_, workspace_, reference_q, zero_velocity_, kDynamics);
  const Eigen::MatrixXd& output_jacobian = workspace_.output_jacobian;
  reference_tangent_basis_ = TangentBasis(output_jacobian, options_.rank_tolerance);
  if (reference_tangent_basis_.cols() != dof() - num_outputs()) {
    throw NoSolution(
        "the outputs are not independent at the reference point: H = dh/dq has "
        "rank < " +
        std::to_string(num_outputs()));
  }

  // The paper's chart (Eq. 19): z = q_u, the coordinates no input acts on directly.
  const Eigen::MatrixXd& input_matrix = workspace_.input_matrix;
  std::vector<Eigen::Index> unactuated;
  for (Eigen::Index row = 0; row < dof(); ++row) {
    if (input_matrix.row(row).isZero(0.0)) unactuated.push_back(row);
  }
  internal_directions_ = reference_tangent_basis_;
  if (Eigen::Index(unactuated.size()) == dof() - num_outputs()) {
    Eigen::MatrixXd selection = Eigen::MatrixXd::Zero(dof(), Eigen::Index(unactuated.size()));
    for (std::size_t k = 0; k < unactuated.size(); ++k)
      selection(unactuated[k], Eigen::Index(k)) = 1.0;
    Eigen::MatrixXd chart(dof(), dof());
    chart << output_jacobian, selection.transpose();
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(chart);
    const Eigen::VectorXd& singular_values = svd.singularValues();
    if (singular_values(singular_values.size() - 1) >
        kMinChartReciprocalCondition * singular_values(0)) {
      internal_directions_ = selection;
      internal_are_unactuated_ = true;
    }
  }

  const auto independent_of_q = [&](const GiNaC::matrix& matrix) {
    // GiNaC: the model's expressions are shared with other threads (modeling/symbolic_lock.h).
    const SymbolicLock lock;
    for (unsigned row = 0; row < matrix.rows(); ++row) {
      for (unsigned column = 0; column < matrix.cols(); ++column) {
        for (const GiNaC::realsymbol& coordinate : model.symbolic().coordinates()) {
          if (matrix(row, column).has(coordinate)) return false;
        }
      }
    }
    return true;
  };
  output_is_linear_ =
      options_.exploit_constant_structure && independent_of_q(model.symbolic().output_jacobian());
  std::string why;
  if (output_is_linear_ && independent_of_q(model.symbolic().mass_matrix()) &&
      independent_of_q(model.symbolic().input_matrix()) &&
      EvaluateDynamics(reference_q, zero_velocity_, why)) {
    constant_mass_factor_ = mass_factor_;
    constant_input_accelerations_ = mass_factor_.solve(workspace_.input_matrix);
    const Eigen::MatrixXd decoupling =
        DecouplingMatrix(output_jacobian, constant_input_accelerations_);
    const Eigen::FullPivLU<Eigen::MatrixXd> factor(decoupling);
    const double scale = output_jacobian.norm() * constant_input_accelerations_.norm();
    // Only when P is regular; otherwise NormalForm() reports the singular P as usual.
    if (factor.matrixLU().diagonal().cwiseAbs().minCoeff() > options_.rank_tolerance * scale) {
      constant_decoupling_inverse_ = factor.inverse();
      constant_decoupling_determinant_ = factor.determinant();
      constant_geometry_ = true;
    }
  }
  if (output_is_linear_) {
    chart_ << output_jacobian, internal_directions_.transpose();
    constant_chart_inverse_ = chart_.inverse();  // well-conditioned: checked above
    output_offset_ = workspace_.output - output_jacobian * reference_q;  // h_0
    workspace_.output_bias.setZero();  // stays: h_bar = 0, H as evaluated above
  }
}

bool ServoConstraintProblem::EvaluateDynamics(const Eigen::Ref<const Eigen::VectorXd>& q,
                                              const Eigen::Ref<const Eigen::VectorXd>& q_dot,
                                              std::string& why,
                                              bool with_output) {
  // A linear output has a constant H (kept from the constructor) and h_bar = H_dot q_dot = 0.
  unsigned quantities = output_is_linear_
                            ? (kDynamics & ~(Quantity::kOutputJacobian | Quantity::kOutputBias))
                            : kDynamics;
  if (!with_output) quantities &= ~static_cast<unsigned>(Quantity::kOutput);
  Evaluate(model_, workspace_, q, q_dot, quantities);
  if (!workspace_.mass_matrix.allFinite() || !workspace_.forces.allFinite() ||
      !workspace_.input_matrix.allFinite() || !workspace_.output.allFinite() ||
      !workspace_.output_jacobian.allFinite() || !workspace_.output_bias.allFinite()) {
    why = "the model evaluates to NaN or Inf";
    last_failure_ = SolveStatus::kIntegratorFailure;
    return false;
  }
  mass_factor_.compute(workspace_.mass_matrix);
  if (mass_factor_.info() != Eigen::Success) {
    why = "M(q) is not positive definite";
    last_failure_ = SolveStatus::kSingularMass;
    return false;
  }
  // (min L_ii / max L_ii)^2 estimates 1/cond(M) from the factor at no extra cost (Eigen's
  // rcond() runs triangular solves and dominated the normal form's right-hand side).
  const auto diagonal = mass_factor_.matrixLLT().diagonal();
  const double diagonal_ratio = diagonal.minCoeff() / diagonal.maxCoeff();
  const double reciprocal_condition = diagonal_ratio * diagonal_ratio;
  if (reciprocal_condition < options_.min_mass_reciprocal_condition) {
    why =
        "M(q) is singular (reciprocal condition number " + FormatNumber(reciprocal_condition) + ")";
    last_failure_ = SolveStatus::kSingularMass;
    return false;
  }
  return true;
}

bool ServoConstraintProblem::StateFromInternal(double t,
                                               const Eigen::Ref<const Eigen::VectorXd>& z,
                                               const Eigen::Ref<const Eigen::VectorXd>& z_dot,
                                               Eigen::VectorXd& q,
                                               Eigen::VectorXd& q_dot,
                                               std::string& why) {
  last_failure_ = SolveStatus::kConverged;
  // A few Newton steps on a square system whose Jacobian [H; C^T] the model already gives;
  // exact in one step when h is linear. (KINSOL would cost more per call than the whole
  // right-hand side of the normal form, which calls this at every stage.)
  const Eigen::Index m = num_outputs();
  DesiredAt(t);
  if (output_is_linear_) {
    // h(q) = H q + h_0: Eq. (19) is linear, [H; C^T] q = [y_d - h_0; z], solved exactly with
    // the inverse formed at the start.
    chart_residual_.head(m) = desired_.col(0) - output_offset_;
    chart_residual_.tail(num_internal()) = z;
    q.noalias() = constant_chart_inverse_ * chart_residual_;
    velocity_targets_.head(m) = desired_.col(1);
    velocity_targets_.tail(num_internal()) = z_dot;
    q_dot.noalias() = constant_chart_inverse_ * velocity_targets_;
    if (!q.allFinite() || !q_dot.allFinite()) {
      why = "the coordinates became NaN or Inf";
      last_failure_ = SolveStatus::kIntegratorFailure;
      return false;
    }
    return true;
  }
  for (int iteration = 0;; ++iteration) {
    Evaluate(model_, workspace_, q, zero_velocity_, kOutputGeometry);
    chart_.topRows(m) = workspace_.output_jacobian;
    chart_.bottomRows(num_internal()) = internal_directions_.transpose();
    chart_residual_.head(m) = workspace_.output - desired_.col(0);
    chart_residual_.tail(num_internal()).noalias() = internal_directions_.transpose() * q;
    chart_residual_.tail(num_internal()) -= z;
    chart_factor_.compute(chart_);
    // The pivots' spread bounds the condition number from below, at no extra cost.
    const auto pivots = chart_factor_.matrixLU().diagonal().cwiseAbs();
    if (!(pivots.minCoeff() > kMinChartPivotRatio * pivots.maxCoeff())) {
      why = "y and the internal coordinates no longer determine q ([H; C^T] is singular)";
      last_failure_ = SolveStatus::kNoConvergence;
      return false;
    }
    correction_ = chart_factor_.solve(chart_residual_);
    q -= correction_;
    if (!q.allFinite()) {
      why = "the coordinates became NaN or Inf";
      last_failure_ = SolveStatus::kIntegratorFailure;
      return false;
    }
    if (correction_.norm() <= options_.coordinate_tolerance * (1.0 + q.norm())) break;
    if (iteration + 1 >= options_.max_coordinate_iterations) {
      // Near a singular [H; C^T] Newton stalls before the pivot test trips: say how close.
      why =
          "Newton's method for q from y_d and the internal coordinates does not converge "
          "([H; C^T] nearly singular: pivot ratio " +
          FormatNumber(pivots.minCoeff() / pivots.maxCoeff()) + ")";
      last_failure_ = SolveStatus::kNoConvergence;
      return false;
    }
  }
  // Eq. (20) at the converged q; the last factorization was taken one correction earlier, at
  // a q within coordinate_tolerance, so [H; C^T] is factored anew only when h is not linear.
  Evaluate(model_, workspace_, q, zero_velocity_, Quantity::kOutputJacobian);
  chart_.topRows(m) = workspace_.output_jacobian;
  chart_factor_.compute(chart_);
  velocity_targets_ << desired_.col(1), z_dot;
  q_dot = chart_factor_.solve(velocity_targets_);
  return true;
}

bool ServoConstraintProblem::NormalForm(double t,
                                        const Eigen::VectorXd& q,
                                        const Eigen::VectorXd& q_dot,
                                        Eigen::VectorXd& u,
                                        Eigen::VectorXd& q_ddot,
                                        std::string& why) {
  last_failure_ = SolveStatus::kConverged;
  if (constant_geometry_) return ConstantGeometryNormalForm(t, q, q_dot, u, q_ddot, why);
  if (!EvaluateDynamics(q, q_dot, why, /*with_output=*/false)) return false;  // h unused
  DesiredAt(t);
  // M^-1 B and M^-1 f in one in-place solve (Eigen's solve() of a matrix right-hand side
  // goes through a temporary).
  const Eigen::Index m = num_inputs();
  accelerations_of_inputs_and_forces_.resize(dof(), m + 1);
  accelerations_of_inputs_and_forces_.leftCols(m) = workspace_.input_matrix;
  accelerations_of_inputs_and_forces_.col(m) = workspace_.forces;
  SolveColumnsWithFactor(mass_factor_, accelerations_of_inputs_and_forces_);
  const auto input_accelerations = accelerations_of_inputs_and_forces_.leftCols(m);
  const auto force_accelerations = accelerations_of_inputs_and_forces_.col(m);
  const Eigen::MatrixXd& output_jacobian = workspace_.output_jacobian;
  DecouplingMatrix(output_jacobian, input_accelerations, decoupling_);
  const double scale = output_jacobian.norm() * input_accelerations.norm();
  // Eq. (24): u = P^-1 (H M^-1 f - h_bar + y_d'').
  decoupling_rhs_.noalias() = output_jacobian * force_accelerations;
  decoupling_rhs_ += desired_.col(2) - workspace_.output_bias;
  double smallest = 0.0;
  if (m == 1) {
    // One input, the common case: P is a number, and pivoting machinery would cost more than
    // the rest of the right-hand side.
    smallest = std::abs(decoupling_(0, 0));
    u.resize(1);
    u(0) = decoupling_rhs_(0) / decoupling_(0, 0);
    decoupling_determinant_ = decoupling_(0, 0);
  } else {
    // Full pivoting reveals the rank: its smallest pivot is within a small factor of sigma_min.
    decoupling_factor_.compute(decoupling_);
    smallest = decoupling_factor_.matrixLU().diagonal().cwiseAbs().minCoeff();
    u = decoupling_factor_.solve(decoupling_rhs_);
    decoupling_determinant_ = decoupling_factor_.determinant();
  }
  if (!(smallest > options_.rank_tolerance * scale)) {
    why = "P = H M^-1 B is singular (smallest pivot / (|H| |M^-1 B|) = " +
          FormatNumber(smallest / scale) + ")";
    last_failure_ = SolveStatus::kSingularDecoupling;
    return false;
  }
  // Eq. (1) solved for q''; its C^T-part is Eq. (25).
  q_ddot.noalias() = input_accelerations * u;
  q_ddot -= force_accelerations;
  return true;
}

bool ServoConstraintProblem::ConstantGeometryNormalForm(double t,
                                                        const Eigen::VectorXd& q,
                                                        const Eigen::VectorXd& q_dot,
                                                        Eigen::VectorXd& u,
                                                        Eigen::VectorXd& q_ddot,
                                                        std::string& why) {
  Evaluate(model_, workspace_, q, q_dot, Quantity::kForces);
  if (!workspace_.forces.allFinite()) {
    why = "the model evaluates to NaN or Inf";
    return false;
  }
  DesiredAt(t);
  force_accelerations_ = workspace_.forces;
  constant_mass_factor_.solveInPlace(force_accelerations_);  // M^-1 f
  // Eq. (24) with h_bar = 0 (H constant): u = P^-1 (H M^-1 f + y_d'').
  decoupling_rhs_.noalias() = workspace_.output_jacobian * force_accelerations_;
  decoupling_rhs_ += desired_.col(2);
  u.noalias() = constant_decoupling_inverse_ * decoupling_rhs_;
  decoupling_determinant_ = constant_decoupling_determinant_;
  q_ddot.noalias() = constant_input_accelerations_ * u;  // Eq. (1) for q''; Eq. (25)
  q_ddot -= force_accelerations_;
  return true;
}

Eigen::MatrixXd ServoConstraintProblem::TangentBasisAt(
    const Eigen::MatrixXd& output_jacobian) const {
  const Eigen::MatrixXd gram = output_jacobian * output_jacobian.transpose();
  return reference_tangent_basis_ -
         output_jacobian.transpose() *
             gram.ldlt().solve(output_jacobian * reference_tangent_basis_);
}

bool ServoConstraintProblem::ProjectedEquations(double t,
                                                const Eigen::VectorXd& x,
                                                Eigen::MatrixXd& mass,
                                                Eigen::VectorXd& rhs,
                                                std::string& why) {
  last_failure_ = SolveStatus::kConverged;
  const Eigen::Index f = dof();
  const Eigen::Index m = num_outputs();
  const Eigen::Index n = 2 * f + num_inputs();
  assert(x.size() == n);
  const auto q = x.head(f);
  const auto v = x.segment(f, f);
  const auto u = x.tail(num_inputs());
  if (!EvaluateDynamics(q, v, why)) return false;
  const Eigen::MatrixXd& output_jacobian = workspace_.output_jacobian;
  // With a constant H, D(q) = D_0 (H D_0 = 0 already).
  if (!output_is_linear_) tangent_basis_ = TangentBasisAt(output_jacobian);
  const Eigen::MatrixXd& tangent_basis =
      output_is_linear_ ? reference_tangent_basis_ : tangent_basis_;
  applied_.noalias() = workspace_.input_matrix * u;  // B u - f
  applied_ -= workspace_.forces;
  const Eigen::VectorXd& applied = applied_;
  accelerations_ = applied_;
  mass_factor_.solveInPlace(accelerations_);

  mass.setZero(n, n);
  rhs.resize(n);
  // Eq. (15): q' = v.
  mass.topLeftCorner(f, f).setIdentity();
  rhs.head(f) = v;
  // Eq. (16): D^T M v' = D^T (B u - f).
  mass.block(f, f, f - m, f) = tangent_basis.transpose() * workspace_.mass_matrix;
  rhs.segment(f, f - m) = tangent_basis.transpose() * applied;
  // Eq. (17): 0 = P u - H M^-1 f + h_bar - y_d'' = H M^-1 (B u - f) + h_bar - y_d''.
  DesiredAt(t);
  rhs.segment(2 * f - m, m).noalias() = output_jacobian * accelerations_;
  rhs.segment(2 * f - m, m) += workspace_.output_bias - desired_.col(2);
  // Eq. (18): 0 = h(q) - y_d.
  rhs.tail(m) = workspace_.output - desired_.col(0);
  return true;
}

bool ServoConstraintProblem::IndexOneResidual(double t,
                                              const Eigen::VectorXd& x,
                                              const Eigen::VectorXd& x_dot,
                                              Eigen::VectorXd& residual,
                                              std::string& why) {
  last_failure_ = SolveStatus::kConverged;
  const Eigen::Index f = dof();
  const Eigen::Index m = num_outputs();
  const Eigen::Index internal = f - m;
  const auto q = x.head(f);
  const auto v = x.segment(f, f);
  const auto u = x.tail(num_inputs());
  if (!EvaluateDynamics(q, v, why)) return false;
  const Eigen::MatrixXd& output_jacobian = workspace_.output_jacobian;
  applied_.noalias() = workspace_.input_matrix * u;  // B u - f
  applied_ -= workspace_.forces;
  accelerations_ = applied_;
  mass_factor_.solveInPlace(accelerations_);  // M^-1 (B u - f)

  DesiredAt(t);
  residual.resize(x.size());
  // Only C^T q' and C^T v' appear, with C constant: the leading term's null space does not
  // move with q. Eq. (15) projected with D(q)^T M(q), whose null space does, made BDF unstable
  // on a pendubot (errors growing by about -2 per step, Gear & Petzold's phenomenon).
  residual.head(internal).noalias() = internal_directions_.transpose() * (x_dot.head(f) - v);
  residual.segment(internal, m) = workspace_.output - desired_.col(0);
  residual.segment(f, internal).noalias() = internal_directions_.transpose() * x_dot.segment(f, f);
  residual.segment(f, internal).noalias() -= internal_directions_.transpose() * accelerations_;
  residual.segment(f + internal, m).noalias() = output_jacobian * v;
  residual.segment(f + internal, m) -= desired_.col(1);
  residual.tail(m).noalias() = output_jacobian * accelerations_;
  residual.tail(m) += workspace_.output_bias - desired_.col(2);
  return true;
}

double ServoConstraintProblem::ServoResidual(double t, const Eigen::VectorXd& q) {
  Evaluate(model_, workspace_, q, Eigen::VectorXd::Zero(dof()), Quantity::kOutput);
  return (workspace_.output - trajectory_.Derivative(t, 0)).cwiseAbs().maxCoeff();
}

std::vector<int> ProjectedDae::ComponentIndices() const {
  const Eigen::Index f = problem_.dof();
  std::vector<int> indices(std::size_t(size()), 1);
  for (Eigen::Index i = f; i < 2 * f; ++i) indices[std::size_t(i)] = 2;
  for (Eigen::Index i = 2 * f; i < size(); ++i)
    indices[std::size_t(i)] = decoupling_regular_ ? 2 : 3;
  return indices;
}

}  // namespace servokit
