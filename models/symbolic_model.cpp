#include "models/symbolic_model.h"

#include <cassert>
#include <utility>

namespace servokit {
namespace {

// d column / d symbols: column.rows() x symbols.size().
GiNaC::matrix Jacobian(const GiNaC::matrix& column, const std::vector<GiNaC::realsymbol>& symbols) {
  GiNaC::matrix jacobian(column.rows(), static_cast<unsigned>(symbols.size()));
  for (unsigned i = 0; i < column.rows(); ++i) {
    for (unsigned j = 0; j < symbols.size(); ++j) {
      jacobian(i, j) = column(i, 0).diff(symbols[j]);
    }
  }
  return jacobian;
}

// d matrix / d symbols[k] for every k, each the shape of `matrix`.
std::vector<GiNaC::matrix> Derivatives(const GiNaC::matrix& matrix,
                                       const std::vector<GiNaC::realsymbol>& symbols) {
  std::vector<GiNaC::matrix> derivatives;
  derivatives.reserve(symbols.size());
  for (const GiNaC::realsymbol& symbol : symbols) {
    GiNaC::matrix derivative(matrix.rows(), matrix.cols());
    for (unsigned i = 0; i < matrix.rows(); ++i) {
      for (unsigned j = 0; j < matrix.cols(); ++j) {
        derivative(i, j) = matrix(i, j).diff(symbol);
      }
    }
    derivatives.push_back(std::move(derivative));
  }
  return derivatives;
}

// h_bar_i = sum_k sum_j dH_ij/dq_k q_dot_j q_dot_k (paper Eq. 5: H_dot q_dot with H_dot =
// sum_k dH/dq_k q_dot_k).
GiNaC::matrix OutputBias(const std::vector<GiNaC::matrix>& output_jacobian_derivatives,
                         const std::vector<GiNaC::realsymbol>& velocities,
                         unsigned num_outputs) {
  GiNaC::matrix bias(num_outputs, 1);
  for (unsigned i = 0; i < num_outputs; ++i) {
    GiNaC::ex sum = 0;
    for (unsigned k = 0; k < velocities.size(); ++k) {
      for (unsigned j = 0; j < velocities.size(); ++j) {
        sum += output_jacobian_derivatives[k](i, j) * velocities[j] * velocities[k];
      }
    }
    bias(i, 0) = sum;
  }
  return bias;
}

// Sum of |terms| of an expanded expression: what its value is compared with to call it zero.
GiNaC::ex SumOfAbsoluteTerms(const GiNaC::ex& expanded) {
  if (!GiNaC::is_a<GiNaC::add>(expanded)) return GiNaC::abs(expanded);
  GiNaC::ex sum = 0;
  for (const GiNaC::ex& term : expanded) sum += GiNaC::abs(term);
  return sum;
}

}  // namespace

SymbolicModel::SymbolicModel(std::vector<GiNaC::realsymbol> parameters,
                             std::vector<GiNaC::realsymbol> coordinates,
                             std::vector<GiNaC::realsymbol> velocities,
                             GiNaC::matrix mass_matrix,
                             GiNaC::matrix forces,
                             GiNaC::matrix input_matrix,
                             GiNaC::matrix output)
    : parameters_(std::move(parameters)),
      coordinates_(std::move(coordinates)),
      velocities_(std::move(velocities)),
      mass_matrix_(std::move(mass_matrix)),
      forces_(std::move(forces)),
      input_matrix_(std::move(input_matrix)),
      output_(std::move(output)) {
  assert(velocities_.size() == coordinates_.size());
  assert(mass_matrix_.rows() == dof() && mass_matrix_.cols() == dof());
  assert(forces_.rows() == dof() && forces_.cols() == 1);
  assert(input_matrix_.rows() == dof());
  assert(output_.cols() == 1);
  output_jacobian_ = Jacobian(output_, coordinates_);
  output_jacobian_derivatives_ = Derivatives(output_jacobian_, coordinates_);
  output_bias_ = OutputBias(output_jacobian_derivatives_, velocities_, output_.rows());
  forces_position_jacobian_ = Jacobian(forces_, coordinates_);
  forces_velocity_jacobian_ = Jacobian(forces_, velocities_);
  mass_matrix_derivatives_ = Derivatives(mass_matrix_, coordinates_);
  input_matrix_derivatives_ = Derivatives(input_matrix_, coordinates_);
  output_bias_position_jacobian_ = Jacobian(output_bias_, coordinates_);
  output_bias_velocity_jacobian_ = Jacobian(output_bias_, velocities_);
  if (dof() + num_inputs() <= kMaxPolynomialSize && num_outputs() == num_inputs()) {
    GiNaC::exmap at_rest;
    for (const GiNaC::realsymbol& velocity : velocities_) at_rest[velocity] = 0;
    const GiNaC::realsymbol lambda("lambda");
    const GiNaC::ex polynomial =
        GiNaC::numer(GiNaC::normal(RosenbrockDeterminant(lambda, at_rest))).expand();
    for (int k = 0; k <= int(2 * dof()); ++k) {
      const GiNaC::ex coefficient = polynomial.coeff(lambda, k);
      zero_dynamics_polynomial_.push_back(coefficient);
      zero_dynamics_polynomial_scale_.push_back(SumOfAbsoluteTerms(coefficient));
    }
  }
}

GiNaC::ex SymbolicModel::RosenbrockDeterminant(const GiNaC::realsymbol& lambda,
                                               const GiNaC::exmap& at) const {
  const unsigned n = unsigned(dof()), m = unsigned(num_inputs());
  GiNaC::matrix rosenbrock(n + m, n + m);
  for (unsigned i = 0; i < n; ++i) {
    for (unsigned j = 0; j < n; ++j) {
      rosenbrock(i, j) =
          (mass_matrix_(i, j) * GiNaC::pow(lambda, 2) + forces_velocity_jacobian_(i, j) * lambda +
           forces_position_jacobian_(i, j))
              .subs(at);
    }
    for (unsigned k = 0; k < m; ++k) rosenbrock(i, n + k) = -input_matrix_(i, k).subs(at);
  }
  for (unsigned r = 0; r < output_.rows(); ++r) {
    for (unsigned j = 0; j < n; ++j) rosenbrock(n + r, j) = output_jacobian_(r, j).subs(at);
  }
  return rosenbrock.determinant();
}

std::vector<GiNaC::ex> SymbolicModel::ProgramInputs() const {
  std::vector<GiNaC::ex> inputs;
  inputs.reserve(parameters_.size() + coordinates_.size() + velocities_.size());
  inputs.insert(inputs.end(), parameters_.begin(), parameters_.end());
  inputs.insert(inputs.end(), coordinates_.begin(), coordinates_.end());
  inputs.insert(inputs.end(), velocities_.begin(), velocities_.end());
  return inputs;
}

GiNaC::exmap SymbolicModel::ParameterValues(const Eigen::VectorXd& values) const {
  assert(static_cast<std::size_t>(values.size()) == parameters_.size());
  GiNaC::exmap substitution;
  for (std::size_t i = 0; i < parameters_.size(); ++i) {
    substitution[parameters_[i]] = GiNaC::numeric(values[static_cast<Eigen::Index>(i)]);
  }
  return substitution;
}

GiNaC::ex SymbolicModel::SubstituteParameters(const GiNaC::ex& expression,
                                              const Eigen::VectorXd& values) const {
  return expression.subs(ParameterValues(values));
}

}  // namespace servokit
