#pragma once
// A servo-constraint model  M(q) q'' + f(q, q') = B(q) u,  y = h(q)  (paper Eqs. 1, 3).
//
// Model is built once by LoadModel() and never changed afterwards; it is shared by all threads.
// Workspace holds every buffer an evaluation needs; each thread owns one (as Pinocchio keeps
// Model apart from Data). Numeric code evaluates compiled ExpressionPrograms only and never
// calls GiNaC, which is slow per call and not thread-safe; symbolic work runs under
// SymbolicLock (modeling/symbolic_lock.h), and so does the destruction of a model's expressions.
#include <Eigen/Dense>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "modeling/dual_number.h"
#include "modeling/units.h"

namespace servokit {

class SymbolicModel;      // modeling/symbolic_model.h: the GiNaC expressions
class ExpressionProgram;  // modeling/expression_program.h: a compiled evaluator

/// What Evaluate() can compute; combine with |. Matrices are evaluated column-major.
enum class Quantity : unsigned {
  kMassMatrix = 1u << 0,              // M(q), dof x dof
  kForces = 1u << 1,                  // f(q, q_dot), dof
  kInputMatrix = 1u << 2,             // B(q), dof x inputs
  kOutput = 1u << 3,                  // h(q), outputs
  kOutputJacobian = 1u << 4,          // H = dh/dq, outputs x dof (Eq. 4)
  kOutputBias = 1u << 5,              // h_bar = H_dot q_dot, outputs (Eq. 5)
  kForcesJacobians = 1u << 6,         // df/dq and df/dq_dot, dof x dof each
  kInputMatrixDerivatives = 1u << 7,  // dB/dq_k, dof matrices of dof x inputs
  // Coefficients a_0..a_(2 dof) of SymbolicModel::zero_dynamics_polynomial() at q (q_dot is
  // ignored), then their scales; all zero when the model is too large for it (check with
  // Model::has_zero_dynamics_polynomial()).
  kZeroDynamicsPolynomial = 1u << 8,
  // Loop-closing constraints c(q) = 0 (docs/model-files.md, "Closed kinematic chains"); each
  // of size 0 for a model without: constraints x ... below.
  kConstraints = 1u << 9,                     // c(q), constraints
  kConstraintJacobian = 1u << 10,             // C = dc/dq, constraints x dof
  kConstraintBias = 1u << 11,                 // c_bar = C_dot q_dot, constraints
  kConstraintJacobianDerivatives = 1u << 12,  // dC/dq_k, dof matrices of constraints x dof
};
constexpr unsigned operator|(Quantity a, Quantity b) {
  return static_cast<unsigned>(a) | static_cast<unsigned>(b);
}
constexpr unsigned operator|(unsigned a, Quantity b) { return a | static_cast<unsigned>(b); }
/// The number of Quantity values; programs are indexed 0..kNumQuantities-1 by bit position.
inline constexpr std::size_t kNumQuantities = 13;
/// The quantities a model too large for symbolic Jacobians (SymbolicModel::has_symbolic_jacobians)
/// has no program for: Evaluate computes them by forward-mode differentiation of the programs
/// of f and B (dual numbers, modeling/dual_number.h), a column per q and q_dot.
constexpr bool IsForwardModeQuantity(Quantity quantity) {
  return quantity == Quantity::kForcesJacobians || quantity == Quantity::kInputMatrixDerivatives;
}
/// What a sweep's polynomial path (analysis/sweep_point.h) evaluates at every point, compiled
/// also as one program (Model::PolynomialPrograms::combined).
inline constexpr unsigned kPolynomialPathQuantities =
    Quantity::kMassMatrix | Quantity::kForces | Quantity::kInputMatrix | Quantity::kOutputJacobian |
    Quantity::kZeroDynamicsPolynomial;

/// A parameter's value given by name, in place of the model file's nominal value; value is a
/// number and may end in "deg".
struct ParameterOverride {
  std::string name;
  std::string value;
};

/// An immutable, thread-shareable model: names, nominal parameters (SI), the symbolic
/// expressions and their compiled evaluators.
class Model {
 public:
  const std::string& name() const { return name_; }
  const std::string& description() const { return description_; }
  /// Where the model came from (the file path as given), used in error messages.
  const std::string& source() const { return source_; }
  /// FNV-1a 64-bit hash of the model file's bytes, as 16 hex digits (sweep.json records it).
  const std::string& content_hash() const { return content_hash_; }

  std::size_t dof() const { return coordinates_.size(); }
  std::size_t num_inputs() const { return inputs_.size(); }
  std::size_t num_outputs() const { return num_outputs_; }
  std::size_t num_parameters() const { return parameter_names_.size(); }
  /// Loop-closing constraints c(q) = 0 (0 for an open chain): q is then redundant, with
  /// dof() - num_constraints() degrees of freedom.
  std::size_t num_constraints() const { return num_constraints_; }
  /// Where each constraint comes from, for messages: "constraints[0]", "joints[1].y".
  const std::vector<std::string>& constraint_names() const { return constraint_names_; }
  /// The file's `q0:`, Newton's start for the operating point and the point whose output it
  /// holds by default (FindOperatingPoint); empty when the file has none (then q = 0). A closed
  /// chain in absolute coordinates gives one on its loops.
  const Eigen::VectorXd& operating_point_start() const { return operating_point_start_; }

  const std::vector<std::string>& coordinates() const { return coordinates_; }
  const std::vector<std::string>& inputs() const { return inputs_; }
  const std::vector<std::string>& parameter_names() const { return parameter_names_; }
  /// Output names y1, y2, ... (the columns y1_d, ... of docs/solve.md).
  std::vector<std::string> output_names() const;
  /// Nominal parameter values in SI units, in the order of parameter_names(), after overrides.
  const Eigen::VectorXd& parameters() const { return parameters_; }
  /// The unit each parameter is shown in, in the order of parameter_names(): kDegree for one
  /// the model file or an override gave in degrees ("5 deg"), kSI otherwise. Values stay SI.
  const std::vector<DisplayUnit>& parameter_display_units() const { return parameter_units_; }
  /// Index of a parameter by name, or nullopt.
  std::optional<std::size_t> FindParameter(std::string_view name) const;

  /// The GiNaC expressions (for closed forms and reports; not for numeric loops). Hold a
  /// SymbolicLock (modeling/symbolic_lock.h) while you use them: other threads may be using them.
  const SymbolicModel& symbolic() const { return *symbolic_; }
  /// The compiled evaluator of one quantity; inputs are [parameters, q, q_dot]. Every quantity
  /// has one but those IsForwardModeQuantity names, on a model too large for symbolic Jacobians.
  const ExpressionProgram& program(Quantity quantity) const;
  bool has_program(Quantity quantity) const;
  /// The zero-dynamics polynomial's programs (SymbolicModel::DeriveZeroDynamicsPolynomial): the
  /// polynomial alone (Quantity::kZeroDynamicsPolynomial), and kPolynomialPathQuantities as one
  /// program, their results one after another in Quantity order, which Evaluate runs for exactly
  /// that combination so that the subexpressions they share (the cosine of a parameter, ...) are
  /// computed once. Null where the model has none.
  struct PolynomialPrograms {
    std::shared_ptr<const ExpressionProgram> alone, combined;
  };
  /// Derived and compiled on the first call, once, whichever thread asks first: loading does not
  /// (the determinant, normal() and expand() were more than half of loading a small model, and
  /// only a sweep's polynomial path reads them).
  const PolynomialPrograms& polynomial_programs() const;
  /// True when the zero-dynamics polynomial is available (small models, as many outputs as
  /// inputs, an expansion within budget), so Quantity::kZeroDynamicsPolynomial is meaningful.
  /// The first call derives it (polynomial_programs()).
  bool has_zero_dynamics_polynomial() const { return polynomial_programs().alone != nullptr; }
  /// The most registers and outputs of any of its programs but the polynomial's (Workspace's
  /// scratch; Evaluate grows it for those).
  std::size_t max_registers() const;
  std::size_t max_outputs() const;

 private:
  friend class ModelBuilder;  // modeling/model_loader.cpp fills a Model
  // The largest size() of any of its programs (max_registers, max_outputs).
  std::size_t LargestOfPrograms(std::size_t (ExpressionProgram::*size)() const) const;
  std::string name_, description_, source_, content_hash_;
  std::vector<std::string> coordinates_, inputs_, parameter_names_, constraint_names_;
  std::vector<DisplayUnit> parameter_units_;
  std::size_t num_outputs_ = 0;
  std::size_t num_constraints_ = 0;
  Eigen::VectorXd parameters_;
  Eigen::VectorXd operating_point_start_;  // empty: q = 0
  std::shared_ptr<const SymbolicModel> symbolic_;
  // By Quantity bit position; the polynomial's slot stays empty (polynomial_programs()).
  std::vector<std::shared_ptr<const ExpressionProgram>> programs_;
  // The polynomial's programs, made by `compile` (set by the loader) on first use; shared by
  // the model's copies.
  struct LazyPolynomial {
    std::once_flag once;
    std::function<PolynomialPrograms()> compile;
    PolynomialPrograms programs;
  };
  std::shared_ptr<LazyPolynomial> polynomial_ = std::make_shared<LazyPolynomial>();
};

/// Reads a model file (YAML, docs/model-files.md), checks it, derives H, h_bar and the
/// Jacobians symbolically and compiles them. Throws ModelError ("file: key: entry: problem")
/// for a bad file (a linear model's too; LoadModelFile, modeling/loaded_model.h, reads a file of
/// either kind) and ParameterOverrideError for a bad override (unknown name, bad value). Uses
/// GiNaC, which is not thread-safe, under SymbolicLock (modeling/symbolic_lock.h): models load
/// from several threads at once, one after the other where they use GiNaC.
Model LoadModel(const std::string& path, const std::vector<ParameterOverride>& overrides = {});

/// As LoadModel, from YAML text; `source` names it in error messages.
Model LoadModelFromString(const std::string& yaml_text,
                          const std::string& source,
                          const std::vector<ParameterOverride>& overrides = {});

/// The loop-closing constraints of `model` as further servo constraints, the form in which the
/// solvers invert a closed chain: c(q) = 0 are outputs held at 0 and their multipliers inputs
/// acting through C^T, so that  M q'' + f = [B C^T] [u; lambda],  [h; c] = [y_d; 0]  is an open
/// chain's servo-constraint problem with inputs + constraints inputs and outputs (inputs named
/// MultiplierName(k) after the model's own). Its decoupling matrix [H; C] M^-1 [B C^T] is
/// regular exactly where both C M^-1 C^T and the constrained P_c are (Schur complement); its
/// projected DAE projects onto the complement of both constraint sets. `model` itself when it
/// has no loops. Uses GiNaC under SymbolicLock.
Model LoopsAsServoConstraints(const Model& model);

/// The name of the multiplier of constraint k (from 0) as an input of LoopsAsServoConstraints
/// and a column of a solve's file: lambda1, lambda2, ...
std::string MultiplierName(std::size_t k);

/// A model whose equations are linear with constant matrices, M q'' + K q + D q' = B u and
/// y = H q: a linearization written as a model of its own (solvers/linearized_inverse.h).
struct LinearEquations {
  std::string name, description, source;
  std::vector<std::string> coordinates, inputs;
  Eigen::MatrixXd mass_matrix;      // M, dof x dof
  Eigen::MatrixXd stiffness;        // K, dof x dof
  Eigen::MatrixXd damping;          // D, dof x dof
  Eigen::MatrixXd input_matrix;     // B, dof x inputs
  Eigen::MatrixXd output_jacobian;  // H, outputs x dof
};

/// Builds and compiles the model of `equations` as LoadModel would the same equations written
/// in a file, from the numbers themselves (each coefficient exactly the double given), without
/// a file or its text. No parameters. Throws ModelError when the sizes do not agree.
Model ModelFromLinearEquations(const LinearEquations& equations);

/// Per-thread buffers and results of Evaluate(). Build one per thread from the model it serves.
class Workspace {
 public:
  explicit Workspace(const Model& model);

  /// Parameter values Evaluate() uses; starts as model.parameters(). Sweeps change it per point.
  Eigen::VectorXd parameters;

  // Results of the last Evaluate(); only the quantities asked for are up to date.
  Eigen::MatrixXd mass_matrix;                                   // dof x dof
  Eigen::VectorXd forces;                                        // dof
  Eigen::MatrixXd input_matrix;                                  // dof x inputs
  Eigen::VectorXd output;                                        // outputs
  Eigen::MatrixXd output_jacobian;                               // outputs x dof
  Eigen::VectorXd output_bias;                                   // outputs
  Eigen::MatrixXd forces_position_jacobian;                      // dof x dof, df/dq
  Eigen::MatrixXd forces_velocity_jacobian;                      // dof x dof, df/dq_dot
  std::vector<Eigen::MatrixXd> input_matrix_derivatives;         // dof of dof x inputs
  Eigen::VectorXd zero_dynamics_polynomial;                      // a_0 .. a_(2 dof)
  Eigen::VectorXd zero_dynamics_polynomial_scale;                // sum of |terms| of each a_k
  Eigen::VectorXd constraints;                                   // c(q), constraints
  Eigen::MatrixXd constraint_jacobian;                           // C, constraints x dof
  Eigen::VectorXd constraint_bias;                               // C_dot q_dot, constraints
  std::vector<Eigen::MatrixXd> constraint_jacobian_derivatives;  // dof of constraints x dof

  /// Factorizations an analysis redoes at every point of a sweep, kept here so that their
  /// memory is allocated once per thread. Nothing but memory carries over between calls.
  Eigen::FullPivLU<Eigen::MatrixXd> equilibrium_factor;  // FindOperatingPoint: isolated?

  /// True if this workspace was built for a model of the same shape.
  bool Fits(const Model& model) const;

 private:
  friend void Evaluate(const Model&,
                       Workspace&,
                       const Eigen::Ref<const Eigen::VectorXd>&,
                       const Eigen::Ref<const Eigen::VectorXd>&,
                       unsigned);
  friend void EvaluateByForwardMode(const Model&,
                                    Workspace&,
                                    const Eigen::Ref<const Eigen::VectorXd>&,
                                    const Eigen::Ref<const Eigen::VectorXd>&,
                                    unsigned);
  // The inputs [parameters, q, q_dot] of every program.
  void SetProgramInputs(const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& q_dot);
  // One forward-mode quantity from the programs of f or B (program_inputs_ set).
  void DifferentiateForwardMode(const Model& model, Quantity quantity);
  std::size_t dof_ = 0, num_inputs_ = 0, num_outputs_ = 0, num_parameters_ = 0,
              num_constraints_ = 0;
  std::vector<double> program_inputs_;  // [parameters, q, q_dot]
  std::vector<double> registers_;       // scratch for the largest program
  std::vector<double> outputs_;         // scratch for programs with several result blocks
  // The polynomial path's combined program's registers (its constants loaded for
  // `combined_program_`, on first use), and where its outputs go.
  std::vector<double> combined_registers_;
  std::shared_ptr<const ExpressionProgram> combined_program_;  // held: its address is the key
  std::vector<double*> combined_destinations_;
  // Forward mode's dual numbers (IsForwardModeQuantity): the programs' inputs, registers and
  // outputs, sized at the first use.
  std::vector<DualChunk> dual_inputs_, dual_registers_, dual_outputs_;
  // ExpressionProgram::PropagateTangents's registers that carry a tangent, and their flags.
  std::vector<std::uint32_t> tangent_carrying_;
  std::vector<char> tangent_flags_;
};

/// Evaluates the quantities in `quantities` (Quantity values or'ed together) at (q, q_dot) with
/// workspace.parameters. q and q_dot have size model.dof(). Does not check for NaN: callers that
/// hand numbers to users do. `workspace` must be built from `model` (asserted).
void Evaluate(const Model& model,
              Workspace& workspace,
              const Eigen::Ref<const Eigen::VectorXd>& q,
              const Eigen::Ref<const Eigen::VectorXd>& q_dot,
              unsigned quantities);

/// The quantities of `quantities` that IsForwardModeQuantity names, by forward-mode
/// differentiation of the programs of f and B whether or not the model has programs for them:
/// the route Evaluate takes without one, callable on any model so that tests compare the two.
void EvaluateByForwardMode(const Model& model,
                           Workspace& workspace,
                           const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& q_dot,
                           unsigned quantities);

/// Evaluate() for one quantity, so that a single Quantity needs no cast.
inline void Evaluate(const Model& model,
                     Workspace& workspace,
                     const Eigen::Ref<const Eigen::VectorXd>& q,
                     const Eigen::Ref<const Eigen::VectorXd>& q_dot,
                     Quantity quantity) {
  Evaluate(model, workspace, q, q_dot, static_cast<unsigned>(quantity));
}

}  // namespace servokit
