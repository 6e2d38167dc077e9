#include "modeling/expression_program.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

#include "modeling/canonical_expression.h"

namespace servokit {
namespace {

[[noreturn]] void Unsupported(const std::string& what, const std::string& text) {
  throw std::invalid_argument("cannot compile " + what + ": " + text);
}

enum class SlotKind : std::uint8_t { kInput, kConstant, kInstruction };

// A register before the final layout [inputs | constants | instructions] is known.
struct Slot {
  Slot() = default;
  Slot(SlotKind slot_kind, std::uint32_t slot_index) : kind(slot_kind), index(slot_index) {}
  SlotKind kind = SlotKind::kInput;
  std::uint32_t index = 0;
};

}  // namespace

// Builds one ExpressionProgram from the canonical form of the expressions
// (modeling/canonical_expression.h): the instructions follow the canonical order of operands, so
// a program computes the same bits in every run, and each node of the canonical DAG gets one
// register, which is how common subexpressions are shared across all outputs.
class ExpressionCompiler {
 public:
  using OpCode = ExpressionProgram::OpCode;
  using Scaled = CanonicalExpressions::Scaled;
  using Kind = CanonicalExpressions::Kind;
  using NodeId = CanonicalExpressions::NodeId;

  // Compiles in `canonical`, or in a store of its own when that is null.
  ExpressionCompiler(const std::vector<GiNaC::ex>& input_symbols, CanonicalExpressions* canonical)
      : own_canonical_(canonical == nullptr ? std::make_unique<CanonicalExpressions>(input_symbols)
                                            : nullptr),
        canonical_(canonical == nullptr ? *own_canonical_ : *canonical) {
    program_.num_inputs_ = input_symbols.size();
    for (std::size_t i = 0; i < input_symbols.size(); ++i) {
      if (!GiNaC::is_a<GiNaC::symbol>(input_symbols[i])) {
        Unsupported("input that is not a symbol", CanonicalText(input_symbols[i]));
      }
      const NodeId node = canonical_.Add(input_symbols[i]).node;
      if (!node_slots_.emplace(node, Slot(SlotKind::kInput, static_cast<std::uint32_t>(i)))
               .second) {
        Unsupported("duplicate input symbol", CanonicalText(input_symbols[i]));
      }
    }
  }

  ExpressionProgram Compile(const std::vector<GiNaC::ex>& outputs) && {
    std::vector<Scaled> values;
    values.reserve(outputs.size());
    for (const GiNaC::ex& output : outputs) values.push_back(canonical_.Add(output));
    return std::move(*this).Compile(values);
  }

  // `outputs` are forms in the compiler's store.
  ExpressionProgram Compile(const std::vector<Scaled>& outputs) && {
    std::vector<Slot> output_slots;
    output_slots.reserve(outputs.size());
    for (const Scaled& output : outputs) output_slots.push_back(RegisterScaled(output));
    // Registers hold [inputs | constants | instructions], but constants were numbered apart
    // while compiling; now that their count is known, place them and the instructions.
    const auto constant_base = static_cast<std::uint32_t>(program_.num_inputs_);
    const auto instruction_base =
        static_cast<std::uint32_t>(constant_base + program_.constants_.size());
    const auto resolve = [&](Slot slot) -> std::uint32_t {
      switch (slot.kind) {
        case SlotKind::kInput:
          return slot.index;
        case SlotKind::kConstant:
          return constant_base + slot.index;
        case SlotKind::kInstruction:
          return instruction_base + slot.index;
      }
      return 0;
    };
    for (const PendingInstruction& pending : pending_) {
      program_.instructions_.push_back(
          {pending.op, resolve(pending.a),
           pending.op == OpCode::kPowInt ? pending.exponent : resolve(pending.b)});
    }
    for (const Slot slot : output_slots) {
      program_.output_registers_.push_back(resolve(slot));
    }
    return std::move(program_);
  }

 private:
  struct PendingInstruction {
    OpCode op;
    Slot a;
    Slot b;
    std::uint32_t exponent = 0;  // kPowInt only
  };

  // For errors only: `source` is the node an error names, printed only when one is raised (the
  // text of a power of a long sum is as long as the sum).
  std::string Text(const Scaled& value) const { return canonical_.Text(value); }

  // coefficient * node, the coefficient's multiplication shared like any subexpression.
  Slot RegisterScaled(const Scaled& value) {
    if (value.node == canonical_.one()) return Constant(NumericValue(value.coefficient));
    if (value.coefficient == 1) return RegisterNode(value.node);
    const auto key = std::make_pair(value.node, NumericValue(value.coefficient));
    if (const auto found = scaled_slots_.find(key); found != scaled_slots_.end()) {
      return found->second;
    }
    const Slot node = RegisterNode(value.node);
    const Slot slot = value.coefficient == -1
                          ? Emit(OpCode::kNeg, node)
                          : Emit(OpCode::kMul, Constant(NumericValue(value.coefficient)), node);
    scaled_slots_.emplace(key, slot);
    return slot;
  }

  Slot RegisterNode(NodeId id) {
    if (const auto found = node_slots_.find(id); found != node_slots_.end()) return found->second;
    const Slot slot = BuildNode(id);
    node_slots_.emplace(id, slot);
    return slot;
  }

  Slot BuildNode(NodeId id) {
    const CanonicalExpressions::Node& node = canonical_.node(id);
    switch (node.kind) {
      case Kind::kNumber:
        return Constant(NumericValue(node.number));
      case Kind::kConstant:
        if (node.original.is_equal(GiNaC::Pi)) return Constant(std::numbers::pi);
        Unsupported("constant", node.name);
      case Kind::kSymbol:
        // Inputs were entered in node_slots_ up front; any other symbol is free.
        Unsupported("symbol that is not an input", node.name);
      case Kind::kSum:
        return BuildSum(node);
      case Kind::kProduct:
        return BuildProduct(node);
      case Kind::kPower:
        return BuildPower(node.operands[0], node.operands[1], id);
      case Kind::kFunction:
        return BuildFunction(node, id);
      case Kind::kOpaque:
        break;
    }
    Unsupported("expression", Text({1, id}));
  }

  static double NumericValue(const GiNaC::numeric& number) {
    if (!number.is_real()) Unsupported("complex number", CanonicalText(number));
    const double value = number.to_double();
    if (!std::isfinite(value)) {
      Unsupported("number outside the range of double", CanonicalText(number));
    }
    return value;
  }

  // First term (positive by the canonical sign convention), then each further one added or
  // subtracted in order. A sum and its negation thus give exactly negated bits.
  Slot BuildSum(const CanonicalExpressions::Node& sum) {
    Slot result = RegisterScaled(sum.operands.front());
    for (std::size_t i = 1; i < sum.operands.size(); ++i) {
      const Scaled& term = sum.operands[i];
      const bool negative = term.coefficient.is_real() && term.coefficient.is_negative();
      const GiNaC::numeric magnitude = negative ? -term.coefficient : term.coefficient;
      const Slot term_slot = RegisterScaled({magnitude, term.node});
      result = Emit(negative ? OpCode::kSub : OpCode::kAdd, result, term_slot);
    }
    return result;
  }

  // Factors with negative numeric exponents go to a denominator, so that x*y^-1 is one division
  // and the rounding of a separate reciprocal is avoided.
  Slot BuildProduct(const CanonicalExpressions::Node& product) {
    std::vector<Slot> numerator, denominator;
    for (const Scaled& factor : product.operands) {
      const CanonicalExpressions::Node& node = canonical_.node(factor.node);
      const bool reciprocal =
          node.kind == Kind::kPower && node.operands[1].node == canonical_.one() &&
          node.operands[1].coefficient.is_real() && node.operands[1].coefficient.is_negative();
      if (reciprocal) {
        denominator.push_back(
            PowerSlot(node.operands[0], -node.operands[1].coefficient, factor.node));
      } else {
        numerator.push_back(RegisterNode(factor.node));
      }
    }
    if (denominator.empty()) return Fold(OpCode::kMul, numerator);
    if (numerator.empty()) return Emit(OpCode::kReciprocal, Fold(OpCode::kMul, denominator));
    return Emit(OpCode::kDiv, Fold(OpCode::kMul, numerator), Fold(OpCode::kMul, denominator));
  }

  Slot BuildPower(const Scaled& base, const Scaled& exponent, NodeId source) {
    if (exponent.node != canonical_.one()) {
      return Emit(OpCode::kPow, RegisterScaled(base), RegisterScaled(exponent));
    }
    const GiNaC::numeric& number = exponent.coefficient;
    if (number.is_real() && number.is_negative()) {
      return Emit(OpCode::kReciprocal, PowerSlot(base, -number, source));
    }
    return PowerSlot(base, number, source);
  }

  // base^exponent for a positive numeric exponent, shared between every use: x^(1/2) and
  // x^(3/2) share one square root.
  Slot PowerSlot(const Scaled& base, const GiNaC::numeric& exponent, NodeId source) {
    const auto key =
        std::make_tuple(base.node, NumericValue(base.coefficient), NumericValue(exponent));
    if (const auto found = power_slots_.find(key); found != power_slots_.end()) {
      return found->second;
    }
    Slot slot;
    if (exponent.is_pos_integer()) {
      slot = IntegerPower(RegisterScaled(base), exponent, source);
    } else if (exponent.is_rational() && exponent.denom().is_equal(2)) {
      // x^(p/2) = sqrt(x)^p: one square root, shared with every other power of the same base.
      const Slot root = exponent.numer().is_equal(1)
                            ? Emit(OpCode::kSqrt, RegisterScaled(base))
                            : PowerSlot(base, GiNaC::numeric(1, 2), source);
      slot = exponent.numer().is_equal(1) ? root : IntegerPower(root, exponent.numer(), source);
    } else {
      slot = Emit(OpCode::kPow, RegisterScaled(base), Constant(NumericValue(exponent)));
    }
    power_slots_.emplace(key, slot);
    return slot;
  }

  Slot IntegerPower(Slot base, const GiNaC::numeric& exponent, NodeId source) {
    if (exponent > GiNaC::numeric(kMaxIntegerExponent)) {
      Unsupported("power with an exponent above 2^31", Text({1, source}));
    }
    const auto power = static_cast<std::uint32_t>(exponent.to_long());
    if (power == 1) {
      return base;
    }
    if (power == 2) {
      return Emit(OpCode::kMul, base, base);
    }
    pending_.push_back({OpCode::kPowInt, base, Slot(), power});
    return LastInstruction();
  }

  Slot BuildFunction(const CanonicalExpressions::Node& call, NodeId source) {
    static const std::unordered_map<std::string, OpCode> kUnary = {
        {"sin", OpCode::kSin},   {"cos", OpCode::kCos},   {"tan", OpCode::kTan},
        {"asin", OpCode::kAsin}, {"acos", OpCode::kAcos}, {"atan", OpCode::kAtan},
        {"exp", OpCode::kExp},   {"log", OpCode::kLog},   {"sinh", OpCode::kSinh},
        {"cosh", OpCode::kCosh}, {"tanh", OpCode::kTanh}, {"abs", OpCode::kAbs},
    };
    if (call.name == "atan2" && call.operands.size() == 2) {
      return Emit(OpCode::kAtan2, RegisterScaled(call.operands[0]),
                  RegisterScaled(call.operands[1]));
    }
    const auto found = kUnary.find(call.name);
    if (found == kUnary.end() || call.operands.size() != 1) {
      Unsupported("function", Text({1, source}));
    }
    return Emit(found->second, RegisterScaled(call.operands[0]));
  }

  Slot Constant(double value) {
    const auto [found, inserted] =
        constants_.emplace(value, static_cast<std::uint32_t>(program_.constants_.size()));
    if (inserted) {
      program_.constants_.push_back(value);
    }
    return Slot(SlotKind::kConstant, found->second);
  }

  Slot Emit(OpCode op, Slot a, Slot b = Slot()) {
    pending_.push_back({op, a, b});
    return LastInstruction();
  }

  Slot LastInstruction() const {
    return Slot(SlotKind::kInstruction, static_cast<std::uint32_t>(pending_.size() - 1));
  }

  // Left fold of a non-empty operand list with a binary operation.
  Slot Fold(OpCode op, const std::vector<Slot>& operands) {
    Slot result = operands.front();
    for (std::size_t i = 1; i < operands.size(); ++i) {
      result = Emit(op, result, operands[i]);
    }
    return result;
  }

  // Integer exponents are stored in 32 bits; any power beyond this over- or underflows anyway.
  static constexpr long kMaxIntegerExponent = 1L << 31;

  std::unique_ptr<CanonicalExpressions> own_canonical_;
  CanonicalExpressions& canonical_;
  ExpressionProgram program_;
  std::unordered_map<NodeId, Slot> node_slots_;
  std::map<std::pair<NodeId, double>, Slot> scaled_slots_;
  std::map<std::tuple<NodeId, double, double>, Slot> power_slots_;
  // Constants by value; -0.0 and 0.0 compare equal and share a register.
  std::map<double, std::uint32_t> constants_;
  std::vector<PendingInstruction> pending_;
};

ExpressionProgram CompileExpressions(const std::vector<GiNaC::ex>& outputs,
                                     const std::vector<GiNaC::ex>& input_symbols) {
  return ExpressionCompiler(input_symbols, nullptr).Compile(outputs);
}

ExpressionProgram CompileExpressions(const std::vector<GiNaC::ex>& outputs,
                                     const std::vector<GiNaC::ex>& input_symbols,
                                     CanonicalExpressions& canonical) {
  return ExpressionCompiler(input_symbols, &canonical).Compile(outputs);
}

ExpressionProgram CompileExpressions(const std::vector<CanonicalExpressions::Scaled>& outputs,
                                     const std::vector<GiNaC::ex>& input_symbols,
                                     CanonicalExpressions& canonical) {
  return ExpressionCompiler(input_symbols, &canonical).Compile(outputs);
}

// Hot loop of every numeric algorithm (sweeps call it ~1e6 times per second): one switch per
// instruction over a contiguous array, results written in instruction order.
void ExpressionProgram::Evaluate(const double* inputs, double* registers, double* outputs) const {
  std::copy_n(inputs, num_inputs_, registers);
  LoadConstants(registers);
  Run(registers);
  for (std::size_t i = 0; i < output_registers_.size(); ++i) {
    outputs[i] = registers[output_registers_[i]];
  }
}

void ExpressionProgram::LoadConstants(double* registers) const {
  std::copy(constants_.begin(), constants_.end(), registers + num_inputs_);
}

void ExpressionProgram::EvaluateLoaded(double* registers, double* const* outputs) const {
  Run(registers);
  for (std::size_t i = 0; i < output_registers_.size(); ++i) {
    *outputs[i] = registers[output_registers_[i]];
  }
}

void ExpressionProgram::Run(double* registers) const {
  double* result = registers + num_inputs_ + constants_.size();
  for (const Instruction& instruction : instructions_) {
    const double a = registers[instruction.a];
    double value = 0.0;
    switch (instruction.op) {
      case OpCode::kAdd:
        value = a + registers[instruction.b];
        break;
      case OpCode::kSub:
        value = a - registers[instruction.b];
        break;
      case OpCode::kMul:
        value = a * registers[instruction.b];
        break;
      case OpCode::kDiv:
        value = a / registers[instruction.b];
        break;
      case OpCode::kNeg:
        value = -a;
        break;
      case OpCode::kReciprocal:
        value = 1.0 / a;
        break;
      case OpCode::kPowInt: {
        // Binary exponentiation: exact for the small exponents of mechanics, log2(b) products.
        double base = a;
        value = 1.0;
        for (std::uint32_t exponent = instruction.b; exponent != 0; exponent >>= 1) {
          if ((exponent & 1u) != 0) {
            value *= base;
          }
          base *= base;
        }
        break;
      }
      case OpCode::kPow:
        value = std::pow(a, registers[instruction.b]);
        break;
      case OpCode::kSqrt:
        value = std::sqrt(a);
        break;
      case OpCode::kSin:
        value = std::sin(a);
        break;
      case OpCode::kCos:
        value = std::cos(a);
        break;
      case OpCode::kTan:
        value = std::tan(a);
        break;
      case OpCode::kAsin:
        value = std::asin(a);
        break;
      case OpCode::kAcos:
        value = std::acos(a);
        break;
      case OpCode::kAtan:
        value = std::atan(a);
        break;
      case OpCode::kAtan2:
        value = std::atan2(a, registers[instruction.b]);
        break;
      case OpCode::kExp:
        value = std::exp(a);
        break;
      case OpCode::kLog:
        value = std::log(a);
        break;
      case OpCode::kSinh:
        value = std::sinh(a);
        break;
      case OpCode::kCosh:
        value = std::cosh(a);
        break;
      case OpCode::kTanh:
        value = std::tanh(a);
        break;
      case OpCode::kAbs:
        value = std::abs(a);
        break;
    }
    *result++ = value;
  }
}

}  // namespace servokit
