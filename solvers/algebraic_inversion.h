#pragma once
// Algebraic inversion of a flat servo-constraint problem (paper Sect. 5.1): u_d and q_d from the
// desired output and its derivatives alone, without integrating anything.
//
// Derived symbolically once (GiNaC) by the structure algorithm (analysis/nonlinear_structure.h):
// each output y_i = h_i(q) is differentiated along the motion, q'' = M^-1 (B u - f), until the
// inputs appear; the derivatives before are constraints on the state (q, q') given the desired
// y_d^(k). Where the inputs' coefficient matrix is singular on a neighbourhood (mixed
// realizations: the gantry crane, a PVTOL aircraft) the algorithm performs a dynamic extension:
// the equations that repeat the kept rows' inputs are combined with them into new, u-free
// constraints and differentiated further. A problem is flat in this sense when the constraints
// number 2 dof (they fix the whole state) and the final input equations have a regular matrix.
// At each time the state follows from the constraints by Newton's method (one step when they
// are linear, e.g. for linear models) and u from the input equations. For the mass on car,
// case 4 (alpha = 0, d = 0), this gives Eq. (47) without being told it.
//
// The structure is decided for the model's parameter values (after overrides): parameters
// that are 0 are substituted exactly before differentiating (alpha = 0 makes sin(alpha)
// vanish identically), and a u-coefficient counts as zero by analyze's rank rule
// (AlgebraicInverseOptions::rank_tolerance) at the reference state and at generic states.
// A coefficient that vanishes at rest only (the gantry crane's y1'' has one proportional to
// sin(theta)) still puts u into that derivative. The relative degrees are therefore those of
// the nonlinear model, which can differ from those of its linearization at rest: the crane's
// are (2, 2) with a singular coefficient matrix, extended to (4, 4), not (4, 2).
#include <ginac/ginac.h>

#include <Eigen/Dense>
#include <memory>
#include <string>
#include <vector>

#include "analysis/nonlinear_structure.h"
#include "modeling/model.h"
#include "modeling/symbolic_lock.h"

namespace servokit {

class ExpressionProgram;
struct AlgebraicInverseScratch;

struct AlgebraicInverseOptions {
  // Accept internal dynamics: the relative degrees may add up to less than 2 dof. Internal
  // coordinates z = W^T (q, q') then complete the state (the input-output normal form, Isidori
  // Ch. 4-5), W an orthonormal basis of the null space of the constraints' Jacobian at the
  // reference state; EvaluateWithInternal() recovers the state from y_d's derivatives and z.
  bool internal_dynamics = false;
  // The reference state (q here, q' = 0) where W is chosen and the structure is decided: the
  // operating point. Empty: q = 0.
  Eigen::VectorXd reference_q;
  // Rank decisions, as ClassificationOptions::rank_tolerance (the solvers pass analyze's).
  double rank_tolerance = 1e-10;
};

class AlgebraicInverse {
 public:
  /// Derives the inverse from model.symbolic(), under SymbolicLock (modeling/symbolic_lock.h: the
  /// derivation is GiNaC's, one thread at a time; any thread may destroy it). Throws NoSolution
  /// naming the reason when the problem is not flat in the sense above (internal dynamics
  /// remain, unless options.internal_dynamics; an output never depends on the inputs within
  /// 2 dof derivatives; the u-coefficient matrix or the constraint Jacobian is singular at the
  /// reference state), or when the symbolic derivation fails.
  explicit AlgebraicInverse(const Model& model, const AlgebraicInverseOptions& options = {});
  ~AlgebraicInverse();
  AlgebraicInverse(AlgebraicInverse&&) noexcept;
  AlgebraicInverse& operator=(AlgebraicInverse&&) noexcept;

  /// The highest derivative of output i that the inverse reads: its relative degree, or after
  /// a dynamic extension its extended relative degree (the gantry crane's (4, 4)).
  const std::vector<int>& output_derivative_orders() const { return orders_; }
  /// The first derivative of output i in which the inputs appear (nonlinear relative degree).
  const std::vector<int>& relative_degree() const { return relative_degree_; }
  /// The steps of the dynamic extension; empty when the coefficient matrix was regular at once.
  const std::vector<StructureStep>& extension_steps() const { return extension_steps_; }
  /// Integrators the dynamic extension adds (0 without one).
  int integrators() const { return integrators_; }
  /// max over output_derivative_orders(): how many derivatives of y_d the inverse reads (4 for
  /// mass on car case 4).
  int highest_output_derivative() const;

  /// q, q' and u at one instant. `output_derivatives` is outputs x (r + 1), column k holding
  /// y_d^(k) (r = highest_output_derivative(); output i reads columns 0..r_i); `parameters`
  /// as Workspace::parameters. q and q_dot (size dof) hold Newton's starting point on entry
  /// (the previous instant's answer) and the answer on return; u is resized to the inputs.
  /// Returns false, sets `why` and leaves q, q_dot, u unchanged when Newton does not converge
  /// within 20 iterations or the constraint Jacobian or the u-coefficient matrix is singular
  /// there. Throws UsageError when a size is wrong or when a parameter the structure depends
  /// on (one that was 0 at construction, or one in a u-coefficient that vanished there)
  /// differs from its value at construction, and when internal_order() > 0 (use
  /// EvaluateWithInternal). Thread-safe (const, no GiNaC, local scratch).
  bool Evaluate(const Eigen::MatrixXd& output_derivatives,
                const Eigen::VectorXd& parameters,
                Eigen::VectorXd& q,
                Eigen::VectorXd& q_dot,
                Eigen::VectorXd& u,
                std::string& why) const;

  /// 2 dof minus the sum of the relative degrees: the dimension of the internal coordinates.
  Eigen::Index internal_order() const;
  /// W (2 dof x internal_order()): z = W^T (q, q') are the internal coordinates.
  const Eigen::MatrixXd& internal_directions() const;

  /// As Evaluate(), with the internal coordinates z (size internal_order()) fixing the rest of
  /// the state: Newton on the constraints and W^T (q, q') = z.
  bool EvaluateWithInternal(const Eigen::MatrixXd& output_derivatives,
                            const Eigen::VectorXd& internal,
                            const Eigen::VectorXd& parameters,
                            Eigen::VectorXd& q,
                            Eigen::VectorXd& q_dot,
                            Eigen::VectorXd& u,
                            std::string& why) const;

  /// Scratch space of one caller (one thread): keeps the programs' registers and Newton's
  /// matrices between calls, so that a right-hand side does not allocate.
  class Workspace {
   public:
    Workspace();
    ~Workspace();
    Workspace(Workspace&&) noexcept;
    Workspace& operator=(Workspace&&) noexcept;
    /// Whether the last failed evaluation failed on a singular matrix of the input equations
    /// (the decoupling matrix of the normal form: P for relative degree 2).
    bool singular_inputs() const;

   private:
    friend class AlgebraicInverse;
    std::unique_ptr<AlgebraicInverseScratch> scratch_;
  };
  /// As above, with the caller's workspace.
  bool EvaluateWithInternal(const Eigen::MatrixXd& output_derivatives,
                            const Eigen::VectorXd& internal,
                            const Eigen::VectorXd& parameters,
                            Eigen::VectorXd& q,
                            Eigen::VectorXd& q_dot,
                            Eigen::VectorXd& u,
                            std::string& why,
                            Workspace& workspace) const;

  /// u_d as closed forms in the parameters and the symbols of y_d^(k) when the state
  /// constraints are linear in (q, q'), one per input; empty otherwise. For mass on car case 4:
  /// (m1 + m2) y1_d'' + m1 m2 / k y1_d'''' (Eq. 47). Parameters that were 0 at construction
  /// are already substituted. GiNaC expressions: hold a SymbolicLock while you use them.
  const std::vector<GiNaC::ex>& input_formulas() const { return formulas_->input_formulas; }
  /// The symbol standing for d^order y_i / dt^order in input_formulas(), named
  /// "y<i+1>_d" followed by `order` primes; order 0..r_i. Throws std::out_of_range otherwise.
  const GiNaC::realsymbol& output_derivative_symbol(std::size_t output, int order) const;

 private:
  struct Programs;  // the compiled constraints, their Jacobian and the u-equations
  std::vector<int> orders_;
  std::vector<int> relative_degree_;
  std::vector<StructureStep> extension_steps_;
  int integrators_ = 0;
  // The symbolic results, kept for input_formulas(); destroyed under SymbolicLock, since the
  // last owner of a shared inverse (DeriveAlgebraicInverse) may be any thread.
  struct Formulas {
    std::vector<std::vector<GiNaC::realsymbol>> derivative_symbols;  // [output][order]
    std::vector<GiNaC::ex> input_formulas;
  };
  SymbolicPtr<const Formulas> formulas_;
  std::unique_ptr<const Programs> programs_;
};

/// The inverse of `model` (with its parameters) for `options`, derived once per process for
/// the same model file, parameter values and options (the last few are kept), so that solving
/// many trajectories of one model pays for the symbolic derivation once. Throws as the
/// constructor. Thread-safe: a derivation runs under SymbolicLock, once for the callers that
/// ask for the same inverse at once; a cached inverse is returned without waiting for it.
std::shared_ptr<const AlgebraicInverse> DeriveAlgebraicInverse(
    const Model& model, const AlgebraicInverseOptions& options = {});

}  // namespace servokit
