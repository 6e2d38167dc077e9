#include "solvers/algebraic_inversion.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "analysis/nonlinear_structure.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "base/vocabulary.h"
#include "modeling/canonical_expression.h"
#include "modeling/expression_program.h"
#include "modeling/symbolic_model.h"

namespace servokit {
namespace {

using GiNaC::ex;

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

std::string JoinOrders(const std::vector<int>& orders) {
  std::string text;
  for (std::size_t i = 0; i < orders.size(); ++i) {
    text += (i ? ", " : "") + std::to_string(orders[i]);
  }
  return orders.size() == 1 ? text : "(" + text + ")";
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

// Solves A x = b through the LU of D_row A D_column, factored into `lu` (kept by the caller,
// so that no call allocates once it has the size); false when A is singular or the answer is
// not finite.
bool SolveScaledInto(const Eigen::MatrixXd& matrix,
                     const Eigen::VectorXd& row_scale,
                     const Eigen::VectorXd& column_scale,
                     const Eigen::VectorXd& right_hand_side,
                     Eigen::FullPivLU<Eigen::MatrixXd>& lu,
                     Eigen::VectorXd& solution) {
  lu.compute(row_scale.asDiagonal() * matrix * column_scale.asDiagonal());
  if (!IsRegular(lu)) return false;
  solution = column_scale.asDiagonal() * lu.solve(row_scale.asDiagonal() * right_hand_side);
  return solution.allFinite();
}

// "q = [...], q_dot = [...]" for x = (q, q_dot), for messages, to 6 digits.
std::string StateText(const Eigen::VectorXd& x) {
  const Eigen::Index dof = x.size() / 2;
  return "q = " + FormatList(x.head(dof), 6) + ", q_dot = " + FormatList(x.tail(dof), 6);
}

// The compiled programs' outputs: the constraints' values, their Jacobian by x = (q, q_dot)
// and by Y (row-major), for Newton and for the size of each residual's terms.
std::vector<ex> ConstraintPrograms(const NonlinearStructure& structure) {
  std::vector<ex> outputs = structure.constraints;
  for (const ex& value : structure.constraints) {
    for (const auto& q : structure.coordinates) outputs.push_back(value.diff(q));
    for (const auto& v : structure.velocities) outputs.push_back(value.diff(v));
  }
  for (const ex& value : structure.constraints) {
    for (const auto& symbols : structure.output_derivatives) {
      for (const auto& symbol : symbols) outputs.push_back(value.diff(symbol));
    }
  }
  return outputs;
}

// The u-coefficient matrix (row i: input equation i), row-major, then the u-free part of each
// input equation, 0 = drift + coefficients u.
std::vector<ex> InputEquations(const NonlinearStructure& structure) {
  std::vector<ex> equations;
  for (const auto& row : structure.input_coefficients) {
    equations.insert(equations.end(), row.begin(), row.end());
  }
  equations.insert(equations.end(), structure.input_drift.begin(), structure.input_drift.end());
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

// Throws NoSolution unless the u-coefficient matrix at the reference state is regular. It is
// regular on a neighbourhood (the structure algorithm saw to that), so a singular one here is
// singular at the reference only.
void RequireRegularCoefficients(const Eigen::MatrixXd& coefficients,
                                const Eigen::VectorXd& row_scale,
                                const Eigen::VectorXd& column_scale,
                                const std::vector<int>& orders) {
  const std::string which =
      "the inputs' coefficients in the input equations (outputs read to "
      "order " +
      JoinOrders(orders) + ")";
  if (!coefficients.allFinite()) {
    throw NoSolution("algebraic inversion: " + which + " are not finite at the reference state");
  }
  const Eigen::FullPivLU<Eigen::MatrixXd> lu = ScaledLu(coefficients, row_scale, column_scale);
  if (IsRegular(lu)) return;
  throw UndefinedRelativeDegree(
      "algebraic inversion: " + which + " form a singular matrix at the reference state (rank " +
      std::to_string(RegularRank(lu)) + " of " + std::to_string(coefficients.rows()) +
      ") but not near it: the relative degree is not defined at the operating point, and no "
      "exact inverse passes through it");
}

// Throws NoSolution unless the relative degrees add up to 2 dof (paper Sect. 2.4: r = n), or,
// with internal dynamics allowed, to at most 2 dof.
void RequireOrders(const NonlinearStructure& structure, bool internal_dynamics) {
  const std::size_t states = 2 * structure.coordinates.size();
  const std::size_t constraints = structure.constraints.size();
  if (constraints < states && !internal_dynamics) {
    const std::vector<int>& orders = structure.relative_degree;
    std::string degrees;
    if (structure.extended()) {
      degrees = "after a dynamic extension (relative degrees " +
                JoinOrders(structure.highest_derivative) + ") the outputs fix " +
                std::to_string(constraints) + " of the " + std::to_string(states) + " states";
    } else if (orders.size() == 1) {
      degrees = "the output's relative degree is " + std::to_string(orders[0]) +
                ", not 2 dof = " + std::to_string(states);
    } else {
      degrees = "the outputs' relative degrees " + JoinOrders(orders) + " add up to " +
                std::to_string(constraints) + ", not 2 dof = " + std::to_string(states);
    }
    throw NoSolution("algebraic inversion needs a flat problem: " + degrees +
                     " (internal dynamics of order " + std::to_string(states - constraints) +
                     " remain)");
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

// u_d in closed form when every constraint is affine in (q, q_dot): solve them for the state,
// substitute into the input equations and solve those for u. Empty otherwise.
std::vector<ex> ClosedForms(const NonlinearStructure& structure) {
  GiNaC::lst state;
  for (const auto& q : structure.coordinates) state.append(q);
  for (const auto& v : structure.velocities) state.append(v);
  for (const ex& constraint : structure.constraints) {
    for (const ex& variable : state) {
      const ex slope = constraint.diff(GiNaC::ex_to<GiNaC::symbol>(variable));
      for (const ex& other : state) {
        if (slope.has(other)) return {};
      }
    }
  }
  GiNaC::lst equations;
  for (const ex& constraint : structure.constraints) equations.append(constraint == 0);
  const ex solution = GiNaC::lsolve(equations, state);
  if (solution.nops() != state.nops()) return {};
  GiNaC::exmap state_values;
  for (const ex& equation : solution) state_values[equation.lhs()] = equation.rhs();

  const auto m = static_cast<unsigned>(structure.input_drift.size());
  GiNaC::matrix coefficients(m, m), right_hand_side(m, 1);
  GiNaC::lst all_symbols;
  for (unsigned i = 0; i < m; ++i) {
    for (unsigned j = 0; j < m; ++j) {
      coefficients(i, j) = CanonicalNormal(structure.input_coefficients[i][j].subs(state_values));
    }
    right_hand_side(i, 0) = -structure.input_drift[i].subs(state_values);
    for (const auto& symbol : structure.output_derivatives[i]) all_symbols.append(symbol);
  }
  const GiNaC::matrix inputs = coefficients.inverse().mul(right_hand_side);
  std::vector<ex> formulas;
  for (unsigned j = 0; j < m; ++j) {
    formulas.push_back(CanonicalNormal(inputs(j, 0)).expand().collect(all_symbols, true));
  }
  return formulas;
}

// Throws UsageError unless reference_q is empty (q = 0) or has one value per coordinate.
void RequireReferenceQFits(const Model& model, const AlgebraicInverseOptions& options) {
  if (options.reference_q.size() != 0 &&
      options.reference_q.size() != static_cast<Eigen::Index>(model.dof())) {
    throw UsageError("AlgebraicInverseOptions::reference_q has " +
                     std::to_string(options.reference_q.size()) + " values, the model " +
                     std::to_string(model.dof()) + " coordinates");
  }
}

NonlinearStructureOptions StructureOptions(const AlgebraicInverseOptions& options) {
  NonlinearStructureOptions structure_options;
  structure_options.rank_tolerance = options.rank_tolerance;
  structure_options.reference_q = options.reference_q;
  return structure_options;
}

// The programs' inputs at the reference state: q as given (default 0), q_dot = 0, y_d at rest
// there. `derivative_counts`: how many derivatives of each output the inputs hold.
std::vector<double> NominalProgramInputs(const Model& model,
                                         const Eigen::VectorXd& reference_q,
                                         const std::vector<ex>& program_inputs,
                                         const std::vector<int>& derivative_counts) {
  std::vector<double> nominal_inputs(program_inputs.size(), 0.0);
  std::copy(model.parameters().begin(), model.parameters().end(), nominal_inputs.begin());
  std::copy(reference_q.begin(), reference_q.end(),
            nominal_inputs.begin() + static_cast<long>(model.num_parameters()));
  const GiNaC::matrix& output = model.symbolic().output();
  std::vector<ex> output_expressions;
  for (unsigned i = 0; i < output.rows(); ++i) output_expressions.push_back(output(i, 0));
  const ExpressionProgram outputs = CompileExpressions(output_expressions, program_inputs);
  std::vector<double> registers(outputs.num_registers()), values(outputs.num_outputs());
  outputs.Evaluate(nominal_inputs.data(), registers.data(), values.data());
  std::size_t slot = model.num_parameters() + 2 * model.dof();
  for (std::size_t i = 0; i < values.size(); ++i) {
    nominal_inputs[slot] = values[i];
    slot += static_cast<std::size_t>(derivative_counts[i]);
  }
  return nominal_inputs;
}

// Whether an expression varies along the motion: it reads q, q' or y_d, not only the
// parameters (the programs' first inputs).
bool VariesAlongMotion(const ex& expression,
                       const NonlinearStructure& structure,
                       const std::vector<ex>& program_inputs) {
  for (std::size_t k = structure.parameters.size(); k < program_inputs.size(); ++k) {
    if (expression.has(program_inputs[k])) return true;
  }
  return false;
}

// Whether every constraint is affine in the state with a Jacobian free of y_d (linear models,
// the mass on car at alpha = 0).
bool ConstraintsAffineInState(const NonlinearStructure& structure,
                              const std::vector<ex>& program_inputs) {
  return std::none_of(
      structure.constraints.begin(), structure.constraints.end(), [&](const ex& constraint) {
        for (const auto* symbols : {&structure.coordinates, &structure.velocities}) {
          for (const auto& variable : *symbols) {
            if (VariesAlongMotion(constraint.diff(variable), structure, program_inputs)) {
              return true;
            }
          }
        }
        return false;
      });
}

}  // namespace

// Per-call scratch: the programs' inputs, registers and outputs, Newton's vectors and
// matrices (a Workspace keeps them between calls, so that no call allocates).
struct AlgebraicInverseScratch {
  std::vector<double> inputs, registers, outputs;
  Eigen::VectorXd x, residual, step, scaled, u;
  Eigen::MatrixXd jacobian, coefficients;
  Eigen::VectorXd right_hand_side;
  Eigen::FullPivLU<Eigen::MatrixXd> lu;
  bool constant_matrix = false;        // affine constraints at the nominal parameters
  bool constant_coefficients = false;  // constant u-coefficients at the nominal parameters
  bool singular_inputs = false;        // the last failure: the input equations' matrix
};

// The compiled inverse and its numerics. Both programs read [parameters, q, q_dot, Y]
// (NonlinearStructure::ProgramInputs); x = (q, q_dot) is Newton's unknown.
struct AlgebraicInverse::Programs {
  std::size_t dof = 0, num_inputs = 0, num_parameters = 0;
  // How many derivatives of each output the programs read (highest + 1), in input order.
  std::vector<int> derivative_counts;
  std::size_t num_derivatives = 0;
  // ConstraintPrograms(): values, Jacobian by x, Jacobian by Y; and the values alone.
  ExpressionProgram constraints;
  ExpressionProgram constraint_values;
  std::size_t num_constraints = 0;
  // InputEquations(): 0 = drift + coefficients u.
  ExpressionProgram input_equations;
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
  // Constraints affine in x with a constant Jacobian: Newton's matrix factored once, valid for
  // these parameter values.
  Eigen::VectorXd nominal_parameters;  // the model's at construction
  bool affine = false;
  Eigen::FullPivLU<Eigen::MatrixXd> affine_lu;
  // The same for a u-coefficient matrix free of the state and y_d, valid for the nominal
  // parameters.
  bool constant_coefficients = false;
  Eigen::FullPivLU<Eigen::MatrixXd> coefficient_lu;

  using Scratch = AlgebraicInverseScratch;
  // The sizes of `model` and of the outputs' derivatives in `structure`.
  void SetSizes(const Model& model, const NonlinearStructure& structure);
  // Compiles the input equations and takes their u-coefficient matrix's units at the reference
  // state; returns that matrix. Throws NoSolution where it is singular (`orders`: the outputs'
  // highest derivatives, for the message).
  Eigen::MatrixXd CompileInputEquations(const NonlinearStructure& structure,
                                        const std::vector<ex>& program_inputs,
                                        const std::vector<double>& nominal_inputs,
                                        const std::vector<int>& orders);
  // Compiles the constraints, completes them with the internal directions and takes Newton's
  // matrix's units at the reference state; returns that matrix. Throws NoSolution unless it is
  // regular.
  Eigen::MatrixXd CompileConstraints(const NonlinearStructure& structure,
                                     const std::vector<ex>& program_inputs,
                                     const std::vector<double>& nominal_inputs);
  // Factors once the matrices that stay constant along the motion for the nominal parameters.
  void FactorConstantMatrices(const Model& model,
                              const NonlinearStructure& structure,
                              const std::vector<ex>& program_inputs,
                              const Eigen::MatrixXd& nominal_coefficients,
                              const Eigen::MatrixXd& newton_matrix);
  // Records the parameters the derivation relies on at their nominal values.
  void PinParameters(const Model& model, const NonlinearStructure& structure);
  void PrepareScratch(const Eigen::VectorXd& parameters,
                      const Eigen::MatrixXd& output_derivatives,
                      Scratch& scratch) const;

  // Throws UsageError when a pinned parameter differs from its nominal value.
  void CheckPinned(const Eigen::VectorXd& parameters) const;
  // Newton's method on the constraints (and W^T x = internal, when there are internal
  // coordinates) for x from its starting value; false and `why` when it fails.
  bool SolveState(const Eigen::VectorXd& internal,
                  Scratch& scratch,
                  Eigen::VectorXd& x,
                  std::string& why) const;
  // u from the input equations at x; false and `why` when their matrix is singular.
  bool SolveInputs(Scratch& scratch,
                   const Eigen::VectorXd& x,
                   Eigen::VectorXd& u,
                   std::string& why) const;
};

void AlgebraicInverse::Programs::SetSizes(const Model& model, const NonlinearStructure& structure) {
  dof = model.dof();
  num_inputs = model.num_inputs();
  num_parameters = model.num_parameters();
  parameter_names = model.parameter_names();
  for (const auto& symbols : structure.output_derivatives) {
    derivative_counts.push_back(static_cast<int>(symbols.size()));
    num_derivatives += symbols.size();
  }
}

Eigen::MatrixXd AlgebraicInverse::Programs::CompileInputEquations(
    const NonlinearStructure& structure,
    const std::vector<ex>& program_inputs,
    const std::vector<double>& nominal_inputs,
    const std::vector<int>& orders) {
  input_equations = CompileExpressions(InputEquations(structure), program_inputs);
  const auto m = static_cast<Eigen::Index>(num_inputs);
  const Eigen::MatrixXd nominal_coefficients =
      EvaluateMatrix(input_equations, nominal_inputs, m, m, 0);
  std::tie(coefficient_row_scale, coefficient_column_scale) =
      EquilibrationScales(nominal_coefficients);
  RequireRegularCoefficients(nominal_coefficients, coefficient_row_scale, coefficient_column_scale,
                             orders);
  return nominal_coefficients;
}

Eigen::MatrixXd AlgebraicInverse::Programs::CompileConstraints(
    const NonlinearStructure& structure,
    const std::vector<ex>& program_inputs,
    const std::vector<double>& nominal_inputs) {
  constraints = CompileExpressions(ConstraintPrograms(structure), program_inputs);
  num_constraints = structure.constraints.size();
  const auto states = static_cast<Eigen::Index>(2 * dof);
  const auto rows = static_cast<Eigen::Index>(structure.constraints.size());
  const Eigen::MatrixXd nominal_jacobian =
      EvaluateMatrix(constraints, nominal_inputs, rows, states, static_cast<std::size_t>(rows));
  internal_directions = InternalDirections(nominal_jacobian);
  Eigen::MatrixXd newton_matrix(states, states);
  newton_matrix << nominal_jacobian, internal_directions.transpose();
  std::tie(jacobian_row_scale, jacobian_column_scale) = EquilibrationScales(newton_matrix);
  RequireStateFixed(newton_matrix, jacobian_row_scale, jacobian_column_scale);
  return newton_matrix;
}

void AlgebraicInverse::Programs::FactorConstantMatrices(const Model& model,
                                                        const NonlinearStructure& structure,
                                                        const std::vector<ex>& program_inputs,
                                                        const Eigen::MatrixXd& nominal_coefficients,
                                                        const Eigen::MatrixXd& newton_matrix) {
  // Constraints affine in the state with a Jacobian free of y_d: Newton's matrix is constant
  // for the nominal parameters, so it is factored once here and one step from any start is
  // exact.
  affine = ConstraintsAffineInState(structure, program_inputs);
  nominal_parameters = model.parameters();
  // A u-coefficient matrix free of the state and of y_d is factored once as well.
  const auto m = static_cast<Eigen::Index>(num_inputs);
  const std::vector<ex> equations = InputEquations(structure);
  constant_coefficients =
      std::none_of(equations.begin(), equations.begin() + m * m, [&](const ex& expression) {
        return VariesAlongMotion(expression, structure, program_inputs);
      });
  if (constant_coefficients) {
    coefficient_lu =
        ScaledLu(nominal_coefficients, coefficient_row_scale, coefficient_column_scale);
  }
  if (affine) {
    constraint_values = CompileExpressions(structure.constraints, program_inputs);
    affine_lu = ScaledLu(newton_matrix, jacobian_row_scale, jacobian_column_scale);
  }
}

void AlgebraicInverse::Programs::PinParameters(const Model& model,
                                               const NonlinearStructure& structure) {
  for (std::size_t p : structure.pinned_parameters) {
    pinned.emplace_back(p, model.parameters()[static_cast<Eigen::Index>(p)]);
  }
}

AlgebraicInverse::AlgebraicInverse(const Model& model, const AlgebraicInverseOptions& options) {
  assert(model.num_outputs() == model.num_inputs());  // the loader insists
  RequireReferenceQFits(model, options);
  // Everything symbolic below (the structure, its programs' expressions, the closed forms) is
  // made and destroyed in this scope.
  const SymbolicLock lock;
  try {
    NonlinearStructure structure = DeriveNonlinearStructure(model, StructureOptions(options));
    orders_ = structure.highest_derivative;
    relative_degree_ = structure.relative_degree;
    extension_steps_ = structure.extension_steps;
    integrators_ = structure.integrators();

    auto programs = std::make_unique<Programs>();
    programs->SetSizes(model, structure);
    const std::vector<ex> program_inputs = structure.ProgramInputs();
    const std::vector<double> nominal_inputs = NominalProgramInputs(
        model, options.reference_q, program_inputs, programs->derivative_counts);
    // The input equations first: their matrix decides whether the outputs fix u at all.
    const Eigen::MatrixXd nominal_coefficients =
        programs->CompileInputEquations(structure, program_inputs, nominal_inputs, orders_);
    RequireOrders(structure, options.internal_dynamics);
    const Eigen::MatrixXd newton_matrix =
        programs->CompileConstraints(structure, program_inputs, nominal_inputs);
    programs->FactorConstantMatrices(model, structure, program_inputs, nominal_coefficients,
                                     newton_matrix);
    programs->PinParameters(model, structure);
    auto formulas = SymbolicPtr<Formulas>(new Formulas());
    formulas->derivative_symbols = structure.output_derivatives;
    if (structure.constraints.size() == 2 * model.dof()) {
      formulas->input_formulas = ClosedForms(structure);
    }
    formulas_ = std::move(formulas);
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
  if (output >= formulas_->derivative_symbols.size() || order < 0 ||
      static_cast<std::size_t>(order) >= formulas_->derivative_symbols[output].size()) {
    throw std::out_of_range("AlgebraicInverse::output_derivative_symbol: no derivative " +
                            std::to_string(order) + " of output " + std::to_string(output));
  }
  return formulas_->derivative_symbols[output][static_cast<std::size_t>(order)];
}

void AlgebraicInverse::Programs::PrepareScratch(const Eigen::VectorXd& parameters,
                                                const Eigen::MatrixXd& output_derivatives,
                                                Scratch& scratch) const {
  scratch.inputs.resize(num_parameters + 2 * dof + num_derivatives);
  std::copy(parameters.begin(), parameters.end(), scratch.inputs.begin());
  std::size_t slot = num_parameters + 2 * dof;
  for (std::size_t i = 0; i < derivative_counts.size(); ++i) {
    for (int k = 0; k < derivative_counts[i]; ++k) {
      scratch.inputs[slot++] = output_derivatives(static_cast<Eigen::Index>(i), k);
    }
  }
  scratch.registers.resize(std::max({constraints.num_registers(), input_equations.num_registers(),
                                     constraint_values.num_registers()}));
  scratch.outputs.resize(std::max(
      {constraints.num_outputs(), input_equations.num_outputs(), constraint_values.num_outputs()}));
  scratch.constant_matrix = affine && parameters == nominal_parameters;
  scratch.constant_coefficients = constant_coefficients && parameters == nominal_parameters;
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

bool AlgebraicInverse::Programs::SolveState(const Eigen::VectorXd& internal,
                                            Scratch& scratch,
                                            Eigen::VectorXd& x,
                                            std::string& why) const {
  const Eigen::Index states = x.size();
  const auto constraint_rows = static_cast<Eigen::Index>(num_constraints);
  const Eigen::Index internal_rows = internal_directions.cols();
  const auto derivatives = static_cast<Eigen::Index>(num_derivatives);
  const std::size_t by_derivative = num_constraints * (1 + static_cast<std::size_t>(states));
  const double* derivative_values = scratch.inputs.data() + num_parameters + 2 * dof;
  Eigen::VectorXd& residual = scratch.residual;
  Eigen::VectorXd& step = scratch.step;
  Eigen::MatrixXd& jacobian = scratch.jacobian;
  residual.resize(states);
  step.resize(states);
  jacobian.resize(states, states);
  if (internal_rows > 0) jacobian.bottomRows(internal_rows) = internal_directions.transpose();
  if (scratch.constant_matrix) {
    // Affine constraints: one step with the matrix factored at construction is exact, from any
    // start; only the constraints' values are needed.
    std::copy(x.begin(), x.end(), scratch.inputs.begin() + static_cast<long>(num_parameters));
    constraint_values.Evaluate(scratch.inputs.data(), scratch.registers.data(),
                               scratch.outputs.data());
    for (Eigen::Index r = 0; r < constraint_rows; ++r) {
      residual[r] = scratch.outputs[static_cast<std::size_t>(r)];
    }
    for (Eigen::Index r = constraint_rows; r < states; ++r) {
      residual[r] =
          internal_directions.col(r - constraint_rows).dot(x) - internal[r - constraint_rows];
    }
    scratch.scaled = jacobian_row_scale.asDiagonal() * residual;
    step = jacobian_column_scale.asDiagonal() * affine_lu.solve(scratch.scaled);
    x -= step;
    if (!x.allFinite()) {
      why = "the output constraints are not finite";
      return false;
    }
    return true;
  }
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
      double size = 0;
      if (constraint) {
        residual[r] = scratch.outputs[row];
        // The size of the terms: y_d's through the Jacobian by Y, the state's through the
        // Jacobian by x, each coefficient with the size of the whole state, since near rest the
        // entries vanish while round-off of the others does not.
        for (Eigen::Index k = 0; k < derivatives; ++k) {
          size += std::abs(
              scratch.outputs[by_derivative + row * num_derivatives + static_cast<std::size_t>(k)] *
              derivative_values[k]);
        }
      } else {
        const Eigen::Index column = r - constraint_rows;
        residual[r] = internal_directions.col(column).dot(x) - internal[column];
        size = std::abs(internal[column]);
      }
      size += std::abs(residual[r]) + jacobian.row(r).cwiseAbs().sum() * state_size;
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
    const bool stagnated =
        iteration >= 2 && worst >= 0.5 * previous_worst && worst <= kStagnationTolerance;
    if (worst <= kNewtonTolerance || last_step_at_round_off || stagnated) return true;
    previous_worst = worst;
    if (iteration == kMaxNewtonIterations) break;
    if (!jacobian.allFinite() ||
        !SolveScaledInto(jacobian, jacobian_row_scale, jacobian_column_scale, residual, scratch.lu,
                         step)) {
      why = "the Jacobian of the output constraints is singular at " + StateText(x);
      return false;
    }
    x -= step;
    last_step_at_round_off =
        step.cwiseAbs().maxCoeff() <=
        kRoundOffSteps * std::numeric_limits<double>::epsilon() * (1.0 + x.cwiseAbs().maxCoeff());
  }
  std::ostringstream text;
  text.precision(3);
  text << "Newton's method on the output constraints did not converge in " << kMaxNewtonIterations
       << " iterations (largest relative residual " << worst << ")";
  why = text.str();
  return false;
}

bool AlgebraicInverse::Programs::SolveInputs(Scratch& scratch,
                                             const Eigen::VectorXd& x,
                                             Eigen::VectorXd& u,
                                             std::string& why) const {
  std::copy(x.begin(), x.end(), scratch.inputs.begin() + static_cast<long>(num_parameters));
  input_equations.Evaluate(scratch.inputs.data(), scratch.registers.data(), scratch.outputs.data());
  const auto m = static_cast<Eigen::Index>(num_inputs);
  Eigen::MatrixXd& coefficients = scratch.coefficients;
  Eigen::VectorXd& right_hand_side = scratch.right_hand_side;
  coefficients.resize(m, m);
  right_hand_side.resize(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) {
      coefficients(i, j) = scratch.outputs[static_cast<std::size_t>(i * m + j)];
    }
    right_hand_side[i] = -scratch.outputs[static_cast<std::size_t>(m * m + i)];
  }
  if (scratch.constant_coefficients && right_hand_side.allFinite()) {
    u = coefficient_column_scale.asDiagonal() *
        coefficient_lu.solve(coefficient_row_scale.asDiagonal() * right_hand_side);
    if (u.allFinite()) return true;
  }
  if (!coefficients.allFinite() || !right_hand_side.allFinite() ||
      !SolveScaledInto(coefficients, coefficient_row_scale, coefficient_column_scale,
                       right_hand_side, scratch.lu, u)) {
    why = "the inputs' coefficient matrix is singular at " + StateText(x);
    scratch.singular_inputs = true;
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
  return EvaluateWithInternal(output_derivatives, Eigen::VectorXd(), parameters, q, q_dot, u, why);
}

bool AlgebraicInverse::EvaluateWithInternal(const Eigen::MatrixXd& output_derivatives,
                                            const Eigen::VectorXd& internal,
                                            const Eigen::VectorXd& parameters,
                                            Eigen::VectorXd& q,
                                            Eigen::VectorXd& q_dot,
                                            Eigen::VectorXd& u,
                                            std::string& why) const {
  Workspace workspace;
  return EvaluateWithInternal(output_derivatives, internal, parameters, q, q_dot, u, why,
                              workspace);
}

AlgebraicInverse::Workspace::Workspace() : scratch_(std::make_unique<AlgebraicInverseScratch>()) {}
AlgebraicInverse::Workspace::~Workspace() = default;
bool AlgebraicInverse::Workspace::singular_inputs() const { return scratch_->singular_inputs; }
AlgebraicInverse::Workspace::Workspace(Workspace&&) noexcept = default;
AlgebraicInverse::Workspace& AlgebraicInverse::Workspace::operator=(Workspace&&) noexcept = default;

bool AlgebraicInverse::EvaluateWithInternal(const Eigen::MatrixXd& output_derivatives,
                                            const Eigen::VectorXd& internal,
                                            const Eigen::VectorXd& parameters,
                                            Eigen::VectorXd& q,
                                            Eigen::VectorXd& q_dot,
                                            Eigen::VectorXd& u,
                                            std::string& why,
                                            Workspace& workspace) const {
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

  Programs::Scratch& scratch = *workspace.scratch_;
  scratch.singular_inputs = false;
  programs.PrepareScratch(parameters, output_derivatives, scratch);
  Eigen::VectorXd& x = scratch.x;
  x.resize(2 * dof);
  x << q, q_dot;
  if (!programs.SolveState(internal, scratch, x, why) ||
      !programs.SolveInputs(scratch, x, scratch.u, why)) {
    return false;
  }
  q = x.head(dof);
  q_dot = x.tail(dof);
  u = scratch.u;
  why.clear();
  return true;
}

namespace {

// The derivations of this process, most recent last: solving many trajectories of one model
// derives its inverse once. Keyed by everything the derivation depends on.
struct CachedInverse {
  std::string key;
  std::shared_ptr<const AlgebraicInverse> inverse;
};
constexpr std::size_t kCachedInverses = 8;

std::string CacheKey(const Model& model, const AlgebraicInverseOptions& options) {
  std::string key = model.content_hash() + "|" + model.name();
  const auto append = [&key](double value) {
    key.append(reinterpret_cast<const char*>(&value), sizeof value);
  };
  for (const double value : model.parameters()) append(value);
  key += "|";
  for (const double value : options.reference_q) append(value);
  append(options.rank_tolerance);
  key += options.internal_dynamics ? "i" : "f";
  return key;
}

}  // namespace

std::shared_ptr<const AlgebraicInverse> DeriveAlgebraicInverse(
    const Model& model, const AlgebraicInverseOptions& options) {
  // Lock order: SymbolicLock, then `mutex`, never the other way round; an inverse is never
  // destroyed while `mutex` is held (its destructor takes SymbolicLock).
  static std::mutex mutex;
  static std::vector<CachedInverse> cache;
  const std::string key = CacheKey(model, options);
  const auto find = [&key]() -> std::shared_ptr<const AlgebraicInverse> {
    const std::lock_guard<std::mutex> lock(mutex);
    for (auto entry = cache.begin(); entry != cache.end(); ++entry) {
      if (entry->key != key) continue;
      CachedInverse found = std::move(*entry);
      cache.erase(entry);
      cache.push_back(found);
      return found.inverse;
    }
    return nullptr;
  };
  if (auto cached = find()) return cached;
  // Derive under the symbolic lock, and look once more there: a thread that asked for the same
  // inverse a moment earlier has derived it meanwhile.
  const SymbolicLock symbolic;
  if (auto cached = find()) return cached;
  auto inverse = std::make_shared<const AlgebraicInverse>(model, options);
  CachedInverse evicted;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    if (cache.size() == kCachedInverses) {
      evicted = std::move(cache.front());
      cache.erase(cache.begin());
    }
    cache.push_back({key, inverse});
  }
  return inverse;  // `evicted` goes here, under SymbolicLock and outside `mutex`
}

}  // namespace servokit
