#pragma once
// The symbolic view of a model (docs/model-files.md, "How servokit reads a model"): the GiNaC
// expressions of M, f, B, h as read from the model file, and everything derived from them once
// at load time. Numeric code uses the compiled programs instead (modeling/model.h); this view is
// for closed forms (characteristic polynomials, normal forms) and for reports. GiNaC is not
// thread-safe: hold a SymbolicLock (modeling/symbolic_lock.h) while you use the expressions; the
// member functions that make new ones take it themselves, and any thread may destroy a
// SymbolicModel (its expressions go under the lock).
#include <ginac/ginac.h>

#include <Eigen/Dense>
#include <cstddef>
#include <memory>
#include <optional>
#include <variant>
#include <vector>

#include "modeling/canonical_expression.h"
#include "modeling/symbolic_lock.h"

namespace servokit {

/// M(q) q'' + f(q, q') = B(q) u, y = h(q) (paper Eqs. 1, 3) with the derived H, h_bar and the
/// Jacobians. Vectors are GiNaC matrices with one column. Symbols are GiNaC::realsymbol, so that
/// abs() differentiates to x/abs(x) and conjugate() is the identity.
/// The inputs of every compiled program of a model, in Evaluate()'s order: [parameters, q,
/// q_dot]. The loader compiles M with them before the SymbolicModel exists.
std::vector<GiNaC::ex> ProgramInputSymbols(const std::vector<GiNaC::realsymbol>& parameters,
                                           const std::vector<GiNaC::realsymbol>& coordinates,
                                           const std::vector<GiNaC::realsymbol>& velocities);

/// A matrix's entries in canonical form in `store`, row by row (a column: one per row): a
/// model's f as the file writes it (modeling/expression_parser.h), M and f derived on canonical
/// forms (modeling/lagrangian_model.h). The SymbolicModel builds their GiNaC forms only when
/// they are asked for, so that a force of 10^5 terms or the 160 000 entries of a chain's M,
/// compiled straight from their canonical forms, are never built in GiNaC for a model that does
/// not need them (issue #31).
struct CanonicalEntries {
  std::shared_ptr<CanonicalExpressions> store;
  std::vector<CanonicalExpressions::Scaled> entries;
};

/// The GiNaC matrix (rows x cols) of `forms`' entries. Hold a SymbolicLock.
GiNaC::matrix InGiNaC(const CanonicalEntries& forms, unsigned rows, unsigned cols);

class SymbolicModel {
 public:
  /// M or f: in GiNaC, or in canonical form (then built in GiNaC on first use).
  using Entries = std::variant<GiNaC::matrix, CanonicalEntries>;

  /// Takes M (dof x dof), f (dof x 1), B (dof x inputs), h (outputs x 1) in the given symbols and
  /// derives the rest. `velocities[k]` is the time derivative of `coordinates[k]`. The caller
  /// holds a SymbolicLock (it made the arguments); the derivation takes one too.
  SymbolicModel(std::vector<GiNaC::realsymbol> parameters,
                std::vector<GiNaC::realsymbol> coordinates,
                std::vector<GiNaC::realsymbol> velocities,
                Entries mass_matrix,
                Entries forces,
                GiNaC::matrix input_matrix,
                GiNaC::matrix output,
                GiNaC::matrix constraints = GiNaC::matrix(0, 1));

  /// Number of coordinates q.
  std::size_t dof() const { return expressions_->coordinates.size(); }
  /// Number of inputs u (columns of B).
  std::size_t num_inputs() const { return expressions_->input_matrix.cols(); }
  /// Number of outputs y (rows of h).
  std::size_t num_outputs() const { return expressions_->output.rows(); }
  /// Number of loop-closing constraints c(q) = 0 (rows of c; 0 for an open chain).
  std::size_t num_constraints() const { return expressions_->constraints.rows(); }

  /// The parameter symbols, in the order of Model::parameter_names().
  const std::vector<GiNaC::realsymbol>& parameters() const { return expressions_->parameters; }
  /// q, in the order of Model::coordinates().
  const std::vector<GiNaC::realsymbol>& coordinates() const { return expressions_->coordinates; }
  /// q_dot; the symbol of coordinate c is named c_dot.
  const std::vector<GiNaC::realsymbol>& velocities() const { return expressions_->velocities; }
  /// The inputs of every compiled program: [parameters, q, q_dot] (ProgramInputSymbols).
  std::vector<GiNaC::ex> ProgramInputs() const;

  /// M(q), dof x dof (paper Eq. 1); built from its canonical form on the first call when the
  /// model was given one (takes a SymbolicLock).
  const GiNaC::matrix& mass_matrix() const;
  /// M's canonical form (row by row) when the model was given one, else null.
  const CanonicalEntries* canonical_mass_matrix() const {
    return expressions_->canonical_mass_matrix ? &*expressions_->canonical_mass_matrix : nullptr;
  }
  /// f(q, q_dot), dof x 1 (paper Eq. 1); built from its canonical form on the first call when
  /// the model was given one (takes a SymbolicLock).
  const GiNaC::matrix& forces() const;
  /// f's canonical form when the model was given one (then compile from it), else null.
  const CanonicalEntries* canonical_forces() const {
    return expressions_->canonical_forces ? &*expressions_->canonical_forces : nullptr;
  }
  /// B(q), dof x inputs (paper Eq. 1).
  const GiNaC::matrix& input_matrix() const { return expressions_->input_matrix; }
  /// h(q), outputs x 1 (paper Eq. 3).
  const GiNaC::matrix& output() const { return expressions_->output; }
  /// H = dh/dq, outputs x dof (paper Eq. 4).
  const GiNaC::matrix& output_jacobian() const { return expressions_->output_jacobian; }
  /// h_bar = H_dot q_dot = sum_jk d2h/dq_j dq_k q_dot_j q_dot_k, outputs x 1 (paper Eq. 5).
  const GiNaC::matrix& output_bias() const { return expressions_->output_bias; }
  /// c(q), constraints x 1 (paper Eq. 7: c_c(q) = 0), C = dc/dq (constraints x dof), dC/dq_k
  /// for k = 0..dof-1 and c_bar = C_dot q_dot, derived as H, dH/dq and h_bar are from h.
  const GiNaC::matrix& constraints() const { return expressions_->constraints; }
  const GiNaC::matrix& constraint_jacobian() const { return expressions_->constraint_jacobian; }
  const std::vector<GiNaC::matrix>& constraint_jacobian_derivatives() const {
    return expressions_->constraint_jacobian_derivatives;
  }
  const GiNaC::matrix& constraint_bias() const { return expressions_->constraint_bias; }
  /// True when df/dq, df/dq_dot and dB/dq were derived: when differentiating f and B walks at
  /// most kMaxJacobianWork nodes (dof (2 |f| + |B|), TreeSize, modeling/expansion_bound.h).
  /// Larger models get them by forward-mode differentiation of the compiled programs of f and
  /// B at every evaluation (Evaluate, modeling/model.h), and no zero-dynamics polynomial.
  bool has_symbolic_jacobians() const { return expressions_->jacobian_work <= kMaxJacobianWork; }
  // Every shipped and test model needs at most about 2000; a chain of 10 pendulums written as
  // energies about 3.3e4, a sum of 1000 monomials in the forces 4.1e4 (issue #31's benchmark),
  // a chain of 50 pendulums 3.8e6, whose symbolic Jacobians took seconds.
  static constexpr double kMaxJacobianWork = 1e4;
  /// f given in canonical form is built in GiNaC at load (to count that work exactly, and for
  /// its Jacobians) only when its canonical form promises at most this work (counted the same
  /// way: its tree size is about GiNaC's). Beyond, the Jacobians are past kMaxJacobianWork
  /// anyway, and f is built in GiNaC only if something asks for it.
  static constexpr double kMaxEagerForcesWork = 10 * kMaxJacobianWork;
  /// df/dq, dof x dof (empty without has_symbolic_jacobians()).
  const GiNaC::matrix& forces_position_jacobian() const {
    return expressions_->forces_position_jacobian;
  }
  /// df/dq_dot, dof x dof (empty without has_symbolic_jacobians()).
  const GiNaC::matrix& forces_velocity_jacobian() const {
    return expressions_->forces_velocity_jacobian;
  }
  /// dB/dq_k for k = 0..dof-1, each dof x inputs (empty without has_symbolic_jacobians()).
  const std::vector<GiNaC::matrix>& input_matrix_derivatives() const {
    return expressions_->input_matrix_derivatives;
  }

  /// det [[M lambda^2 + (df/dq_dot) lambda + df/dq, -B], [H, 0]] with `at` substituted (e.g.
  /// q_dot -> 0): the characteristic polynomial of the linearized zero dynamics at an
  /// equilibrium where B u0 does not vary with q (u0 = 0 or B constant); its roots are the
  /// invariant zeros. The one place this determinant is formed. Needs
  /// has_symbolic_jacobians().
  GiNaC::ex RosenbrockDeterminant(const GiNaC::realsymbol& lambda, const GiNaC::exmap& at) const;
  /// The matrix of that determinant, [[M lambda^2 + (df/dq_dot) lambda + df/dq, -B], [H, 0]].
  GiNaC::matrix RosenbrockMatrix(const GiNaC::realsymbol& lambda, const GiNaC::exmap& at) const;

  /// Its coefficients a_0 .. a_(2 dof) in lambda at q_dot = 0, as functions of the parameters
  /// and q (Denominators are cleared, which scales every coefficient alike and keeps the
  /// roots), and for each coefficient the sum of the absolute values of its terms: the size
  /// against which "this coefficient is zero" is decided (cancellation down to round-off).
  struct ZeroDynamicsPolynomial {
    std::vector<GiNaC::ex> coefficients, scales;
  };
  /// True for models without constraints with dof + inputs <= kMaxPolynomialSize (a symbolic
  /// determinant costs like n!), as many outputs as inputs and an expansion within
  /// kMaxPolynomialTerms: decided at load, before anything is expanded.
  bool has_zero_dynamics_polynomial() const { return expressions_->has_zero_dynamics_polynomial; }
  /// Derives the polynomial (empty without has_zero_dynamics_polynomial()): the determinant,
  /// normal() and expand(), more than half of loading a small model, so only a caller that
  /// needs it (a sweep's polynomial path, Model::polynomial_programs) pays. Takes a SymbolicLock.
  ZeroDynamicsPolynomial DeriveZeroDynamicsPolynomial() const;
  /// Rows of the Rosenbrock matrix (dof + inputs) up to which the polynomial is derived.
  static constexpr std::size_t kMaxPolynomialSize = 4;
  /// The most terms the polynomial's expanded numerator may have, by BoundExpandedTerms
  /// (modeling/expansion_bound.h) before anything is expanded: beyond it the polynomial is not
  /// derived (a product of sums in the forces would take minutes and gigabytes to expand, issue
  /// #31) and the sweeps classify the model by its eigenvalues, as a larger model.
  // The shipped models need up to 5616 (rotational_arm_tip, loaded in about 50 ms); a product of
  // seven sums of five terms, about 1.4e4, took seconds.
  static constexpr double kMaxPolynomialTerms = 8000;
  /// The bound on its numerator's terms that decided (0 when the size rule above excluded it).
  double zero_dynamics_polynomial_terms() const {
    return expressions_->zero_dynamics_polynomial_terms;
  }

  /// The substitution parameter symbol -> value, for GiNaC's subs(). `values` has
  /// parameters().size() entries in SI units (e.g. Model::parameters()).
  GiNaC::exmap ParameterValues(const Eigen::VectorXd& values) const;
  /// `expression` with every parameter replaced by its value in `values` (as ParameterValues).
  GiNaC::ex SubstituteParameters(const GiNaC::ex& expression, const Eigen::VectorXd& values) const;

 private:
  // Everything GiNaC of the model. A Model shares it with its copies, and the thread that drops
  // the last one may be any, so it is destroyed under SymbolicLock (modeling/symbolic_lock.h).
  struct Expressions {
    std::vector<GiNaC::realsymbol> parameters, coordinates, velocities;
    GiNaC::matrix mass_matrix, forces, input_matrix, output;
    std::optional<CanonicalEntries> canonical_mass_matrix, canonical_forces;
    bool mass_matrix_built = true;  // false while M is only in canonical_mass_matrix
    bool forces_built = true;       // false while f is only in canonical_forces
    GiNaC::matrix output_jacobian, output_bias;
    GiNaC::matrix constraints, constraint_jacobian, constraint_bias;
    std::vector<GiNaC::matrix> constraint_jacobian_derivatives;
    GiNaC::matrix forces_position_jacobian, forces_velocity_jacobian;
    std::vector<GiNaC::matrix> input_matrix_derivatives;
    bool has_zero_dynamics_polynomial = false;
    double zero_dynamics_polynomial_terms = 0.0;
    double jacobian_work = 0.0;
  };
  SymbolicPtr<Expressions> expressions_;
};

}  // namespace servokit
