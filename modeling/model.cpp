#include "modeling/model.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <utility>

#include "modeling/expression_program.h"

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

std::string MultiplierName(std::size_t k) {
  std::string name = "lambda";  // appended: see output_names()
  name += std::to_string(k + 1);
  return name;
}

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
  if (quantity == Quantity::kZeroDynamicsPolynomial) {
    assert(has_zero_dynamics_polynomial() && "no program: see has_program");
    return *polynomial_programs().alone;
  }
  const std::size_t index = ProgramIndex(quantity);
  assert(index < programs_.size() && programs_[index] && "no program: see has_program");
  return *programs_[index];
}

bool Model::has_program(Quantity quantity) const {
  if (quantity == Quantity::kZeroDynamicsPolynomial) return has_zero_dynamics_polynomial();
  const std::size_t index = ProgramIndex(quantity);
  return index < programs_.size() && programs_[index] != nullptr;
}

const Model::PolynomialPrograms& Model::polynomial_programs() const {
  LazyPolynomial& lazy = *polynomial_;
  std::call_once(lazy.once, [&lazy] {
    if (lazy.compile) lazy.programs = lazy.compile();
    lazy.compile = nullptr;  // its captures (the symbolic model) are not needed again
  });
  return lazy.programs;
}

std::size_t Model::max_registers() const {
  return LargestOfPrograms(&ExpressionProgram::num_registers);
}

std::size_t Model::max_outputs() const {
  return LargestOfPrograms(&ExpressionProgram::num_outputs);
}

std::size_t Model::LargestOfPrograms(std::size_t (ExpressionProgram::*size)() const) const {
  std::size_t largest = 0;
  for (const auto& program : programs_) {
    if (program) largest = std::max(largest, ((*program).*size)());
  }
  return largest;
}

Workspace::Workspace(const Model& model)
    : parameters(model.parameters()),
      dof_(model.dof()),
      num_inputs_(model.num_inputs()),
      num_outputs_(model.num_outputs()),
      num_parameters_(model.num_parameters()),
      num_constraints_(model.num_constraints()) {
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
  input_matrix_derivatives.assign(dof_, Eigen::MatrixXd::Zero(dof, inputs));
  zero_dynamics_polynomial.setZero(2 * dof + 1);
  zero_dynamics_polynomial_scale.setZero(2 * dof + 1);
  const Eigen::Index loops = ToIndex(num_constraints_);
  constraints.setZero(loops);
  constraint_jacobian.setZero(loops, dof);
  constraint_bias.setZero(loops);
  constraint_jacobian_derivatives.assign(dof_, Eigen::MatrixXd::Zero(loops, dof));

  program_inputs_.assign(num_parameters_ + 2 * dof_, 0.0);
  registers_.assign(model.max_registers(), 0.0);
  outputs_.assign(model.max_outputs(), 0.0);
}

bool Workspace::Fits(const Model& model) const {
  if (dof_ != model.dof() || num_inputs_ != model.num_inputs() ||
      num_outputs_ != model.num_outputs() || num_parameters_ != model.num_parameters() ||
      num_constraints_ != model.num_constraints() ||
      static_cast<std::size_t>(parameters.size()) != num_parameters_) {
    return false;
  }
  // Same shape is not enough: a different model may need more scratch registers.
  return model.max_registers() <= registers_.size() && model.max_outputs() <= outputs_.size();
}

namespace {

// Calls visit(data, size) for each block of quantity's results in the workspace, in the order
// the loader compiles them (column-major, one after another).
template <typename Visit>
void ForEachResultBlock(Quantity quantity, Workspace& workspace, Visit visit) {
  const auto block = [&](auto& matrix) {
    visit(matrix.data(), static_cast<std::size_t>(matrix.size()));
  };
  switch (quantity) {
    case Quantity::kMassMatrix:
      return block(workspace.mass_matrix);
    case Quantity::kForces:
      return block(workspace.forces);
    case Quantity::kInputMatrix:
      return block(workspace.input_matrix);
    case Quantity::kOutput:
      return block(workspace.output);
    case Quantity::kOutputJacobian:
      return block(workspace.output_jacobian);
    case Quantity::kOutputBias:
      return block(workspace.output_bias);
    case Quantity::kForcesJacobians:
      block(workspace.forces_position_jacobian);
      return block(workspace.forces_velocity_jacobian);
    case Quantity::kInputMatrixDerivatives:
      for (Eigen::MatrixXd& matrix : workspace.input_matrix_derivatives) block(matrix);
      return;
    case Quantity::kZeroDynamicsPolynomial:
      block(workspace.zero_dynamics_polynomial);
      return block(workspace.zero_dynamics_polynomial_scale);
    case Quantity::kConstraints:
      return block(workspace.constraints);
    case Quantity::kConstraintJacobian:
      return block(workspace.constraint_jacobian);
    case Quantity::kConstraintBias:
      return block(workspace.constraint_bias);
    case Quantity::kConstraintJacobianDerivatives:
      for (Eigen::MatrixXd& matrix : workspace.constraint_jacobian_derivatives) block(matrix);
      return;
  }
}

// Copies quantity's results from `source` into the workspace.
void CopyResults(Quantity quantity, const double* source, Workspace& workspace) {
  ForEachResultBlock(quantity, workspace, [&](double* data, std::size_t size) {
    std::copy_n(source, size, data);
    source += size;
  });
}

// Where a result of a single block lives in the workspace, laid out column-major by the loader
// as Eigen stores it, so that its program writes it in place; nullptr for a result of several
// blocks (it goes through outputs_ and CopyResults).
double* InPlaceResult(Quantity quantity, Workspace& workspace) {
  double* only = nullptr;
  int blocks = 0;
  ForEachResultBlock(quantity, workspace, [&](double* data, std::size_t) {
    only = data;
    ++blocks;
  });
  return blocks == 1 ? only : nullptr;
}

}  // namespace

void Workspace::SetProgramInputs(const Eigen::Ref<const Eigen::VectorXd>& q,
                                 const Eigen::Ref<const Eigen::VectorXd>& q_dot) {
  assert(static_cast<std::size_t>(q.size()) == dof_ && "q must have size dof");
  assert(static_cast<std::size_t>(q_dot.size()) == dof_ && "q_dot must have size dof");
  double* inputs = program_inputs_.data();
  inputs = std::copy_n(parameters.data(), parameters.size(), inputs);
  inputs = std::copy_n(q.data(), q.size(), inputs);
  std::copy_n(q_dot.data(), q_dot.size(), inputs);
}

// Column j of a Jacobian is the tangent of the program's outputs when input `first + j` carries
// tangent 1: kChunk columns per pass over dual numbers with that many tangents (vector mode: the
// values computed once per chunk, not once per column; each column's bits those of its own pass).
void Workspace::DifferentiateForwardMode(const Model& model, Quantity quantity) {
  const Quantity differentiated =
      quantity == Quantity::kForcesJacobians ? Quantity::kForces : Quantity::kInputMatrix;
  const ExpressionProgram& program = model.program(differentiated);
  dual_inputs_.assign(program_inputs_.begin(), program_inputs_.end());
  dual_registers_.resize(program.num_registers());
  dual_outputs_.resize(program.num_outputs());
  // The columns: (program input, destination of the column's num_outputs() entries).
  std::vector<std::pair<std::size_t, double*>> columns;
  const std::size_t first_q = num_parameters_, first_q_dot = num_parameters_ + dof_;
  for (std::size_t j = 0; j < dof_; ++j) {
    const auto col = static_cast<Eigen::Index>(j);
    if (quantity == Quantity::kForcesJacobians) {
      columns.emplace_back(first_q + j, forces_position_jacobian.col(col).data());
      columns.emplace_back(first_q_dot + j, forces_velocity_jacobian.col(col).data());
    } else {
      columns.emplace_back(first_q + j, input_matrix_derivatives[j].data());  // as B's program
    }
  }
  // Every value once, then per chunk of columns only the instructions its inputs reach: in a
  // chain of 400 pendulums an instruction reads two or three coordinates, so most of the
  // program carries no tangent in most chunks (issue #31).
  program.EvaluateTaylor(0, dual_inputs_.data(), dual_registers_.data(), dual_outputs_.data());
  for (std::size_t first = 0; first < columns.size(); first += kChunk) {
    const std::size_t count = std::min(kChunk, columns.size() - first);
    for (std::size_t c = 0; c < count; ++c) {
      const auto input = static_cast<std::uint32_t>(columns[first + c].first);
      dual_registers_[input].tangent.d[c] = 1.0;
      tangent_carrying_.push_back(input);
    }
    program.PropagateTangents(dual_registers_.data(), tangent_carrying_, tangent_flags_);
    for (std::size_t c = 0; c < count; ++c) {
      double* destination = columns[first + c].second;
      for (std::size_t k = 0; k < program.num_outputs(); ++k) {
        *destination++ = dual_registers_[program.output_register(k)].tangent.d[c];
      }
    }
    program.ClearTangents(dual_registers_.data(), tangent_carrying_, tangent_flags_);
  }
}

void EvaluateByForwardMode(const Model& model,
                           Workspace& workspace,
                           const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& q_dot,
                           unsigned quantities) {
  assert(workspace.Fits(model) && "workspace was built for another model");
  workspace.SetProgramInputs(q, q_dot);
  for (const Quantity quantity : {Quantity::kForcesJacobians, Quantity::kInputMatrixDerivatives}) {
    if (Wants(quantities, quantity)) workspace.DifferentiateForwardMode(model, quantity);
  }
}

void Evaluate(const Model& model,
              Workspace& workspace,
              const Eigen::Ref<const Eigen::VectorXd>& q,
              const Eigen::Ref<const Eigen::VectorXd>& q_dot,
              unsigned quantities) {
  assert(workspace.Fits(model) && "workspace was built for another model");
  workspace.SetProgramInputs(q, q_dot);

  const auto run = [&](const ExpressionProgram& program, double* destination) {
    // The polynomial's programs come after the workspace: its scratch grows for them.
    if (workspace.registers_.size() < program.num_registers()) {
      workspace.registers_.resize(program.num_registers());
    }
    program.Evaluate(workspace.program_inputs_.data(), workspace.registers_.data(), destination);
  };
  // The polynomial path, compiled as one program: its shared subexpressions computed once, on
  // registers of its own that keep its constants, its results written in place.
  if (quantities == kPolynomialPathQuantities && model.has_zero_dynamics_polynomial()) {
    const std::shared_ptr<const ExpressionProgram>& combined = model.polynomial_programs().combined;
    const ExpressionProgram& program = *combined;
    std::vector<double>& registers = workspace.combined_registers_;
    if (workspace.combined_program_ != combined) {
      registers.assign(program.num_registers(), 0.0);
      program.LoadConstants(registers.data());
      workspace.combined_program_ = combined;
    }
    std::copy(workspace.program_inputs_.begin(), workspace.program_inputs_.end(),
              registers.begin());
    std::vector<double*>& destinations = workspace.combined_destinations_;
    destinations.clear();
    for (unsigned bit = 0; bit < kNumQuantities; ++bit) {
      const auto quantity = static_cast<Quantity>(1u << bit);
      if (!Wants(quantities, quantity)) continue;
      ForEachResultBlock(quantity, workspace, [&](double* data, std::size_t size) {
        for (std::size_t k = 0; k < size; ++k) destinations.push_back(data + k);
      });
    }
    program.EvaluateLoaded(registers.data(), destinations.data());
    return;
  }
  // One program per quantity.
  for (unsigned bit = 0; bit < kNumQuantities; ++bit) {
    const auto quantity = static_cast<Quantity>(1u << bit);
    if (!Wants(quantities, quantity)) continue;
    if (!model.has_program(quantity)) {
      workspace.DifferentiateForwardMode(model, quantity);
    } else if (double* destination = InPlaceResult(quantity, workspace)) {
      run(model.program(quantity), destination);
    } else {
      const ExpressionProgram& program = model.program(quantity);
      if (workspace.outputs_.size() < program.num_outputs()) {
        workspace.outputs_.resize(program.num_outputs());
      }
      run(program, workspace.outputs_.data());
      CopyResults(quantity, workspace.outputs_.data(), workspace);
    }
  }
}

}  // namespace servokit
