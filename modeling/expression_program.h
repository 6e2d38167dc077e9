#pragma once
// A compiled numeric evaluator for a list of GiNaC expressions (docs/model-files.md, "How
// servokit reads a model"). GiNaC is slow per call and not thread-safe, so expressions are compiled
// once into a flat list of register instructions in which every common subexpression is computed
// once; evaluating that list needs neither GiNaC nor memory allocation.
#include <ginac/ginac.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "modeling/canonical_expression.h"
#include "modeling/dual_number.h"

namespace servokit {

/// An immutable, thread-shareable evaluator of several expressions in the same inputs.
///
/// Register file layout (the caller owns it, so that one program serves many threads):
/// [inputs | constants | one register per instruction]. Evaluate() copies the inputs and the
/// constants in, runs the instructions in order and copies the output registers out.
class ExpressionProgram {
 public:
  /// An empty program: no inputs, no outputs.
  ExpressionProgram() = default;

  /// Size of the `inputs` array Evaluate() reads.
  std::size_t num_inputs() const { return num_inputs_; }
  /// Size of the `outputs` array Evaluate() writes.
  std::size_t num_outputs() const { return output_registers_.size(); }
  /// Size of the `registers` scratch array Evaluate() needs.
  std::size_t num_registers() const {
    return num_inputs_ + constants_.size() + instructions_.size();
  }
  /// Number of instructions run per evaluation (shared subexpressions count once).
  std::size_t num_instructions() const { return instructions_.size(); }

  /// Evaluates every output. `inputs` has num_inputs() values, `registers` is scratch space of
  /// num_registers() values (overwritten), `outputs` receives num_outputs() values. Allocates
  /// nothing and changes nothing in the program, so threads may share one program if each
  /// passes its own registers. Domain errors (log of a negative number) give NaN, as in <cmath>.
  void Evaluate(const double* inputs, double* registers, double* outputs) const;

  /// Taylor-mode forward differentiation (modeling/taylor_evaluation.cpp): given every input as a
  /// truncated Taylor series x_i(t) = sum_k x_ik t^k, k = 0..degree, computes every output's
  /// coefficients y_k = y^(k)(0) / k! through the instructions, without expanding a formula: the
  /// cost is (degree + 1)^2 operations per instruction. `input_coefficients` holds num_inputs()
  /// rows of degree + 1 (input i's coefficient k at i * (degree + 1) + k), `registers` scratch of
  /// num_registers() * (degree + 1) values, `output_coefficients` receives num_outputs() rows of
  /// degree + 1. Degree 1 with x_i1 the direction v gives the directional derivative (a Jacobian
  /// column for v = e_j). Where a derivative does not exist (sqrt or abs at 0, log at 0) the
  /// coefficients are not finite, as in <cmath>.
  void EvaluateTaylor(int degree,
                      const double* input_coefficients,
                      double* registers,
                      double* output_coefficients) const;
  /// The same over dual numbers (modeling/dual_number.h): each coefficient carries its
  /// derivative in one direction, which the inputs' tangents give (a start or an input of a
  /// motion, modeling/motion_series.h), exactly rather than as a difference.
  void EvaluateTaylor(int degree,
                      const Dual* input_coefficients,
                      Dual* registers,
                      Dual* output_coefficients) const;
  /// The same over kChunk directions at once (DualChunk): the values and each function's
  /// derivative computed once for all of them (forward-mode Jacobians, a chunk of columns per
  /// pass); every direction's tangent has the bits of a pass over Dual along it.
  void EvaluateTaylor(int degree,
                      const DualChunk* input_coefficients,
                      DualChunk* registers,
                      DualChunk* output_coefficients) const;

  /// Forward-mode Jacobian columns that cost what the seeded inputs reach, not the whole program
  /// per chunk of columns (Workspace::DifferentiateForwardMode). `registers` hold a pass of
  /// EvaluateTaylor(0, ...) over DualChunk at the point with every tangent zero; the caller
  /// seeds the tangents of some inputs and lists them in `carrying`. Runs each instruction that
  /// reads a register carrying a tangent, as that pass runs it (the same bits), and appends its
  /// result to `carrying`; every other instruction's tangent is zero and its value unchanged, so
  /// those are skipped. Then the outputs' registers hold the directional derivatives.
  /// `carries` is the caller's scratch (a flag per register, all 0 between calls).
  void PropagateTangents(DualChunk* registers,
                         std::vector<std::uint32_t>& carrying,
                         std::vector<char>& carries) const;
  /// Sets the tangents of `carrying` back to zero (values kept) and empties it: `registers` are
  /// ready for the next PropagateTangents.
  void ClearTangents(DualChunk* registers,
                     std::vector<std::uint32_t>& carrying,
                     std::vector<char>& carries) const;
  /// The register that holds output k.
  std::uint32_t output_register(std::size_t k) const { return output_registers_[k]; }

  /// For a caller that keeps `registers` (num_registers() values) for this program alone: writes
  /// the constants into them, once.
  void LoadConstants(double* registers) const;
  /// Evaluate() on registers that hold the constants (LoadConstants) and the inputs (in
  /// registers[0, num_inputs())), writing output k to *outputs[k]: nothing copied in or out but
  /// the results, for a hot loop that evaluates the program into the same places again and again.
  void EvaluateLoaded(double* registers, double* const* outputs) const;

 private:
  /// The operations of the instruction list. Binary operations read registers `a` and `b`; unary
  /// ones read `a`; kPowInt raises register `a` to the positive integer power `b`.
  enum class OpCode : std::uint8_t {
    kAdd,
    kSub,
    kMul,
    kDiv,
    kNeg,
    kReciprocal,
    kPowInt,
    kPow,
    kSqrt,
    kSin,
    kCos,
    kTan,
    kAsin,
    kAcos,
    kAtan,
    kAtan2,
    kExp,
    kLog,
    kSinh,
    kCosh,
    kTanh,
    kAbs,
  };

  /// One instruction; instruction i writes register num_inputs() + constants + i.
  struct Instruction {
    OpCode op;
    std::uint32_t a;
    std::uint32_t b;
  };

  // Runs the instructions on registers holding the inputs and the constants.
  void Run(double* registers) const;
  // One instruction of RunTaylor, series of n coefficients, scratch of 4 n (taylor_evaluation).
  template <typename T>
  static void RunInstruction(const Instruction& instruction,
                             std::size_t n,
                             T* registers,
                             std::uint32_t result_index,
                             T* scratch);
  // Binary operations read register b; kPowInt's b is its exponent.
  static bool ReadsSecondRegister(OpCode op);
  // EvaluateTaylor for coefficients of type T (modeling/taylor_evaluation.cpp).
  template <typename T>
  void RunTaylor(int degree,
                 const T* input_coefficients,
                 T* registers,
                 T* output_coefficients) const;

  friend class ExpressionCompiler;  // expression_program.cpp builds programs
  std::size_t num_inputs_ = 0;
  std::vector<double> constants_;
  std::vector<Instruction> instructions_;
  std::vector<std::uint32_t> output_registers_;
};

/// Compiles `outputs` into one program whose inputs are `input_symbols` (GiNaC symbols, in the
/// order Evaluate() expects them); output k of the program is outputs[k]. Supports numbers
/// (rational or float, real and finite), the input symbols, Pi, sums, products, powers (integer,
/// half-integer and general exponents) and the functions sin cos tan asin acos atan atan2 exp
/// log sinh cosh tanh abs (sqrt is a power in GiNaC). Throws std::invalid_argument naming the
/// construct for anything else, including a symbol that is not an input and a duplicate or
/// non-symbol entry in `input_symbols`.
ExpressionProgram CompileExpressions(const std::vector<GiNaC::ex>& outputs,
                                     const std::vector<GiNaC::ex>& input_symbols);

/// The same, in `canonical`: a store whose ordered symbols are `input_symbols` and which may
/// hold the expressions already (read by ExpressionParser and handed out by
/// CanonicalExpressions::Expression), so that they are not converted again. The loader compiles
/// all of a model's programs in one store.
ExpressionProgram CompileExpressions(const std::vector<GiNaC::ex>& outputs,
                                     const std::vector<GiNaC::ex>& input_symbols,
                                     CanonicalExpressions& canonical);
/// The same for forms already in `canonical` (ExpressionParser's), without GiNaC.
ExpressionProgram CompileExpressions(const std::vector<CanonicalExpressions::Scaled>& outputs,
                                     const std::vector<GiNaC::ex>& input_symbols,
                                     CanonicalExpressions& canonical);

}  // namespace servokit
