#include "modeling/symbolic_model.h"

#include <cassert>
#include <utility>

#include "modeling/expansion_bound.h"

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

// The nodes GiNaC walks to differentiate f by every q and q_dot and B by every q,
// dof (2 |f| + |B|); counting stops once that is past `limit`.
double JacobianWork(const GiNaC::matrix& forces,
                    const GiNaC::matrix& input_matrix,
                    std::size_t dof,
                    double limit) {
  const double nodes_limit = limit / double(dof);  // of 2 |f| + |B|
  double nodes = 0.0;
  const auto add = [&](const GiNaC::ex& entry, double weight) {
    if (nodes <= nodes_limit) nodes += weight * TreeSize(entry, (nodes_limit - nodes) / weight);
  };
  for (unsigned i = 0; i < forces.rows(); ++i) add(forces(i, 0), 2.0);
  for (unsigned i = 0; i < input_matrix.rows(); ++i) {
    for (unsigned j = 0; j < input_matrix.cols(); ++j) add(input_matrix(i, j), 1.0);
  }
  return double(dof) * nodes;
}

// Sum of |terms| of an expanded expression: what its value is compared with to call it zero.
GiNaC::ex SumOfAbsoluteTerms(const GiNaC::ex& expanded) {
  if (!GiNaC::is_a<GiNaC::add>(expanded)) return GiNaC::abs(expanded);
  GiNaC::ex sum = 0;
  for (const GiNaC::ex& term : expanded) sum += GiNaC::abs(term);
  return sum;
}

// `entries` kept as given: a GiNaC matrix in `matrix`, canonical forms in `canonical` (then
// `built` is false until the GiNaC matrix is built).
void Keep(SymbolicModel::Entries entries,
          GiNaC::matrix& matrix,
          std::optional<CanonicalEntries>& canonical,
          bool& built) {
  if (auto* forms = std::get_if<CanonicalEntries>(&entries)) {
    canonical = std::move(*forms);
    built = false;
  } else {
    matrix = std::move(std::get<GiNaC::matrix>(entries));
  }
}

}  // namespace

GiNaC::matrix InGiNaC(const CanonicalEntries& forms, unsigned rows, unsigned cols) {
  assert(forms.entries.size() == std::size_t(rows) * cols);
  GiNaC::matrix matrix(rows, cols);
  for (unsigned i = 0; i < rows; ++i) {
    for (unsigned j = 0; j < cols; ++j) {
      matrix(i, j) = forms.store->Expression(forms.entries[i * cols + j]);
    }
  }
  return matrix;
}

SymbolicModel::SymbolicModel(std::vector<GiNaC::realsymbol> parameters,
                             std::vector<GiNaC::realsymbol> coordinates,
                             std::vector<GiNaC::realsymbol> velocities,
                             Entries mass_matrix,
                             Entries forces,
                             GiNaC::matrix input_matrix,
                             GiNaC::matrix output,
                             GiNaC::matrix constraints) {
  const SymbolicLock lock;
  expressions_.reset(new Expressions());
  Expressions& e = *expressions_;
  e.parameters = std::move(parameters);
  e.coordinates = std::move(coordinates);
  e.velocities = std::move(velocities);
  Keep(std::move(mass_matrix), e.mass_matrix, e.canonical_mass_matrix, e.mass_matrix_built);
  Keep(std::move(forces), e.forces, e.canonical_forces, e.forces_built);
  e.input_matrix = std::move(input_matrix);
  e.output = std::move(output);
  assert(e.velocities.size() == e.coordinates.size());
  assert(e.mass_matrix_built ? e.mass_matrix.rows() == dof() && e.mass_matrix.cols() == dof()
                             : e.canonical_mass_matrix->entries.size() == dof() * dof());
  assert(e.forces_built ? e.forces.rows() == dof() && e.forces.cols() == 1
                        : e.canonical_forces->entries.size() == dof());
  assert(e.input_matrix.rows() == dof());
  assert(e.output.cols() == 1);
  e.output_jacobian = Jacobian(e.output, e.coordinates);
  e.output_bias =
      OutputBias(Derivatives(e.output_jacobian, e.coordinates), e.velocities, e.output.rows());
  e.constraints = std::move(constraints);
  assert(e.constraints.cols() == 1);
  e.constraint_jacobian = Jacobian(e.constraints, e.coordinates);
  e.constraint_jacobian_derivatives = Derivatives(e.constraint_jacobian, e.coordinates);
  e.constraint_bias =
      OutputBias(e.constraint_jacobian_derivatives, e.velocities, e.constraints.rows());
  if (!e.forces_built) {
    const double limit = kMaxEagerForcesWork / (2.0 * double(dof()));  // of |f|
    double size = 0.0;
    for (const CanonicalExpressions::Scaled& entry : e.canonical_forces->entries) {
      if (size <= limit) size += e.canonical_forces->store->TreeSize(entry, limit - size);
    }
    if (size > limit) {
      e.jacobian_work = 2.0 * double(dof()) * size;
      return;  // Evaluate differentiates the programs; f stays canonical until asked for
    }
    static_cast<void>(this->forces());  // small: built now, as a model derived in GiNaC
  }
  e.jacobian_work = JacobianWork(e.forces, e.input_matrix, dof(), kMaxJacobianWork);
  if (e.jacobian_work > kMaxJacobianWork) return;  // Evaluate differentiates the programs
  e.forces_position_jacobian = Jacobian(e.forces, e.coordinates);
  e.forces_velocity_jacobian = Jacobian(e.forces, e.velocities);
  e.input_matrix_derivatives = Derivatives(e.input_matrix, e.coordinates);
  // With loops the zero dynamics live on the constraint manifold: no closed form here.
  if (dof() + num_inputs() <= kMaxPolynomialSize && num_outputs() == num_inputs() &&
      num_constraints() == 0) {
    GiNaC::exmap at_rest;
    for (const GiNaC::realsymbol& velocity : e.velocities) at_rest[velocity] = 0;
    const GiNaC::realsymbol lambda("lambda");
    const GiNaC::matrix rosenbrock = RosenbrockMatrix(lambda, at_rest);
    // Derived only when its expansion stays within the budget; else sweeps take the numeric
    // route (the eigenvalues of the linearized zero dynamics) for this model too.
    e.zero_dynamics_polynomial_terms = BoundExpandedTerms(LeibnizDeterminant(rosenbrock)).numerator;
    e.has_zero_dynamics_polynomial = e.zero_dynamics_polynomial_terms <= kMaxPolynomialTerms;
  }
}

const GiNaC::matrix& SymbolicModel::mass_matrix() const {
  const SymbolicLock lock;
  Expressions& e = *expressions_;
  if (!e.mass_matrix_built) {
    e.mass_matrix = InGiNaC(*e.canonical_mass_matrix, unsigned(dof()), unsigned(dof()));
    e.mass_matrix_built = true;
  }
  return e.mass_matrix;
}

const GiNaC::matrix& SymbolicModel::forces() const {
  const SymbolicLock lock;
  Expressions& e = *expressions_;
  if (!e.forces_built) {
    e.forces = InGiNaC(*e.canonical_forces, unsigned(dof()), 1);
    e.forces_built = true;
  }
  return e.forces;
}

SymbolicModel::ZeroDynamicsPolynomial SymbolicModel::DeriveZeroDynamicsPolynomial() const {
  const SymbolicLock lock;
  ZeroDynamicsPolynomial result;
  if (!has_zero_dynamics_polynomial()) return result;
  GiNaC::exmap at_rest;
  for (const GiNaC::realsymbol& velocity : expressions_->velocities) at_rest[velocity] = 0;
  const GiNaC::realsymbol lambda("lambda");
  const GiNaC::ex determinant = LeibnizDeterminant(RosenbrockMatrix(lambda, at_rest));
  const GiNaC::ex polynomial = GiNaC::numer(GiNaC::normal(determinant)).expand();
  for (int k = 0; k <= int(2 * dof()); ++k) {
    const GiNaC::ex coefficient = polynomial.coeff(lambda, k);
    result.coefficients.push_back(coefficient);
    result.scales.push_back(SumOfAbsoluteTerms(coefficient));
  }
  return result;
}

GiNaC::ex SymbolicModel::RosenbrockDeterminant(const GiNaC::realsymbol& lambda,
                                               const GiNaC::exmap& at) const {
  const SymbolicLock lock;
  return RosenbrockMatrix(lambda, at).determinant();
}

GiNaC::matrix SymbolicModel::RosenbrockMatrix(const GiNaC::realsymbol& lambda,
                                              const GiNaC::exmap& at) const {
  const SymbolicLock lock;
  const Expressions& e = *expressions_;
  assert(has_symbolic_jacobians() && "the Rosenbrock matrix needs df/dq and df/dq_dot");
  const unsigned n = unsigned(dof()), m = unsigned(num_inputs());
  GiNaC::matrix rosenbrock(n + m, n + m);
  for (unsigned i = 0; i < n; ++i) {
    for (unsigned j = 0; j < n; ++j) {
      rosenbrock(i, j) =
          (mass_matrix()(i, j) * GiNaC::pow(lambda, 2) + e.forces_velocity_jacobian(i, j) * lambda +
           e.forces_position_jacobian(i, j))
              .subs(at);
    }
    for (unsigned k = 0; k < m; ++k) rosenbrock(i, n + k) = -e.input_matrix(i, k).subs(at);
  }
  for (unsigned r = 0; r < e.output.rows(); ++r) {
    for (unsigned j = 0; j < n; ++j) rosenbrock(n + r, j) = e.output_jacobian(r, j).subs(at);
  }
  return rosenbrock;
}

std::vector<GiNaC::ex> ProgramInputSymbols(const std::vector<GiNaC::realsymbol>& parameters,
                                           const std::vector<GiNaC::realsymbol>& coordinates,
                                           const std::vector<GiNaC::realsymbol>& velocities) {
  const SymbolicLock lock;
  std::vector<GiNaC::ex> inputs;
  inputs.reserve(parameters.size() + coordinates.size() + velocities.size());
  inputs.insert(inputs.end(), parameters.begin(), parameters.end());
  inputs.insert(inputs.end(), coordinates.begin(), coordinates.end());
  inputs.insert(inputs.end(), velocities.begin(), velocities.end());
  return inputs;
}

std::vector<GiNaC::ex> SymbolicModel::ProgramInputs() const {
  const SymbolicLock lock;
  return ProgramInputSymbols(expressions_->parameters, expressions_->coordinates,
                             expressions_->velocities);
}

GiNaC::exmap SymbolicModel::ParameterValues(const Eigen::VectorXd& values) const {
  const SymbolicLock lock;
  const std::vector<GiNaC::realsymbol>& symbols = expressions_->parameters;
  assert(static_cast<std::size_t>(values.size()) == symbols.size());
  GiNaC::exmap substitution;
  for (std::size_t i = 0; i < symbols.size(); ++i) {
    substitution[symbols[i]] = GiNaC::numeric(values[static_cast<Eigen::Index>(i)]);
  }
  return substitution;
}

GiNaC::ex SymbolicModel::SubstituteParameters(const GiNaC::ex& expression,
                                              const Eigen::VectorXd& values) const {
  const SymbolicLock lock;
  return expression.subs(ParameterValues(values));
}

}  // namespace servokit
