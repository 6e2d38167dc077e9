#include "models/model.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <utility>

#include "models/expression_program.h"

namespace servokit {
namespace {

std::size_t ProgramIndex(Quantity quantity) {
  const auto bits = static_cast<unsigned>(quantity);
  assert(std::has_single_bit(bits) && "program() takes one Quantity, not a combination");
  return static_cast<std::size_t>(std::countr_zero(bits));
}

bool Wants(unsigned quantities, Quantity quantity) {
  return (quantities & static_cast<unsigned>(quantity)) != 0;
}

Eigen::Index ToIndex(std::size_t size) { return static_cast<Eigen::Index>(size); }

// Copies consecutive column-major blocks of blocks[k].rows() x blocks[k].cols() values.
template <typename Block>
const double* CopyBlock(const double* source, Block& block) {
  std::copy_n(source, block.size(), block.data());
  return source + block.size();
}

}  // namespace

std::vector<std::string> Model::output_names() const {
  std::vector<std::string> names;
  names.reserve(num_outputs_);
  for (std::size_t i = 1; i <= num_outputs_; ++i) {
    // Appending, not "y" + to_string(i): GCC 12 -O2 warns falsely (-Wrestrict) on the latter.
    std::string name = "y";
    name += std::to_string(i);
    names.push_back(std::move(name));
  }
  return names;
}

std::optional<std::size_t> Model::FindParameter(std::string_view name) const {
  const auto found = std::find(parameter_names_.begin(), parameter_names_.end(), name);
  if (found == parameter_names_.end()) {
    return std::nullopt;
  }
  return static_cast<std::size_t>(found - parameter_names_.begin());
}

const ExpressionProgram& Model::program(Quantity quantity) const {
  const std::size_t index = ProgramIndex(quantity);
  assert(index < programs_.size() && programs_[index] && "model was not built by LoadModel");
  return *programs_[index];
}

Workspace::Workspace(const Model& model)
    : parameters(model.parameters()),
      dof_(model.dof()),
      num_inputs_(model.num_inputs()),
      num_outputs_(model.num_outputs()),
      num_parameters_(model.num_parameters()) {
  const Eigen::Index dof = ToIndex(dof_);
  const Eigen::Index inputs = ToIndex(num_inputs_);
  const Eigen::Index outputs = ToIndex(num_outputs_);
  mass_matrix.setZero(dof, dof);
  forces.setZero(dof);
  input_matrix.setZero(dof, inputs);
  output.setZero(outputs);
  output_jacobian.setZero(outputs, dof);
  output_bias.setZero(outputs);
  forces_position_jacobian.setZero(dof, dof);
  forces_velocity_jacobian.setZero(dof, dof);
  mass_matrix_derivatives.assign(dof_, Eigen::MatrixXd::Zero(dof, dof));
  input_matrix_derivatives.assign(dof_, Eigen::MatrixXd::Zero(dof, inputs));
  output_jacobian_derivatives.assign(dof_, Eigen::MatrixXd::Zero(outputs, dof));
  output_bias_position_jacobian.setZero(outputs, dof);
  output_bias_velocity_jacobian.setZero(outputs, dof);
  zero_dynamics_polynomial.setZero(2 * dof + 1);
  zero_dynamics_polynomial_scale.setZero(2 * dof + 1);

  program_inputs_.assign(num_parameters_ + 2 * dof_, 0.0);
  std::size_t max_registers = 0, max_outputs = 0;
  for (std::size_t i = 0; i < kNumQuantities; ++i) {
    const ExpressionProgram& program = model.program(static_cast<Quantity>(1u << i));
    max_registers = std::max(max_registers, program.num_registers());
    max_outputs = std::max(max_outputs, program.num_outputs());
  }
  registers_.assign(max_registers, 0.0);
  outputs_.assign(max_outputs, 0.0);
}

bool Workspace::Fits(const Model& model) const {
  if (dof_ != model.dof() || num_inputs_ != model.num_inputs() ||
      num_outputs_ != model.num_outputs() || num_parameters_ != model.num_parameters() ||
      static_cast<std::size_t>(parameters.size()) != num_parameters_) {
    return false;
  }
  // Same shape is not enough: a different model may need more scratch registers.
  for (std::size_t i = 0; i < kNumQuantities; ++i) {
    const ExpressionProgram& program = model.program(static_cast<Quantity>(1u << i));
    if (program.num_registers() > registers_.size() || program.num_outputs() > outputs_.size()) {
      return false;
    }
  }
  return true;
}

void Evaluate(const Model& model,
              Workspace& workspace,
              const Eigen::Ref<const Eigen::VectorXd>& q,
              const Eigen::Ref<const Eigen::VectorXd>& q_dot,
              unsigned quantities) {
  assert(workspace.Fits(model) && "workspace was built for another model");
  assert(static_cast<std::size_t>(q.size()) == model.dof() && "q must have size dof");
  assert(static_cast<std::size_t>(q_dot.size()) == model.dof() && "q_dot must have size dof");

  double* inputs = workspace.program_inputs_.data();
  inputs = std::copy_n(workspace.parameters.data(), workspace.parameters.size(), inputs);
  inputs = std::copy_n(q.data(), q.size(), inputs);
  std::copy_n(q_dot.data(), q_dot.size(), inputs);

  const auto run = [&](Quantity quantity, double* destination) {
    model.program(quantity).Evaluate(workspace.program_inputs_.data(), workspace.registers_.data(),
                                     destination);
  };
  // Single-block results are laid out column-major by the loader, as Eigen stores them, so the
  // program writes straight into the result; several blocks go through outputs_.
  if (Wants(quantities, Quantity::kMassMatrix)) {
    run(Quantity::kMassMatrix, workspace.mass_matrix.data());
  }
  if (Wants(quantities, Quantity::kForces)) {
    run(Quantity::kForces, workspace.forces.data());
  }
  if (Wants(quantities, Quantity::kInputMatrix)) {
    run(Quantity::kInputMatrix, workspace.input_matrix.data());
  }
  if (Wants(quantities, Quantity::kOutput)) {
    run(Quantity::kOutput, workspace.output.data());
  }
  if (Wants(quantities, Quantity::kOutputJacobian)) {
    run(Quantity::kOutputJacobian, workspace.output_jacobian.data());
  }
  if (Wants(quantities, Quantity::kOutputBias)) {
    run(Quantity::kOutputBias, workspace.output_bias.data());
  }
  const double* blocks = workspace.outputs_.data();
  if (Wants(quantities, Quantity::kForcesJacobians)) {
    run(Quantity::kForcesJacobians, workspace.outputs_.data());
    CopyBlock(CopyBlock(blocks, workspace.forces_position_jacobian),
              workspace.forces_velocity_jacobian);
  }
  const auto run_blocks = [&](Quantity quantity, std::vector<Eigen::MatrixXd>& results) {
    run(quantity, workspace.outputs_.data());
    const double* source = blocks;
    for (Eigen::MatrixXd& block : results) {
      source = CopyBlock(source, block);
    }
  };
  if (Wants(quantities, Quantity::kMassMatrixDerivatives)) {
    run_blocks(Quantity::kMassMatrixDerivatives, workspace.mass_matrix_derivatives);
  }
  if (Wants(quantities, Quantity::kInputMatrixDerivatives)) {
    run_blocks(Quantity::kInputMatrixDerivatives, workspace.input_matrix_derivatives);
  }
  if (Wants(quantities, Quantity::kOutputJacobianDerivatives)) {
    run_blocks(Quantity::kOutputJacobianDerivatives, workspace.output_jacobian_derivatives);
  }
  if (Wants(quantities, Quantity::kOutputBiasJacobians)) {
    run(Quantity::kOutputBiasJacobians, workspace.outputs_.data());
    CopyBlock(CopyBlock(blocks, workspace.output_bias_position_jacobian),
              workspace.output_bias_velocity_jacobian);
  }
  if (Wants(quantities, Quantity::kZeroDynamicsPolynomial)) {
    run(Quantity::kZeroDynamicsPolynomial, workspace.outputs_.data());
    CopyBlock(CopyBlock(blocks, workspace.zero_dynamics_polynomial),
              workspace.zero_dynamics_polynomial_scale);
  }
}

}  // namespace servokit
