#include "modeling/motion_series.h"

#include <cmath>
#include <cstddef>
#include <limits>

#include "modeling/expression_program.h"

namespace servokit {
namespace {

std::vector<Dual> Duals(const Eigen::VectorXd& values, const Eigen::VectorXd& tangents) {
  std::vector<Dual> duals(std::size_t(values.size()));
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    duals[std::size_t(i)] = Dual(values[i], tangents.size() == 0 ? 0.0 : tangents[i]);
  }
  return duals;
}

// x with A x = b for a small square matrix of duals (column-major): the values by LU, the
// tangents by the product rule A x' = b' - A' x. Empty where A's values are singular or not
// finite.
std::vector<Dual> SolveSmallSystem(const std::vector<Dual>& matrix, const std::vector<Dual>& rhs) {
  const auto n = Eigen::Index(rhs.size());
  Eigen::MatrixXd values(n, n), tangents(n, n);
  for (Eigen::Index c = 0; c < n; ++c) {
    for (Eigen::Index r = 0; r < n; ++r) {
      values(r, c) = matrix[std::size_t(r + c * n)].value;
      tangents(r, c) = matrix[std::size_t(r + c * n)].tangent;
    }
  }
  if (!values.allFinite() || !tangents.allFinite()) return {};
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(values);
  if (!(lu.rcond() > std::numeric_limits<double>::epsilon())) return {};
  Eigen::VectorXd b(n), b_tangent(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    b[i] = rhs[std::size_t(i)].value;
    b_tangent[i] = rhs[std::size_t(i)].tangent;
  }
  const Eigen::VectorXd x = lu.solve(b);
  return Duals(x, lu.solve(b_tangent - tangents * x));
}

}  // namespace

MotionSeries::MotionSeries(const Model& model,
                           const Eigen::VectorXd& parameters,
                           const MotionStart& start,
                           const MotionStart& direction,
                           Scratch& scratch)
    : model_(model),
      scratch_(&scratch),
      parameters_(Duals(parameters, Eigen::VectorXd())),
      u_(Duals(start.u, direction.u)),
      q_{Duals(start.q, direction.q), Duals(start.q_dot, direction.q_dot)} {
  FillInputs(0);
  EvaluateSeries(Quantity::kMassMatrix, 0);
  const auto n = Eigen::Index(model_.dof());
  Eigen::MatrixXd values(n, n);
  bool finite = true;
  for (Eigen::Index c = 0; c < n; ++c) {
    for (Eigen::Index r = 0; r < n; ++r) {
      const Dual& entry = scratch_->outputs[std::size_t(r + c * n)];
      values(r, c) = entry.value;
      finite = finite && std::isfinite(entry.value) && std::isfinite(entry.tangent);
    }
  }
  if (!finite) return;
  auto factor = std::make_shared<Eigen::PartialPivLU<Eigen::MatrixXd>>(values);
  // PartialPivLU does not report singularity; its reciprocal condition estimate does.
  if (factor->rcond() > std::numeric_limits<double>::epsilon()) mass_matrix_ = std::move(factor);
}

MotionSeries::MotionSeries(const MotionSeries& same_start, const MotionStart& direction)
    : model_(same_start.model_),
      scratch_(same_start.scratch_),
      parameters_(same_start.parameters_),
      mass_matrix_(same_start.mass_matrix_) {
  const auto values = [](const std::vector<Dual>& duals) {
    Eigen::VectorXd result(Eigen::Index(duals.size()));
    for (std::size_t i = 0; i < duals.size(); ++i) result[Eigen::Index(i)] = duals[i].value;
    return result;
  };
  u_ = Duals(values(same_start.u_), direction.u);
  q_ = {Duals(values(same_start.q_[0]), direction.q),
        Duals(values(same_start.q_[1]), direction.q_dot)};
}

MotionSeries::MotionSeries(const MotionSeries& same_start,
                           const MotionStart& direction,
                           std::shared_ptr<const Tracking> tracking)
    : MotionSeries(same_start, direction) {
  tracking_ = std::move(tracking);
  if (!mass_matrix_) return;
  FillInputs(0);
  EvaluateSeries(Quantity::kInputMatrix, 0);
  KeepTrackingColumns(1);
  EvaluateSeries(Quantity::kMassMatrix, 0);
  if (!PrepareTracking(1)) mass_matrix_.reset();  // every value NaN: nothing to decide here
}

void MotionSeries::KeepTrackingColumns(std::size_t width) {
  const std::size_t n = model_.dof();
  tracking_columns_.clear();
  for (std::size_t c : tracking_->inputs) {
    std::vector<Dual> column(n);
    for (std::size_t r = 0; r < n; ++r) column[r] = scratch_->outputs[(r + c * n) * width];
    tracking_columns_.push_back(std::move(column));
  }
}

bool MotionSeries::PrepareTracking(std::size_t width) {
  const std::size_t n = model_.dof(), p = parameters_.size();
  const std::size_t kept = tracking_->inputs.size();
  tracking_directions_.clear();
  for (const std::vector<Dual>& column : tracking_columns_) {
    tracking_directions_.push_back(SolveMassMatrix(column, scratch_->outputs.data(), width));
  }
  // H_R v = the coefficient 1 of h_R(q_0 + t v); h reads no velocity.
  tracking_matrix_.assign(kept * kept, Dual());
  for (std::size_t c = 0; c < kept; ++c) {
    scratch_->inputs.assign((p + 2 * n) * 2, Dual());
    for (std::size_t i = 0; i < p; ++i) scratch_->inputs[i * 2] = parameters_[i];
    for (std::size_t j = 0; j < n; ++j) {
      scratch_->inputs[(p + j) * 2] = q_[0][j];
      scratch_->inputs[(p + j) * 2 + 1] = tracking_directions_[c][j];
    }
    EvaluateSeries(Quantity::kOutput, 1);
    for (std::size_t r = 0; r < kept; ++r) {
      tracking_matrix_[r + c * kept] = scratch_->outputs[tracking_->outputs[r] * 2 + 1];
    }
  }
  return !SolveSmallSystem(tracking_matrix_, std::vector<Dual>(kept)).empty();
}

void MotionSeries::SolveTrackingInputs(std::size_t k, std::vector<Dual>& acceleration) {
  const auto divisor = double((k + 1) * (k + 2));
  const std::size_t kept = tracking_->inputs.size(), order = k + 2;
  double factorial = 1.0;
  for (std::size_t j = 2; j <= order; ++j) factorial *= double(j);
  // The residual of y_R's coefficient k + 2 with u_C,k = 0.
  std::vector<Dual> provisional(acceleration.size());
  for (std::size_t j = 0; j < acceleration.size(); ++j) provisional[j] = acceleration[j] / divisor;
  q_.push_back(std::move(provisional));
  FillInputs(int(order));
  EvaluateSeries(Quantity::kOutput, int(order));
  q_.pop_back();
  std::vector<Dual> rhs(kept);
  for (std::size_t r = 0; r < kept; ++r) {
    const std::vector<double>& desired = tracking_->desired[r];
    const double wanted = order < desired.size() ? desired[order] / factorial : 0.0;
    rhs[r] = -divisor * (scratch_->outputs[tracking_->outputs[r] * (order + 1) + order] - wanted);
  }
  std::vector<Dual> inputs = SolveSmallSystem(tracking_matrix_, rhs);
  if (inputs.empty()) inputs.assign(kept, Dual(std::nan(""), std::nan("")));
  for (std::size_t c = 0; c < kept; ++c) {
    for (std::size_t j = 0; j < acceleration.size(); ++j) {
      acceleration[j] += tracking_directions_[c][j] * inputs[c];
    }
  }
  tracking_inputs_.push_back(std::move(inputs));
}

void MotionSeries::FillInputs(int degree) {
  const auto width = std::size_t(degree + 1);
  const std::size_t n = model_.dof(), p = parameters_.size();
  scratch_->inputs.assign((p + 2 * n) * width, Dual());
  for (std::size_t i = 0; i < p; ++i) scratch_->inputs[i * width] = parameters_[i];
  for (std::size_t j = 0; j < n; ++j) {
    for (std::size_t k = 0; k < width; ++k) {
      scratch_->inputs[(p + j) * width + k] = q_[k][j];
      // h reads no velocity: an output's series may run an order past the velocities known.
      if (k + 1 < q_.size()) {
        scratch_->inputs[(p + n + j) * width + k] = double(k + 1) * q_[k + 1][j];
      }
    }
  }
}

void MotionSeries::EvaluateSeries(Quantity quantity, int degree) {
  const ExpressionProgram& program = model_.program(quantity);
  const auto width = std::size_t(degree + 1);
  scratch_->registers.resize(program.num_registers() * width);
  scratch_->outputs.resize(program.num_outputs() * width);
  program.EvaluateTaylor(degree, scratch_->inputs.data(), scratch_->registers.data(),
                         scratch_->outputs.data());
  scratch_->work += double(program.num_instructions()) * double(width * width);
}

std::vector<Dual> MotionSeries::SolveMassMatrix(const std::vector<Dual>& rhs,
                                                const Dual* mass_series,
                                                std::size_t width) const {
  const auto n = Eigen::Index(rhs.size());
  if (!mass_matrix_) return std::vector<Dual>(rhs.size(), Dual(std::nan(""), std::nan("")));
  Eigen::VectorXd values(n), tangents(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    values[i] = rhs[std::size_t(i)].value;
    tangents[i] = rhs[std::size_t(i)].tangent;
  }
  const Eigen::VectorXd solution = mass_matrix_->solve(values);
  // tangents -= M_0' solution, entry (r, c) of M_0 being series r + c n at coefficient 0.
  for (Eigen::Index c = 0; c < n; ++c) {
    for (Eigen::Index r = 0; r < n; ++r) {
      tangents[r] -= mass_series[std::size_t(r + c * n) * width].tangent * solution[c];
    }
  }
  return Duals(solution, mass_matrix_->solve(tangents));
}

void MotionSeries::AddOrder() {
  const std::size_t k = accelerations_.size();
  const auto width = k + 1;
  const std::size_t n = model_.dof();
  FillInputs(int(k));
  // rhs = B_k u - f_k - sum_(l=1..k) M_l a_(k-l); entry (r, c) of a matrix is output r + c n.
  // M's series last, so that the solve reads M_0's tangents from it.
  std::vector<Dual> rhs(n);
  EvaluateSeries(Quantity::kForces, int(k));
  for (std::size_t r = 0; r < n; ++r) rhs[r] -= scratch_->outputs[r * width + k];
  EvaluateSeries(Quantity::kInputMatrix, int(k));
  for (std::size_t c = 0; c < u_.size(); ++c) {
    if (IsZero(u_[c])) continue;  // 0 * inf would make a motion at rest NaN
    for (std::size_t r = 0; r < n; ++r)
      rhs[r] += scratch_->outputs[(r + c * n) * width + k] * u_[c];
  }
  // A tracking motion's input series: coefficient k of B(q(t)) u_C(t), but u_C,k (solved below).
  for (std::size_t l = 0; l < tracking_inputs_.size(); ++l) {
    for (std::size_t i = 0; i < tracking_inputs_[l].size(); ++i) {
      const Dual& input = tracking_inputs_[l][i];
      if (IsZero(input)) continue;
      const std::size_t c = tracking_->inputs[i];
      for (std::size_t r = 0; r < n; ++r)
        rhs[r] += scratch_->outputs[(r + c * n) * width + (k - l)] * input;
    }
  }
  EvaluateSeries(Quantity::kMassMatrix, int(k));
  for (std::size_t c = 0; c < n; ++c) {
    for (std::size_t r = 0; r < n; ++r) {
      const Dual* series = &scratch_->outputs[(r + c * n) * width];
      for (std::size_t l = 1; l <= k; ++l) rhs[r] -= series[l] * accelerations_[k - l][c];
    }
  }
  std::vector<Dual> acceleration = SolveMassMatrix(rhs, scratch_->outputs.data(), width);
  if (tracking_) SolveTrackingInputs(k, acceleration);
  std::vector<Dual> next(n);
  const auto divisor = double((k + 1) * (k + 2));
  for (std::size_t j = 0; j < n; ++j) next[j] = acceleration[j] / divisor;
  q_.push_back(std::move(next));
  accelerations_.push_back(std::move(acceleration));
}

MotionSeries::Derivative MotionSeries::Split(const std::vector<Dual>& duals, double scale) {
  Derivative split{Eigen::VectorXd(Eigen::Index(duals.size())),
                   Eigen::VectorXd(Eigen::Index(duals.size()))};
  for (std::size_t i = 0; i < duals.size(); ++i) {
    split.value[Eigen::Index(i)] = scale * duals[i].value;
    split.tangent[Eigen::Index(i)] = scale * duals[i].tangent;
  }
  return split;
}

MotionSeries::Derivative MotionSeries::Acceleration() {
  if (accelerations_.empty()) AddOrder();
  return Split(accelerations_.front(), 1.0);
}

MotionSeries::Derivative MotionSeries::OutputDerivative(int k) {
  const auto order = std::size_t(k);
  const std::size_t outputs = model_.num_outputs();
  if (!mass_matrix_) {
    return Split(std::vector<Dual>(outputs, Dual(std::nan(""), std::nan(""))), 1.0);
  }
  // h reads q alone (y = h(q)), and its coefficient k reads q_0 .. q_k: the velocities' series,
  // one order further, is left 0 beyond the orders known (the gradient of y' needs no solve).
  while (q_.size() < order + 1) AddOrder();
  FillInputs(k);
  EvaluateSeries(Quantity::kOutput, k);
  double factorial = 1.0;
  for (std::size_t j = 2; j <= order; ++j) factorial *= double(j);
  std::vector<Dual> coefficients(outputs);
  for (std::size_t i = 0; i < outputs; ++i)
    coefficients[i] = scratch_->outputs[i * (order + 1) + order];
  return Split(coefficients, factorial);
}

}  // namespace servokit
