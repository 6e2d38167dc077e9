#include "models/expression_program.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace servokit {
namespace {

std::string Text(const GiNaC::ex& expression) {
  std::ostringstream stream;
  stream << expression;
  return stream.str();
}

[[noreturn]] void Unsupported(const std::string& what, const GiNaC::ex& expression) {
  throw std::invalid_argument("cannot compile " + what + ": " + Text(expression));
}

// A term of a sum whose numeric coefficient is negative is compiled as a subtraction of its
// negation, so that "a - b" costs one instruction and shares "b" with other uses.
bool HasNegativeCoefficient(const GiNaC::ex& term) {
  if (GiNaC::is_a<GiNaC::numeric>(term)) {
    return GiNaC::ex_to<GiNaC::numeric>(term).is_negative();
  }
  if (GiNaC::is_a<GiNaC::mul>(term) && term.nops() > 0) {
    // GiNaC lists a product's numeric coefficient last (when it is not 1).
    const GiNaC::ex last = term.op(term.nops() - 1);
    return GiNaC::is_a<GiNaC::numeric>(last) && GiNaC::ex_to<GiNaC::numeric>(last).is_negative();
  }
  return false;
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

// Builds one ExpressionProgram; each distinct subexpression (by GiNaC's structural order) gets
// one register, which is how common subexpressions are shared across all outputs.
class ExpressionCompiler {
 public:
  using OpCode = ExpressionProgram::OpCode;

  explicit ExpressionCompiler(const std::vector<GiNaC::ex>& input_symbols) {
    program_.num_inputs_ = input_symbols.size();
    for (std::size_t i = 0; i < input_symbols.size(); ++i) {
      if (!GiNaC::is_a<GiNaC::symbol>(input_symbols[i])) {
        Unsupported("input that is not a symbol", input_symbols[i]);
      }
      if (!registers_
               .emplace(input_symbols[i], Slot(SlotKind::kInput, static_cast<std::uint32_t>(i)))
               .second) {
        Unsupported("duplicate input symbol", input_symbols[i]);
      }
    }
  }

  ExpressionProgram Compile(const std::vector<GiNaC::ex>& outputs) && {
    std::vector<Slot> output_slots;
    output_slots.reserve(outputs.size());
    for (const GiNaC::ex& output : outputs) {
      output_slots.push_back(Register(output));
    }
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

  Slot Register(const GiNaC::ex& expression) {
    if (const auto found = registers_.find(expression); found != registers_.end()) {
      return found->second;
    }
    const Slot slot = Build(expression);
    registers_.emplace(expression, slot);
    return slot;
  }

  Slot Build(const GiNaC::ex& expression) {
    if (GiNaC::is_a<GiNaC::numeric>(expression)) {
      return Constant(NumericValue(expression));
    }
    if (GiNaC::is_a<GiNaC::constant>(expression)) {
      if (expression.is_equal(GiNaC::Pi)) {
        return Constant(std::numbers::pi);
      }
      Unsupported("constant", expression);
    }
    if (GiNaC::is_a<GiNaC::symbol>(expression)) {
      // Inputs were entered in registers_ up front; any other symbol is free.
      Unsupported("symbol that is not an input", expression);
    }
    if (GiNaC::is_a<GiNaC::add>(expression)) {
      return BuildSum(expression);
    }
    if (GiNaC::is_a<GiNaC::mul>(expression)) {
      return BuildProduct(expression);
    }
    if (GiNaC::is_a<GiNaC::power>(expression)) {
      return BuildPower(expression.op(0), expression.op(1));
    }
    if (GiNaC::is_a<GiNaC::function>(expression)) {
      return BuildFunction(expression);
    }
    Unsupported("expression", expression);
  }

  static double NumericValue(const GiNaC::ex& expression) {
    const auto& number = GiNaC::ex_to<GiNaC::numeric>(expression);
    if (!number.is_real()) {
      Unsupported("complex number", expression);
    }
    const double value = number.to_double();
    if (!std::isfinite(value)) {
      Unsupported("number outside the range of double", expression);
    }
    return value;
  }

  Slot BuildSum(const GiNaC::ex& sum) {
    std::vector<Slot> added, subtracted;
    for (std::size_t i = 0; i < sum.nops(); ++i) {
      const GiNaC::ex term = sum.op(i);
      if (HasNegativeCoefficient(term)) {
        subtracted.push_back(Register(-term));
      } else {
        added.push_back(Register(term));
      }
    }
    Slot result;
    auto next_subtracted = subtracted.begin();
    if (added.empty()) {
      result = Emit(OpCode::kNeg, *next_subtracted++);
    } else {
      result = Fold(OpCode::kAdd, added);
    }
    for (; next_subtracted != subtracted.end(); ++next_subtracted) {
      result = Emit(OpCode::kSub, result, *next_subtracted);
    }
    return result;
  }

  // Factors with negative numeric exponents go to a denominator, so that x*y^-1 is one division
  // and the rounding of a separate reciprocal is avoided. A coefficient of -1 becomes a negation.
  Slot BuildProduct(const GiNaC::ex& product) {
    std::vector<Slot> numerator, denominator;
    bool negate = false;
    for (std::size_t i = 0; i < product.nops(); ++i) {
      const GiNaC::ex factor = product.op(i);
      if (GiNaC::is_a<GiNaC::numeric>(factor)) {
        if (factor.is_equal(-1)) {
          negate = true;
        } else {
          numerator.insert(numerator.begin(), Register(factor));
        }
      } else if (GiNaC::is_a<GiNaC::power>(factor) && GiNaC::is_a<GiNaC::numeric>(factor.op(1)) &&
                 GiNaC::ex_to<GiNaC::numeric>(factor.op(1)).is_negative()) {
        denominator.push_back(Register(GiNaC::pow(factor.op(0), -factor.op(1))));
      } else {
        numerator.push_back(Register(factor));
      }
    }
    Slot result;
    if (denominator.empty()) {
      result = Fold(OpCode::kMul, numerator);
    } else if (numerator.empty()) {
      result = Emit(OpCode::kReciprocal, Fold(OpCode::kMul, denominator));
    } else {
      result = Emit(OpCode::kDiv, Fold(OpCode::kMul, numerator), Fold(OpCode::kMul, denominator));
    }
    return negate ? Emit(OpCode::kNeg, result) : result;
  }

  Slot BuildPower(const GiNaC::ex& base, const GiNaC::ex& exponent) {
    if (!GiNaC::is_a<GiNaC::numeric>(exponent)) {
      return Emit(OpCode::kPow, Register(base), Register(exponent));
    }
    const auto& number = GiNaC::ex_to<GiNaC::numeric>(exponent);
    if (number.is_negative()) {
      return Emit(OpCode::kReciprocal, Register(GiNaC::pow(base, -exponent)));
    }
    if (number.is_pos_integer()) {
      return IntegerPower(Register(base), number, exponent);
    }
    if (number.is_rational() && number.denom().is_equal(2)) {
      // x^(p/2) = sqrt(x)^p: one square root, shared with every other power of the same base.
      const Slot root = number.numer().is_equal(1) ? Emit(OpCode::kSqrt, Register(base))
                                                   : Register(GiNaC::sqrt(base));
      return IntegerPower(root, number.numer(), exponent);
    }
    return Emit(OpCode::kPow, Register(base), Register(exponent));
  }

  Slot IntegerPower(Slot base, const GiNaC::numeric& exponent, const GiNaC::ex& expression) {
    if (exponent > GiNaC::numeric(kMaxIntegerExponent)) {
      Unsupported("power with an exponent above 2^31", expression);
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

  Slot BuildFunction(const GiNaC::ex& call) {
    static const std::unordered_map<std::string, OpCode> kUnary = {
        {"sin", OpCode::kSin},   {"cos", OpCode::kCos},   {"tan", OpCode::kTan},
        {"asin", OpCode::kAsin}, {"acos", OpCode::kAcos}, {"atan", OpCode::kAtan},
        {"exp", OpCode::kExp},   {"log", OpCode::kLog},   {"sinh", OpCode::kSinh},
        {"cosh", OpCode::kCosh}, {"tanh", OpCode::kTanh}, {"abs", OpCode::kAbs},
    };
    const std::string name = GiNaC::ex_to<GiNaC::function>(call).get_name();
    if (name == "atan2" && call.nops() == 2) {
      return Emit(OpCode::kAtan2, Register(call.op(0)), Register(call.op(1)));
    }
    const auto found = kUnary.find(name);
    if (found == kUnary.end() || call.nops() != 1) {
      Unsupported("function", call);
    }
    return Emit(found->second, Register(call.op(0)));
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

  ExpressionProgram program_;
  std::map<GiNaC::ex, Slot, GiNaC::ex_is_less> registers_;
  std::map<double, std::uint32_t> constants_;
  std::vector<PendingInstruction> pending_;
};

ExpressionProgram CompileExpressions(const std::vector<GiNaC::ex>& outputs,
                                     const std::vector<GiNaC::ex>& input_symbols) {
  return ExpressionCompiler(input_symbols).Compile(outputs);
}

// Hot loop of every numeric algorithm (sweeps call it ~1e6 times per second): one switch per
// instruction over a contiguous array, results written in instruction order.
void ExpressionProgram::Evaluate(const double* inputs, double* registers, double* outputs) const {
  std::copy_n(inputs, num_inputs_, registers);
  std::copy(constants_.begin(), constants_.end(), registers + num_inputs_);
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
  for (std::size_t i = 0; i < output_registers_.size(); ++i) {
    outputs[i] = registers[output_registers_[i]];
  }
}

}  // namespace servokit
