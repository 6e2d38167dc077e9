#include "solvers/algebraic_inversion.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <cstddef>
#include <exception>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "analysis/types.h"
#include "models/errors.h"
#include "models/expression_program.h"
#include "models/symbolic_model.h"

namespace servokit {
namespace {

using GiNaC::ex;

// A u-coefficient whose numerator is below this fraction of the sum of its terms' magnitudes
// (sines and cosines counted as 1) at every decision point is zero. Coefficients that vanish
// only through the round-off of a parameter value, such as cos(90 deg) = 6e-17, come out near
// 1e-16 of their terms; a coefficient that does not vanish comes out at O(1) of them.
constexpr double kZeroCoefficientTolerance = 1e-12;
// A matrix (constraint Jacobian or u-coefficients), with rows and columns scaled as at the
// nominal point (so that its entries are O(1) there), is singular when a pivot of its
// full-pivoting LU falls below this fraction of max(1, largest pivot): the solution would have
// lost about 12 of its 16 digits. Absolute below 1 so that a matrix that shrinks as a whole
// (the pendulum's at theta = 90 deg, where cos(theta) = 6e-17) counts as singular.
constexpr double kSingularPivotTolerance = 1e-12;
// Newton has converged when every constraint residual is below this fraction of the size of
// its terms (|y_d^(k)| + |value| + sum_j |dc/dx_j x_j|). Constraints of high derivative order
// sum many terms that cancel (the six-mass chain's 11th derivative has binomial-like
// coefficients up to 10^10 in size), so this leaves room above machine precision while
// staying far below any modelling error.
constexpr double kNewtonTolerance = 1e-11;
constexpr int kMaxNewtonIterations = 20;
// A Newton correction of at most this many ulps of the largest state entry is round-off.
constexpr double kRoundOffSteps = 16.0;
// A relative residual that Newton no longer halves is accepted when below this: the
// six-mass chain's 12 constraints (derivatives up to y^(11)) have a Jacobian with condition
// number ~1e10 and may stall above kNewtonTolerance (cond * eps), while the forward check of
// that answer tracks y_d to ~1e-7.
constexpr double kStagnationTolerance = 1e-6;
// A parameter the derivation depends on at its nominal value (see Programs::pinned) must keep
// that value to this relative precision when Evaluate() is called.
constexpr double kPinnedParameterTolerance = 1e-12;

std::string OutputName(std::size_t output) { return "y" + std::to_string(output + 1); }

std::string JoinOrders(const std::vector<int>& orders) {
  std::string text;
  for (std::size_t i = 0; i < orders.size(); ++i) {
    text += (i ? ", " : "") + std::to_string(orders[i]);
  }
  return orders.size() == 1 ? text : "(" + text + ")";
}

// The value of a GiNaC expression at `point` (every symbol in it replaced by a number), or
// nullopt when it is not a finite real number there (a pole, the root of a negative number).
std::optional<double> ValueAt(const ex& expression, const GiNaC::exmap& point) {
  try {
    const ex value = expression.subs(point).evalf();
    if (!GiNaC::is_a<GiNaC::numeric>(value)) return std::nullopt;
    const GiNaC::numeric number = GiNaC::ex_to<GiNaC::numeric>(value);
    if (!number.is_real()) return std::nullopt;
    const double result = number.to_double();
    if (!std::isfinite(result)) return std::nullopt;
    return result;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The model's equations ready for differentiation: q'' = drift + sum_k u_k acceleration_input[k]
// (q'' = M^-1 (B u - f), paper Eq. 1), with the parameters whose nominal value is 0
// substituted exactly, so that sin(alpha) and d s_dot vanish identically in mass on car case 4.
struct Dynamics {
  std::vector<GiNaC::realsymbol> parameters, coordinates, velocities;
  std::vector<ex> outputs;                          // h_i(q)
  std::vector<ex> acceleration_drift;               // -M^-1 f, one per coordinate
  std::vector<std::vector<ex>> acceleration_input;  // [input][coordinate]: M^-1 B
  std::vector<std::size_t> zero_parameters;         // substituted by 0
};

Dynamics BuildDynamics(const Model& model) {
  const SymbolicModel& symbolic = model.symbolic();
  Dynamics dynamics;
  dynamics.parameters = symbolic.parameters();
  dynamics.coordinates = symbolic.coordinates();
  dynamics.velocities = symbolic.velocities();
  GiNaC::exmap zero;
  for (std::size_t p = 0; p < dynamics.parameters.size(); ++p) {
    if (model.parameters()[static_cast<Eigen::Index>(p)] == 0.0) {
      zero[dynamics.parameters[p]] = 0;
      dynamics.zero_parameters.push_back(p);
    }
  }
  const auto substitute = [&zero](const GiNaC::matrix& matrix) {
    return GiNaC::ex_to<GiNaC::matrix>(matrix.subs(zero));
  };
  const GiNaC::matrix mass_inverse = substitute(symbolic.mass_matrix()).inverse();
  const GiNaC::matrix drift = mass_inverse.mul(substitute(symbolic.forces())).mul_scalar(-1);
  const GiNaC::matrix input = mass_inverse.mul(substitute(symbolic.input_matrix()));
  const GiNaC::matrix output = substitute(symbolic.output());
  const unsigned dof = static_cast<unsigned>(symbolic.dof());
  for (unsigned j = 0; j < dof; ++j) {
    dynamics.acceleration_drift.push_back(GiNaC::normal(drift(j, 0)));
  }
  for (unsigned k = 0; k < input.cols(); ++k) {
    std::vector<ex> column;
    for (unsigned j = 0; j < dof; ++j) column.push_back(GiNaC::normal(input(j, k)));
    dynamics.acceleration_input.push_back(std::move(column));
  }
  for (unsigned i = 0; i < output.rows(); ++i) dynamics.outputs.push_back(output(i, 0));
  return dynamics;
}

// The time derivative of a u-free state function phi(q, q_dot) along the motion:
// drift + sum_k u_k input_coefficients[k].
struct TimeDerivative {
  ex drift;
  std::vector<ex> input_coefficients;
};

TimeDerivative Differentiate(const ex& state_function, const Dynamics& dynamics) {
  TimeDerivative derivative;
  derivative.input_coefficients.assign(dynamics.acceleration_input.size(), 0);
  ex drift = 0;
  for (std::size_t j = 0; j < dynamics.coordinates.size(); ++j) {
    drift += state_function.diff(dynamics.coordinates[j]) * dynamics.velocities[j];
    const ex by_velocity = state_function.diff(dynamics.velocities[j]);
    if (by_velocity.is_zero()) continue;
    drift += by_velocity * dynamics.acceleration_drift[j];
    for (std::size_t k = 0; k < dynamics.acceleration_input.size(); ++k) {
      derivative.input_coefficients[k] += by_velocity * dynamics.acceleration_input[k][j];
    }
  }
  derivative.drift = GiNaC::normal(drift);
  for (ex& coefficient : derivative.input_coefficients) coefficient = GiNaC::normal(coefficient);
  return derivative;
}

// Where "this u-coefficient is zero" is decided: the nominal parameters at the nominal point
// q = 0, q_dot = 0 and at two generic states. Generic states, because a coefficient that
// vanishes at q = 0 only (the gantry crane's y1'' has one proportional to sin(theta)) still
// puts u into that derivative everywhere else, so that derivative is not a state constraint.
std::vector<GiNaC::exmap> DecisionPoints(const Dynamics& dynamics, const Eigen::VectorXd& values) {
  GiNaC::exmap nominal;
  for (std::size_t p = 0; p < dynamics.parameters.size(); ++p) {
    nominal[dynamics.parameters[p]] = GiNaC::numeric(values[static_cast<Eigen::Index>(p)]);
  }
  std::vector<GiNaC::exmap> points(3, nominal);
  for (std::size_t j = 0; j < dynamics.coordinates.size(); ++j) {
    const double jj = static_cast<double>(j);
    points[0][dynamics.coordinates[j]] = 0;
    points[0][dynamics.velocities[j]] = 0;
    // Small, unrelated values: no multiple of pi/2, no symmetry between coordinates.
    points[1][dynamics.coordinates[j]] = GiNaC::numeric(0.137 + 0.071 * jj);
    points[1][dynamics.velocities[j]] = GiNaC::numeric(0.093 - 0.041 * jj);
    points[2][dynamics.coordinates[j]] = GiNaC::numeric(-0.211 + 0.053 * jj);
    points[2][dynamics.velocities[j]] = GiNaC::numeric(0.177 + 0.029 * jj);
  }
  return points;
}

// True when `coefficient` (normal form) vanishes at every decision point within
// kZeroCoefficientTolerance of the size of its numerator's terms.
bool VanishesAtDecisionPoints(const ex& coefficient, const std::vector<GiNaC::exmap>& points) {
  const ex numerator = GiNaC::numer(coefficient).expand();
  if (numerator.is_zero()) return true;
  // The size a term would have if no sine or cosine in it were (numerically) zero.
  const GiNaC::lst unit_trigonometry{GiNaC::sin(GiNaC::wild()) == 1,
                                     GiNaC::cos(GiNaC::wild()) == 1};
  ex scale = 0;
  if (GiNaC::is_a<GiNaC::add>(numerator)) {
    for (const ex& term : numerator) scale += GiNaC::abs(term.subs(unit_trigonometry));
  } else {
    scale = GiNaC::abs(numerator.subs(unit_trigonometry));
  }
  bool decided = false;
  for (const GiNaC::exmap& point : points) {
    const std::optional<double> value = ValueAt(numerator, point);
    const std::optional<double> size = ValueAt(scale, point);
    if (!value || !size) continue;
    decided = true;
    if (std::abs(*value) > kZeroCoefficientTolerance * *size) return false;
  }
  return decided;
}

// One output differentiated until the inputs appear: state_functions[k] = y_i^(k) along the
// motion for k < r_i (u-free), and y_i^(r_i) = drift + sum_k u_k input_coefficients[k].
struct OutputChain {
  std::vector<ex> state_functions;
  TimeDerivative last;
  std::set<std::size_t> pinned_parameters;  // in a u-coefficient dropped as zero
};

OutputChain DifferentiateUntilInputsAppear(std::size_t output,
                                           const Dynamics& dynamics,
                                           const std::vector<GiNaC::exmap>& points) {
  const int max_order = 2 * static_cast<int>(dynamics.coordinates.size());
  OutputChain chain;
  ex state_function = dynamics.outputs[output];
  for (int order = 1; order <= max_order; ++order) {
    chain.state_functions.push_back(state_function);
    TimeDerivative derivative = Differentiate(state_function, dynamics);
    bool inputs_appear = false;
    for (const ex& coefficient : derivative.input_coefficients) {
      if (coefficient.is_zero()) continue;
      if (!VanishesAtDecisionPoints(coefficient, points)) {
        inputs_appear = true;
        break;
      }
    }
    if (inputs_appear) {
      chain.last = std::move(derivative);
      return chain;
    }
    // Coefficients that are zero only numerically are dropped: the derivation then holds for
    // the nominal values of the parameters in them, which Evaluate() insists on.
    for (const ex& coefficient : derivative.input_coefficients) {
      for (std::size_t p = 0; p < dynamics.parameters.size(); ++p) {
        if (coefficient.has(dynamics.parameters[p])) chain.pinned_parameters.insert(p);
      }
    }
    state_function = derivative.drift;
  }
  throw NoSolution("algebraic inversion: output " + OutputName(output) +
                   " never depends on the inputs (checked up to its derivative of order " +
                   std::to_string(max_order) + " = 2 dof), so it cannot be tracked");
}

// 1 / the largest |entry| of each row and then of each column of the scaled matrix (1 for a
// zero row or column): the units in which the matrix is judged singular.
std::pair<Eigen::VectorXd, Eigen::VectorXd> EquilibrationScales(const Eigen::MatrixXd& matrix) {
  Eigen::VectorXd row_scale(matrix.rows()), column_scale(matrix.cols());
  for (Eigen::Index i = 0; i < matrix.rows(); ++i) {
    const double largest = matrix.row(i).cwiseAbs().maxCoeff();
    row_scale[i] = largest > 0 ? 1 / largest : 1;
  }
  const Eigen::MatrixXd rows_scaled = row_scale.asDiagonal() * matrix;
  for (Eigen::Index j = 0; j < matrix.cols(); ++j) {
    const double largest = rows_scaled.col(j).cwiseAbs().maxCoeff();
    column_scale[j] = largest > 0 ? 1 / largest : 1;
  }
  return {row_scale, column_scale};
}

// Full-pivoting LU of D_row A D_column.
Eigen::FullPivLU<Eigen::MatrixXd> ScaledLu(const Eigen::MatrixXd& matrix,
                                           const Eigen::VectorXd& row_scale,
                                           const Eigen::VectorXd& column_scale) {
  return Eigen::FullPivLU<Eigen::MatrixXd>(row_scale.asDiagonal() * matrix *
                                           column_scale.asDiagonal());
}

// The number of pivots of `lu` that count as non-zero (kSingularPivotTolerance).
Eigen::Index RegularRank(const Eigen::FullPivLU<Eigen::MatrixXd>& lu) {
  const Eigen::VectorXd pivots = lu.matrixLU().diagonal().cwiseAbs();
  if (pivots.size() == 0) return 0;
  const double threshold = kSingularPivotTolerance * std::max(1.0, pivots.maxCoeff());
  return (pivots.array() > threshold).count();
}

bool IsRegular(const Eigen::FullPivLU<Eigen::MatrixXd>& lu) { return RegularRank(lu) == lu.rows(); }

// Solves A x = b through ScaledLu; false when A is singular or the answer is not finite.
bool SolveScaled(const Eigen::MatrixXd& matrix,
                 const Eigen::VectorXd& row_scale,
                 const Eigen::VectorXd& column_scale,
                 const Eigen::VectorXd& right_hand_side,
                 Eigen::VectorXd& solution) {
  const Eigen::FullPivLU<Eigen::MatrixXd> lu = ScaledLu(matrix, row_scale, column_scale);
  if (!IsRegular(lu)) return false;
  solution = column_scale.asDiagonal() *
             Eigen::VectorXd(lu.solve(Eigen::VectorXd(row_scale.asDiagonal() * right_hand_side)));
  return solution.allFinite();
}

std::string FormatVector(const Eigen::VectorXd& vector) {
  std::ostringstream text;
  text.precision(6);
  text << "[";
  for (Eigen::Index i = 0; i < vector.size(); ++i) text << (i ? ", " : "") << vector[i];
  text << "]";
  return text.str();
}

// "q = [...], q_dot = [...]" for x = (q, q_dot), for messages.
std::string StateText(const Eigen::VectorXd& x) {
  const Eigen::Index dof = x.size() / 2;
  return "q = " + FormatVector(x.head(dof)) + ", q_dot = " + FormatVector(x.tail(dof));
}

// The symbolic results the constructor hands on to the compiler and the closed forms.
struct Derivation {
  Dynamics dynamics;
  std::vector<OutputChain> chains;
  std::vector<int> orders;
};

// The 2 dof state constraints phi_ik(q, q_dot) = y_i_d^(k), k < r_i, output by output, and
// their Jacobian by x = (q, q_dot), row-major.
struct StateConstraints {
  std::vector<ex> values, jacobian;
  std::vector<std::size_t> output;  // for each row: which output
  std::vector<int> order;           // and which derivative of y_d it matches
};

StateConstraints CollectStateConstraints(const Derivation& derivation) {
  StateConstraints constraints;
  for (std::size_t i = 0; i < derivation.chains.size(); ++i) {
    const std::vector<ex>& functions = derivation.chains[i].state_functions;
    for (std::size_t k = 0; k < functions.size(); ++k) {
      constraints.values.push_back(functions[k]);
      constraints.output.push_back(i);
      constraints.order.push_back(static_cast<int>(k));
    }
  }
  const Dynamics& dynamics = derivation.dynamics;
  for (const ex& value : constraints.values) {
    for (const auto& q : dynamics.coordinates) constraints.jacobian.push_back(value.diff(q));
    for (const auto& v : dynamics.velocities) constraints.jacobian.push_back(value.diff(v));
  }
  return constraints;
}

// The u-coefficient matrix (row i: output i at order r_i), row-major, then the u-free part
// of each y_i^(r_i).
std::vector<ex> InputEquations(const Derivation& derivation) {
  std::vector<ex> equations;
  for (const OutputChain& chain : derivation.chains) {
    equations.insert(equations.end(), chain.last.input_coefficients.begin(),
                     chain.last.input_coefficients.end());
  }
  for (const OutputChain& chain : derivation.chains) equations.push_back(chain.last.drift);
  return equations;
}

// Rows x cols outputs of `program` from `offset` on, row-major, at `inputs`.
Eigen::MatrixXd EvaluateMatrix(const ExpressionProgram& program,
                               const std::vector<double>& inputs,
                               Eigen::Index rows,
                               Eigen::Index cols,
                               std::size_t offset) {
  std::vector<double> registers(program.num_registers()), outputs(program.num_outputs());
  program.Evaluate(inputs.data(), registers.data(), outputs.data());
  Eigen::MatrixXd matrix(rows, cols);
  for (Eigen::Index i = 0; i < rows; ++i) {
    for (Eigen::Index j = 0; j < cols; ++j) {
      matrix(i, j) = outputs[offset + static_cast<std::size_t>(i * cols + j)];
    }
  }
  return matrix;
}

// Throws NoSolution unless the u-coefficient matrix at the nominal point is regular.
void RequireRegularCoefficients(const Eigen::MatrixXd& coefficients,
                                const Eigen::VectorXd& row_scale,
                                const Eigen::VectorXd& column_scale,
                                const std::vector<int>& orders) {
  const std::string which =
      "the inputs' coefficients in the outputs' derivatives of order " + JoinOrders(orders);
  if (!coefficients.allFinite()) {
    throw NoSolution("algebraic inversion: " + which + " are not finite at q = 0");
  }
  const Eigen::FullPivLU<Eigen::MatrixXd> lu = ScaledLu(coefficients, row_scale, column_scale);
  if (IsRegular(lu)) return;
  throw NoSolution(
      "algebraic inversion: " + which + " form a singular matrix at q = 0 (rank " +
      std::to_string(RegularRank(lu)) + " of " + std::to_string(coefficients.rows()) +
      "): the outputs have no vector relative degree there, so u does not follow from them "
      "algebraically (if the system is flat, as the gantry crane with the load position as "
      "output is, only a dynamic extension would invert it)");
}

// Throws NoSolution unless the relative degrees add up to 2 dof (paper Sect. 2.4: r = n), or,
// with internal dynamics allowed, to at most 2 dof.
void RequireOrders(const std::vector<int>& orders, std::size_t dof, bool internal_dynamics) {
  int order_sum = 0;
  for (int order : orders) order_sum += order;
  const int states = 2 * static_cast<int>(dof);
  if (order_sum < states && !internal_dynamics) {
    const std::string degrees = orders.size() == 1
                                    ? "the output's relative degree is " + std::to_string(order_sum)
                                    : "the outputs' relative degrees " + JoinOrders(orders) +
                                          " add up to " + std::to_string(order_sum);
    throw NoSolution("algebraic inversion needs a flat problem: " + degrees +
                     ", not 2 dof = " + std::to_string(states) + " (internal dynamics of order " +
                     std::to_string(states - order_sum) + " remain)");
  }
  if (order_sum > states) {  // excluded by a regular u-coefficient matrix; kept as a guard
    throw NoSolution("algebraic inversion: the outputs' relative degrees " + JoinOrders(orders) +
                     " add up to " + std::to_string(order_sum) + ", more than the 2 dof = " +
                     std::to_string(states) + " states they would fix");
  }
}

// W: an orthonormal basis of the null space of the constraints' Jacobian at the reference
// state (its last right singular vectors), which completes the constraints to a chart of the
// state; none when they fix the state alone. A Jacobian of lower row rank leaves the null space
// too large, and [J; W^T] singular: RequireStateFixed() then refuses.
Eigen::MatrixXd InternalDirections(const Eigen::MatrixXd& jacobian) {
  const Eigen::Index states = jacobian.cols();
  const Eigen::Index internal = states - jacobian.rows();
  if (internal == 0) return Eigen::MatrixXd(states, 0);
  if (jacobian.rows() == 0) return Eigen::MatrixXd::Identity(states, states);
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(jacobian, Eigen::ComputeFullV);
  return svd.matrixV().rightCols(internal);
}

// Throws NoSolution unless the constraints' Jacobian at the nominal point is regular.
void RequireStateFixed(const Eigen::MatrixXd& newton_matrix,
                       const Eigen::VectorXd& row_scale,
                       const Eigen::VectorXd& column_scale) {
  if (newton_matrix.allFinite() && IsRegular(ScaledLu(newton_matrix, row_scale, column_scale))) {
    return;
  }
  throw NoSolution(
      "algebraic inversion: the outputs and their derivatives do not fix the state at q = 0 "
      "(the Jacobian of the constraints is singular there)");
}

// Y[i][k] for y_i_d^(k), k = 0..r_i, named "y<i+1>_d" and k primes.
std::vector<std::vector<GiNaC::realsymbol>> DerivativeSymbols(const std::vector<int>& orders) {
  std::vector<std::vector<GiNaC::realsymbol>> symbols(orders.size());
  for (std::size_t i = 0; i < orders.size(); ++i) {
    std::string name = OutputName(i) + "_d";
    for (int k = 0; k <= orders[i]; ++k, name += "'") symbols[i].emplace_back(name);
  }
  return symbols;
}

// u_d in closed form when every state constraint is affine in (q, q_dot): solve them for the
// state, substitute into the order-r_i equations and solve those for u. Empty otherwise.
std::vector<ex> ClosedForms(const Derivation& derivation,
                            const StateConstraints& constraints,
                            const std::vector<std::vector<GiNaC::realsymbol>>& symbols) {
  const Dynamics& dynamics = derivation.dynamics;
  GiNaC::lst state;
  for (const auto& q : dynamics.coordinates) state.append(q);
  for (const auto& v : dynamics.velocities) state.append(v);
  for (const ex& entry : constraints.jacobian) {
    for (const ex& variable : state) {
      if (entry.has(variable)) return {};
    }
  }
  GiNaC::lst equations;
  for (std::size_t row = 0; row < constraints.values.size(); ++row) {
    const auto order = static_cast<std::size_t>(constraints.order[row]);
    equations.append(constraints.values[row] == symbols[constraints.output[row]][order]);
  }
  const ex solution = GiNaC::lsolve(equations, state);
  if (solution.nops() != state.nops()) return {};
  GiNaC::exmap state_values;
  for (const ex& equation : solution) state_values[equation.lhs()] = equation.rhs();

  const auto m = static_cast<unsigned>(derivation.chains.size());
  GiNaC::matrix coefficients(m, m), right_hand_side(m, 1);
  GiNaC::lst all_symbols;
  for (unsigned i = 0; i < m; ++i) {
    const OutputChain& chain = derivation.chains[i];
    for (unsigned j = 0; j < m; ++j) {
      coefficients(i, j) = GiNaC::normal(chain.last.input_coefficients[j].subs(state_values));
    }
    right_hand_side(i, 0) = symbols[i][static_cast<std::size_t>(derivation.orders[i])] -
                            chain.last.drift.subs(state_values);
    for (const auto& symbol : symbols[i]) all_symbols.append(symbol);
  }
  const GiNaC::matrix inputs = coefficients.inverse().mul(right_hand_side);
  std::vector<ex> formulas;
  for (unsigned j = 0; j < m; ++j) {
    formulas.push_back(GiNaC::normal(inputs(j, 0)).expand().collect(all_symbols, true));
  }
  return formulas;
}

}  // namespace

// The compiled inverse and its numerics. Both programs read [parameters, q, q_dot]
// (SymbolicModel::ProgramInputs); x = (q, q_dot) is Newton's unknown.
struct AlgebraicInverse::Programs {
  std::size_t dof = 0, num_inputs = 0, num_parameters = 0;
  // The state constraints' values, then their Jacobian, row-major (StateConstraints).
  ExpressionProgram constraints;
  // InputEquations(): y_i_d^(r_i) = coefficients u + drift.
  ExpressionProgram input_equations;
  std::vector<std::size_t> constraint_output;
  std::vector<int> constraint_order;
  // W: z = W^T x are the internal coordinates (2 dof x internal order; no columns when flat).
  Eigen::MatrixXd internal_directions;
  // Units in which Newton's matrix [constraint Jacobian; W^T] and the u-coefficient matrix are
  // judged singular: their equilibration at the reference state.
  Eigen::VectorXd jacobian_row_scale, jacobian_column_scale;
  Eigen::VectorXd coefficient_row_scale, coefficient_column_scale;
  // Parameters whose nominal value the derivation relies on (substituted because they are 0,
  // or in a u-coefficient dropped as zero): index and value.
  std::vector<std::pair<std::size_t, double>> pinned;
  std::vector<std::string> parameter_names;

  // Per-call scratch: the programs' inputs, registers and outputs (local to one Evaluate()).
  struct Scratch {
    std::vector<double> inputs, registers, outputs;
  };
  Scratch MakeScratch(const Eigen::VectorXd& parameters) const;

  // Throws UsageError when a pinned parameter differs from its nominal value.
  void CheckPinned(const Eigen::VectorXd& parameters) const;
  // Newton's method on the constraints (and W^T x = internal, when there are internal
  // coordinates) for x from its starting value; false and `why` when it fails.
  bool SolveState(const Eigen::MatrixXd& output_derivatives,
                  const Eigen::VectorXd& internal,
                  Scratch& scratch,
                  Eigen::VectorXd& x,
                  std::string& why) const;
  // u from the order-r_i equations at x; false and `why` when their matrix is singular.
  bool SolveInputs(const Eigen::MatrixXd& output_derivatives,
                   const std::vector<int>& orders,
                   Scratch& scratch,
                   const Eigen::VectorXd& x,
                   Eigen::VectorXd& u,
                   std::string& why) const;
};

AlgebraicInverse::AlgebraicInverse(const Model& model, const AlgebraicInverseOptions& options) {
  assert(model.num_outputs() == model.num_inputs());  // the loader insists
  if (options.reference_q.size() != 0 &&
      options.reference_q.size() != static_cast<Eigen::Index>(model.dof())) {
    throw UsageError("AlgebraicInverseOptions::reference_q has " +
                     std::to_string(options.reference_q.size()) + " values, the model " +
                     std::to_string(model.dof()) + " coordinates");
  }
  try {
    Derivation derivation;
    derivation.dynamics = BuildDynamics(model);
    const std::vector<GiNaC::exmap> points =
        DecisionPoints(derivation.dynamics, model.parameters());
    for (std::size_t i = 0; i < model.num_outputs(); ++i) {
      derivation.chains.push_back(DifferentiateUntilInputsAppear(i, derivation.dynamics, points));
      derivation.orders.push_back(
          static_cast<int>(derivation.chains.back().state_functions.size()));
    }
    orders_ = derivation.orders;

    auto programs = std::make_unique<Programs>();
    programs->dof = model.dof();
    programs->num_inputs = model.num_inputs();
    programs->num_parameters = model.num_parameters();
    programs->parameter_names = model.parameter_names();
    const std::vector<ex> program_inputs = model.symbolic().ProgramInputs();
    // The reference state: q as given (default 0), q_dot = 0.
    std::vector<double> nominal_inputs(program_inputs.size(), 0.0);
    std::copy(model.parameters().begin(), model.parameters().end(), nominal_inputs.begin());
    std::copy(options.reference_q.begin(), options.reference_q.end(),
              nominal_inputs.begin() + static_cast<long>(model.num_parameters()));

    // The u-equations first: their matrix decides whether the outputs fix u at all.
    programs->input_equations = CompileExpressions(InputEquations(derivation), program_inputs);
    const auto m = static_cast<Eigen::Index>(model.num_inputs());
    const Eigen::MatrixXd nominal_coefficients =
        EvaluateMatrix(programs->input_equations, nominal_inputs, m, m, 0);
    std::tie(programs->coefficient_row_scale, programs->coefficient_column_scale) =
        EquilibrationScales(nominal_coefficients);
    RequireRegularCoefficients(nominal_coefficients, programs->coefficient_row_scale,
                               programs->coefficient_column_scale, orders_);
    RequireOrders(orders_, model.dof(), options.internal_dynamics);

    const StateConstraints constraints = CollectStateConstraints(derivation);
    std::vector<ex> constraint_outputs = constraints.values;
    constraint_outputs.insert(constraint_outputs.end(), constraints.jacobian.begin(),
                              constraints.jacobian.end());
    programs->constraints = CompileExpressions(constraint_outputs, program_inputs);
    programs->constraint_output = constraints.output;
    programs->constraint_order = constraints.order;
    const auto states = static_cast<Eigen::Index>(2 * model.dof());
    const auto rows = static_cast<Eigen::Index>(constraints.values.size());
    const Eigen::MatrixXd nominal_jacobian = EvaluateMatrix(
        programs->constraints, nominal_inputs, rows, states, static_cast<std::size_t>(rows));
    programs->internal_directions = InternalDirections(nominal_jacobian);
    Eigen::MatrixXd newton_matrix(states, states);
    newton_matrix << nominal_jacobian, programs->internal_directions.transpose();
    std::tie(programs->jacobian_row_scale, programs->jacobian_column_scale) =
        EquilibrationScales(newton_matrix);
    RequireStateFixed(newton_matrix, programs->jacobian_row_scale,
                      programs->jacobian_column_scale);

    std::set<std::size_t> pinned(derivation.dynamics.zero_parameters.begin(),
                                 derivation.dynamics.zero_parameters.end());
    for (const OutputChain& chain : derivation.chains) {
      pinned.insert(chain.pinned_parameters.begin(), chain.pinned_parameters.end());
    }
    for (std::size_t p : pinned) {
      programs->pinned.emplace_back(p, model.parameters()[static_cast<Eigen::Index>(p)]);
    }

    derivative_symbols_ = DerivativeSymbols(orders_);
    if (rows == states) input_formulas_ = ClosedForms(derivation, constraints, derivative_symbols_);
    programs_ = std::move(programs);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& error) {
    // GiNaC (a pole while substituting, a singular symbolic inverse) or the compiler (an
    // unsupported construct): the inverse cannot be derived for this model.
    throw NoSolution(std::string("algebraic inversion: the symbolic derivation failed: ") +
                     error.what());
  }
}

AlgebraicInverse::~AlgebraicInverse() = default;
AlgebraicInverse::AlgebraicInverse(AlgebraicInverse&&) noexcept = default;
AlgebraicInverse& AlgebraicInverse::operator=(AlgebraicInverse&&) noexcept = default;

int AlgebraicInverse::highest_output_derivative() const {
  return orders_.empty() ? 0 : *std::max_element(orders_.begin(), orders_.end());
}

const GiNaC::realsymbol& AlgebraicInverse::output_derivative_symbol(std::size_t output,
                                                                    int order) const {
  if (output >= derivative_symbols_.size() || order < 0 ||
      static_cast<std::size_t>(order) >= derivative_symbols_[output].size()) {
    throw std::out_of_range("AlgebraicInverse::output_derivative_symbol: no derivative " +
                            std::to_string(order) + " of output " + std::to_string(output));
  }
  return derivative_symbols_[output][static_cast<std::size_t>(order)];
}

AlgebraicInverse::Programs::Scratch AlgebraicInverse::Programs::MakeScratch(
    const Eigen::VectorXd& parameters) const {
  Scratch scratch;
  scratch.inputs.assign(num_parameters + 2 * dof, 0.0);
  std::copy(parameters.begin(), parameters.end(), scratch.inputs.begin());
  scratch.registers.resize(std::max(constraints.num_registers(), input_equations.num_registers()));
  scratch.outputs.resize(std::max(constraints.num_outputs(), input_equations.num_outputs()));
  return scratch;
}

void AlgebraicInverse::Programs::CheckPinned(const Eigen::VectorXd& parameters) const {
  for (const auto& [index, value] : pinned) {
    const double given = parameters[static_cast<Eigen::Index>(index)];
    if (std::abs(given - value) <= kPinnedParameterTolerance * std::abs(value)) continue;
    std::ostringstream text;
    text.precision(17);
    text << "AlgebraicInverse::Evaluate: parameter " << parameter_names[index] << " = " << given
         << ", but the inverse was derived for " << value
         << " (its structure depends on it); derive it again for the new value";
    throw UsageError(text.str());
  }
}

bool AlgebraicInverse::Programs::SolveState(const Eigen::MatrixXd& output_derivatives,
                                            const Eigen::VectorXd& internal,
                                            Scratch& scratch,
                                            Eigen::VectorXd& x,
                                            std::string& why) const {
  const Eigen::Index states = x.size();
  const auto constraint_rows = static_cast<Eigen::Index>(constraint_output.size());
  const Eigen::Index internal_rows = internal_directions.cols();
  Eigen::VectorXd residual(states), step(states);
  Eigen::MatrixXd jacobian(states, states);
  if (internal_rows > 0) jacobian.bottomRows(internal_rows) = internal_directions.transpose();
  double worst = 0;  // largest residual relative to the size of its terms
  bool last_step_at_round_off = false;
  double previous_worst = std::numeric_limits<double>::infinity();
  for (int iteration = 0;; ++iteration) {
    std::copy(x.begin(), x.end(), scratch.inputs.begin() + static_cast<long>(num_parameters));
    constraints.Evaluate(scratch.inputs.data(), scratch.registers.data(), scratch.outputs.data());
    for (Eigen::Index r = 0; r < constraint_rows; ++r) {
      for (Eigen::Index c = 0; c < states; ++c) {
        jacobian(r, c) =
            scratch.outputs[static_cast<std::size_t>(constraint_rows + r * states + c)];
      }
    }
    worst = 0;
    const double state_size = x.cwiseAbs().maxCoeff();
    for (Eigen::Index r = 0; r < states; ++r) {
      const auto row = static_cast<std::size_t>(r);
      const bool constraint = r < constraint_rows;
      const double target =
          constraint ? output_derivatives(static_cast<Eigen::Index>(constraint_output[row]),
                                          constraint_order[row])
                     : internal[r - constraint_rows];
      const double value = constraint
                               ? scratch.outputs[row]
                               : internal_directions.col(r - constraint_rows).dot(x);
      residual[r] = value - target;
      // Each coefficient counts with the size of the whole state, not just its own entry:
      // near rest the entries vanish while round-off of the others does not.
      const double size = std::abs(target) + std::abs(value) +
                          jacobian.row(r).cwiseAbs().sum() * state_size;
      if (!std::isfinite(residual[r]) || !std::isfinite(size)) {
        why = "the output constraints are not finite at " + StateText(x);
        return false;
      }
      if (size > 0) worst = std::max(worst, std::abs(residual[r]) / size);
    }
    // Also converged when the last correction was at round-off of x: a residual whose terms
    // are all tiny (a state near rest) cannot get below round-off of the others' sizes.
    // And when the residual stagnates at a level that is round-off for a badly conditioned
    // constraint Jacobian (the six-mass chain's is ~1e10): a further step would only stir it.
    const bool stagnated = iteration >= 2 && worst >= 0.5 * previous_worst &&
                           worst <= kStagnationTolerance;
    if (worst <= kNewtonTolerance || last_step_at_round_off || stagnated) return true;
    previous_worst = worst;
    if (iteration == kMaxNewtonIterations) break;
    if (!jacobian.allFinite() ||
        !SolveScaled(jacobian, jacobian_row_scale, jacobian_column_scale, residual, step)) {
      why = "the Jacobian of the output constraints is singular at " + StateText(x);
      return false;
    }
    x -= step;
    last_step_at_round_off = step.cwiseAbs().maxCoeff() <=
                             kRoundOffSteps * std::numeric_limits<double>::epsilon() *
                                 (1.0 + x.cwiseAbs().maxCoeff());
  }
  std::ostringstream text;
  text.precision(3);
  text << "Newton's method on the output constraints did not converge in " << kMaxNewtonIterations
       << " iterations (largest relative residual " << worst << ")";
  why = text.str();
  return false;
}

bool AlgebraicInverse::Programs::SolveInputs(const Eigen::MatrixXd& output_derivatives,
                                             const std::vector<int>& orders,
                                             Scratch& scratch,
                                             const Eigen::VectorXd& x,
                                             Eigen::VectorXd& u,
                                             std::string& why) const {
  std::copy(x.begin(), x.end(), scratch.inputs.begin() + static_cast<long>(num_parameters));
  input_equations.Evaluate(scratch.inputs.data(), scratch.registers.data(), scratch.outputs.data());
  const auto m = static_cast<Eigen::Index>(num_inputs);
  Eigen::MatrixXd coefficients(m, m);
  Eigen::VectorXd right_hand_side(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) {
      coefficients(i, j) = scratch.outputs[static_cast<std::size_t>(i * m + j)];
    }
    right_hand_side[i] = output_derivatives(i, orders[static_cast<std::size_t>(i)]) -
                         scratch.outputs[static_cast<std::size_t>(m * m + i)];
  }
  if (!coefficients.allFinite() || !right_hand_side.allFinite() ||
      !SolveScaled(coefficients, coefficient_row_scale, coefficient_column_scale, right_hand_side,
                   u)) {
    why = "the inputs' coefficient matrix is singular at " + StateText(x);
    return false;
  }
  return true;
}

Eigen::Index AlgebraicInverse::internal_order() const {
  return programs_->internal_directions.cols();
}

const Eigen::MatrixXd& AlgebraicInverse::internal_directions() const {
  return programs_->internal_directions;
}

bool AlgebraicInverse::Evaluate(const Eigen::MatrixXd& output_derivatives,
                                const Eigen::VectorXd& parameters,
                                Eigen::VectorXd& q,
                                Eigen::VectorXd& q_dot,
                                Eigen::VectorXd& u,
                                std::string& why) const {
  if (internal_order() > 0) {
    throw UsageError("AlgebraicInverse::Evaluate: " + std::to_string(internal_order()) +
                     " internal coordinates remain; use EvaluateWithInternal");
  }
  return EvaluateWithInternal(output_derivatives, Eigen::VectorXd(), parameters, q, q_dot, u,
                              why);
}

bool AlgebraicInverse::EvaluateWithInternal(const Eigen::MatrixXd& output_derivatives,
                                            const Eigen::VectorXd& internal,
                                            const Eigen::VectorXd& parameters,
                                            Eigen::VectorXd& q,
                                            Eigen::VectorXd& q_dot,
                                            Eigen::VectorXd& u,
                                            std::string& why) const {
  const Programs& programs = *programs_;
  const auto dof = static_cast<Eigen::Index>(programs.dof);
  const auto m = static_cast<Eigen::Index>(programs.num_inputs);
  const auto num_parameters = static_cast<Eigen::Index>(programs.num_parameters);
  const auto check_size = [](const char* what, Eigen::Index rows, Eigen::Index cols,
                             Eigen::Index want_rows, Eigen::Index want_cols) {
    if (rows == want_rows && cols == want_cols) return;
    throw UsageError(std::string("AlgebraicInverse::Evaluate: ") + what + " is " +
                     std::to_string(rows) + " x " + std::to_string(cols) + ", expected " +
                     std::to_string(want_rows) + " x " + std::to_string(want_cols));
  };
  check_size("output_derivatives", output_derivatives.rows(), output_derivatives.cols(), m,
             highest_output_derivative() + 1);
  check_size("internal", internal.size(), 1, internal_order(), 1);
  check_size("parameters", parameters.size(), 1, num_parameters, 1);
  check_size("q", q.size(), 1, dof, 1);
  check_size("q_dot", q_dot.size(), 1, dof, 1);
  programs.CheckPinned(parameters);

  Programs::Scratch scratch = programs.MakeScratch(parameters);
  Eigen::VectorXd x(2 * dof), inputs;
  x << q, q_dot;
  if (!programs.SolveState(output_derivatives, internal, scratch, x, why) ||
      !programs.SolveInputs(output_derivatives, orders_, scratch, x, inputs, why)) {
    return false;
  }
  q = x.head(dof);
  q_dot = x.tail(dof);
  u = inputs;
  why.clear();
  return true;
}

}  // namespace servokit
