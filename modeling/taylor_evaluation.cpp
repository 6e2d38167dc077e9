// ExpressionProgram::EvaluateTaylor: univariate Taylor-mode forward differentiation through the
// compiled instruction list (A. Griewank, A. Walther, "Evaluating Derivatives", 2nd ed., SIAM
// 2008, Sect. 13.2, Table 13.1 and 13.2). Each register holds a truncated Taylor series
// c(t) = c_0 + c_1 t + ... + c_d t^d; each instruction maps its operands' series to its result's
// with the recurrences below, O(d^2) operations, and no formula is ever expanded: the cost
// grows with the program (shared subexpressions count once), not with the size of an expanded
// derivative. Coefficient 0 is computed as Evaluate() computes the value, to the same bits.
//
// The elementary functions use that their derivative solves a linear relation with a series
// known one coefficient ahead: for c = F(a) with c' w = v (w and v series), coefficient k - 1 of
// the product gives
//     k c_k w_0 = v_(k-1) - sum_(j=1)^(k-1) j c_j w_(k-j).
//
// The coefficients are doubles, or dual numbers (modeling/dual_number.h): then every coefficient
// carries its derivative in one direction (a start or an input of a motion) along, exactly, or
// in a chunk of directions at once.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "modeling/dual_number.h"
#include "modeling/expression_program.h"

namespace servokit {
namespace {
using std::abs;
using std::acos;
using std::asin;
using std::atan;
using std::atan2;
using std::cos;
using std::cosh;
using std::exp;
using std::log;
using std::pow;
using std::sin;
using std::sinh;
using std::sqrt;
using std::tan;
using std::tanh;

// The recurrences, for coefficients of type T (the functions of <cmath> for double, of
// modeling/dual_number.h for Dual and DualChunk, found by argument-dependent lookup).
template <typename T>
struct TaylorRules {
  using Series = std::span<T>;
  using ConstSeries = std::span<const T>;

  // c = a * b (Cauchy product); c may not alias a or b.
  static void Multiply(ConstSeries a, ConstSeries b, Series c) {
    for (std::size_t k = 0; k < c.size(); ++k) {
      T sum = 0.0;
      for (std::size_t j = 0; j <= k; ++j) sum += a[j] * b[k - j];
      c[k] = sum;
    }
    c[0] = a[0] * b[0];  // the value's bits, as Evaluate
  }

  // c = a / b: c_k = (a_k - sum_(j<k) c_j b_(k-j)) / b_0. `a` empty means 1 (a reciprocal).
  static void Divide(ConstSeries a, ConstSeries b, Series c) {
    c[0] = a.empty() ? 1.0 / b[0] : a[0] / b[0];
    for (std::size_t k = 1; k < c.size(); ++k) {
      T sum = a.empty() ? 0.0 : a[k];
      for (std::size_t j = 0; j < k; ++j) sum -= c[j] * b[k - j];
      c[k] = sum / b[0];
    }
  }

  // c = a^n, n >= 1, by the same binary exponentiation as Evaluate (so c_0 has its bits).
  static void PowerInteger(ConstSeries a, std::uint32_t n, Series c, Series base, Series product) {
    std::fill(c.begin(), c.end(), 0.0);
    c[0] = 1.0;
    std::copy(a.begin(), a.end(), base.begin());
    for (std::uint32_t exponent = n; exponent != 0; exponent >>= 1) {
      if ((exponent & 1u) != 0) {
        Multiply(c, base, product);
        std::copy(product.begin(), product.end(), c.begin());
      }
      if (exponent > 1) {
        Multiply(base, base, product);
        std::copy(product.begin(), product.end(), base.begin());
      }
    }
  }

  // c = F(a) given c_0, where c' w = a' (w a series whose coefficient k - 1 is known before c_k):
  // k c_k w_0 = k a_k - sum_(j=1)^(k-1) j c_j w_(k-j). `sign` -1 gives c' w = -a'.
  static void IntegrateQuotient(ConstSeries a, ConstSeries w, double sign, Series c) {
    for (std::size_t k = 1; k < c.size(); ++k) {
      T sum = sign * double(k) * a[k];
      for (std::size_t j = 1; j < k; ++j) sum -= double(j) * c[j] * w[k - j];
      c[k] = sum / (double(k) * w[0]);
    }
  }

  // c_k = (1/k) sum_(j=1)^k j a_j partner_(k-j) * sign: the recurrence of exp (partner = c),
  // sin/cos and sinh/cosh (partner = the other function), for coefficient k alone.
  static T ChainCoefficient(ConstSeries a, ConstSeries partner, std::size_t k, double sign) {
    T sum = 0.0;
    for (std::size_t j = 1; j <= k; ++j) sum += double(j) * a[j] * partner[k - j];
    return sign * sum / double(k);
  }

  // s = sin a, co = cos a (or sinh, cosh with `hyperbolic`), both computed: each needs the other.
  static void SineCosine(ConstSeries a, bool hyperbolic, Series s, Series co) {
    s[0] = hyperbolic ? sinh(a[0]) : sin(a[0]);
    co[0] = hyperbolic ? cosh(a[0]) : cos(a[0]);
    for (std::size_t k = 1; k < s.size(); ++k) {
      s[k] = ChainCoefficient(a, co, k, 1.0);
      co[k] = ChainCoefficient(a, s, k, hyperbolic ? 1.0 : -1.0);
    }
  }

  // t = tan a (t' = (1 + t^2) a') or tanh a (t' = (1 - t^2) a'); w is 1 +- t^2, built along.
  static void Tangent(ConstSeries a, bool hyperbolic, Series t, Series w) {
    const double sign = hyperbolic ? -1.0 : 1.0;
    t[0] = hyperbolic ? tanh(a[0]) : tan(a[0]);
    w[0] = 1.0 + sign * t[0] * t[0];
    for (std::size_t k = 1; k < t.size(); ++k) {
      t[k] = ChainCoefficient(a, w, k, 1.0);
      T square = 0.0;
      for (std::size_t i = 0; i <= k; ++i) square += t[i] * t[k - i];
      w[k] = sign * square;
    }
  }

  // c = sqrt(a): c_k = (a_k - sum_(j=1)^(k-1) c_j c_(k-j)) / (2 c_0).
  static void SquareRoot(ConstSeries a, Series c) {
    c[0] = sqrt(a[0]);
    for (std::size_t k = 1; k < c.size(); ++k) {
      T sum = a[k];
      for (std::size_t j = 1; j < k; ++j) sum -= c[j] * c[k - j];
      c[k] = sum / (2.0 * c[0]);
    }
  }

  // c = exp(a) with c_0 given (exp(a_0), or pow's value for a^b = exp(b log a)).
  static void Exponential(ConstSeries a, Series c) {
    for (std::size_t k = 1; k < c.size(); ++k) c[k] = ChainCoefficient(a, c, k, 1.0);
  }

  // c = log(a): c' a = a', so k c_k a_0 = k a_k - sum_(j=1)^(k-1) j c_j a_(k-j).
  static void Logarithm(ConstSeries a, Series c) {
    c[0] = log(a[0]);
    IntegrateQuotient(a, a, 1.0, c);
  }

  // c = a^r for a constant r: c' a = r a' c, so
  // k a_0 c_k = sum_(j=1)^k (r j - (k - j)) a_j c_(k-j).
  static void PowerConstant(ConstSeries a, T r, Series c) {
    for (std::size_t k = 1; k < c.size(); ++k) {
      T sum = 0.0;
      for (std::size_t j = 1; j <= k; ++j) {
        sum += (r * double(j) - double(k - j)) * a[j] * c[k - j];
      }
      c[k] = sum / (double(k) * a[0]);
    }
  }

  // w = shift + sign * (a^2 (+ b^2)): the series 1 - a^2, 1 + a^2 and a^2 + b^2.
  static void SumOfSquares(ConstSeries a, ConstSeries b, double shift, double sign, Series w) {
    for (std::size_t k = 0; k < w.size(); ++k) {
      T sum = 0.0;
      for (std::size_t i = 0; i <= k; ++i) {
        sum += a[i] * a[k - i] + (b.empty() ? 0.0 : b[i] * b[k - i]);
      }
      w[k] = (k == 0 ? shift : 0.0) + sign * sum;
    }
  }

  // c = atan2(a, b): c' (a^2 + b^2) = b a' - a b'. Coefficient k - 1 of the right side is
  // v = sum_(i=0)^(k-1) (k - i) (b_i a_(k-i) - a_i b_(k-i)).
  static void ArcTangent2(ConstSeries a, ConstSeries b, Series w, Series c) {
    c[0] = atan2(a[0], b[0]);
    SumOfSquares(a, b, 0.0, 1.0, w);
    for (std::size_t k = 1; k < c.size(); ++k) {
      T sum = 0.0;
      for (std::size_t i = 0; i < k; ++i)
        sum += double(k - i) * (b[i] * a[k - i] - a[i] * b[k - i]);
      for (std::size_t j = 1; j < k; ++j) sum -= double(j) * c[j] * w[k - j];
      c[k] = sum / (double(k) * w[0]);
    }
  }

  // c = |a|: the series of a times its sign, the sign of the first nonzero coefficient where
  // a_0 = 0 (the one-sided series for t > 0).
  static void AbsoluteValue(ConstSeries a, Series c) {
    double sign = 0.0;
    for (const T& coefficient : a) {
      if (ValueOf(coefficient) != 0.0) {
        sign = ValueOf(coefficient) > 0.0 ? 1.0 : -1.0;
        break;
      }
    }
    for (std::size_t k = 0; k < c.size(); ++k) c[k] = sign * a[k];
    c[0] = abs(a[0]);
  }
};

}  // namespace

template <typename T>
void ExpressionProgram::RunInstruction(const Instruction& instruction,
                                       std::size_t n,
                                       T* registers,
                                       std::uint32_t result_index,
                                       T* scratch) {
  using Rules = TaylorRules<T>;
  using Series = typename Rules::Series;
  using ConstSeries = typename Rules::ConstSeries;
  const auto row = [&](std::uint32_t index) { return Series(registers + index * n, n); };
  const Series c = row(result_index);
  const ConstSeries a = row(instruction.a);
  const auto b = [&] { return ConstSeries(row(instruction.b)); };
  // Scratch series: a partner function, an auxiliary w, and two for powers.
  const Series partner(scratch, n), auxiliary(scratch + n, n), spare(scratch + 2 * n, n),
      spare2(scratch + 3 * n, n);
  switch (instruction.op) {
    case OpCode::kAdd:
      for (std::size_t k = 0; k < n; ++k) c[k] = a[k] + b()[k];
      break;
    case OpCode::kSub:
      for (std::size_t k = 0; k < n; ++k) c[k] = a[k] - b()[k];
      break;
    case OpCode::kMul:
      Rules::Multiply(a, b(), c);
      break;
    case OpCode::kDiv:
      Rules::Divide(a, b(), c);
      break;
    case OpCode::kNeg:
      for (std::size_t k = 0; k < n; ++k) c[k] = -a[k];
      break;
    case OpCode::kReciprocal:
      Rules::Divide({}, a, c);
      break;
    case OpCode::kPowInt:
      Rules::PowerInteger(a, instruction.b, c, spare, spare2);
      break;
    case OpCode::kPow: {
      const ConstSeries exponent = b();
      c[0] = pow(a[0], exponent[0]);
      if (std::all_of(exponent.begin() + 1, exponent.end(), [](const T& e) { return IsZero(e); })) {
        Rules::PowerConstant(a, exponent[0], c);
      } else {
        // a^b = exp(b log a): the exponent's series is b * log(a).
        Rules::Logarithm(a, spare);
        Rules::Multiply(exponent, spare, spare2);
        Rules::Exponential(spare2, c);
      }
      break;
    }
    case OpCode::kSqrt:
      Rules::SquareRoot(a, c);
      break;
    case OpCode::kSin:
      Rules::SineCosine(a, false, c, partner);
      break;
    case OpCode::kCos:
      Rules::SineCosine(a, false, partner, c);
      break;
    case OpCode::kTan:
      Rules::Tangent(a, false, c, auxiliary);
      break;
    case OpCode::kAsin:
    case OpCode::kAcos: {
      // c' sqrt(1 - a^2) = +-a'.
      Rules::SumOfSquares(a, {}, 1.0, -1.0, spare);
      Rules::SquareRoot(spare, auxiliary);
      const bool sine = instruction.op == OpCode::kAsin;
      c[0] = sine ? asin(a[0]) : acos(a[0]);
      Rules::IntegrateQuotient(a, auxiliary, sine ? 1.0 : -1.0, c);
      break;
    }
    case OpCode::kAtan:
      // c' (1 + a^2) = a'.
      Rules::SumOfSquares(a, {}, 1.0, 1.0, auxiliary);
      c[0] = atan(a[0]);
      Rules::IntegrateQuotient(a, auxiliary, 1.0, c);
      break;
    case OpCode::kAtan2:
      Rules::ArcTangent2(a, b(), auxiliary, c);
      break;
    case OpCode::kExp:
      c[0] = exp(a[0]);
      Rules::Exponential(a, c);
      break;
    case OpCode::kLog:
      Rules::Logarithm(a, c);
      break;
    case OpCode::kSinh:
      Rules::SineCosine(a, true, c, partner);
      break;
    case OpCode::kCosh:
      Rules::SineCosine(a, true, partner, c);
      break;
    case OpCode::kTanh:
      Rules::Tangent(a, true, c, auxiliary);
      break;
    case OpCode::kAbs:
      Rules::AbsoluteValue(a, c);
      break;
  }
}

template <typename T>
void ExpressionProgram::RunTaylor(int degree,
                                  const T* input_coefficients,
                                  T* registers,
                                  T* output_coefficients) const {
  const auto n = static_cast<std::size_t>(degree) + 1;
  std::copy_n(input_coefficients, num_inputs_ * n, registers);
  for (std::size_t i = 0; i < constants_.size(); ++i) {
    T* constant = registers + (num_inputs_ + i) * n;
    std::fill(constant, constant + n, T(0.0));
    constant[0] = constants_[i];
  }
  std::vector<T> scratch(4 * n);
  auto result_index = static_cast<std::uint32_t>(num_inputs_ + constants_.size());
  for (const Instruction& instruction : instructions_) {
    RunInstruction(instruction, n, registers, result_index++, scratch.data());
  }
  for (std::size_t i = 0; i < output_registers_.size(); ++i) {
    std::copy_n(registers + output_registers_[i] * n, n, output_coefficients + i * n);
  }
}

void ExpressionProgram::PropagateTangents(DualChunk* registers,
                                          std::vector<std::uint32_t>& carrying,
                                          std::vector<char>& carries) const {
  // An instruction whose operands carry no tangent has a zero tangent and keeps its value:
  // only the instructions the seeded inputs reach run, each as a full pass would run it.
  carries.resize(num_registers(), 0);
  for (const std::uint32_t seeded : carrying) carries[seeded] = 1;
  DualChunk scratch[4];
  auto result_index = static_cast<std::uint32_t>(num_inputs_ + constants_.size());
  for (const Instruction& instruction : instructions_) {
    if (carries[instruction.a] != 0 ||
        (ReadsSecondRegister(instruction.op) && carries[instruction.b] != 0)) {
      RunInstruction(instruction, 1, registers, result_index, scratch);
      carries[result_index] = 1;
      carrying.push_back(result_index);
    }
    ++result_index;
  }
}

void ExpressionProgram::ClearTangents(DualChunk* registers,
                                      std::vector<std::uint32_t>& carrying,
                                      std::vector<char>& carries) const {
  for (const std::uint32_t index : carrying) {
    registers[index].tangent = {};
    carries[index] = 0;
  }
  carrying.clear();
}

bool ExpressionProgram::ReadsSecondRegister(OpCode op) {
  switch (op) {
    case OpCode::kAdd:
    case OpCode::kSub:
    case OpCode::kMul:
    case OpCode::kDiv:
    case OpCode::kPow:
    case OpCode::kAtan2:
      return true;
    default:
      return false;  // unary; kPowInt's b is its exponent
  }
}

void ExpressionProgram::EvaluateTaylor(int degree,
                                       const double* input_coefficients,
                                       double* registers,
                                       double* output_coefficients) const {
  RunTaylor(degree, input_coefficients, registers, output_coefficients);
}

void ExpressionProgram::EvaluateTaylor(int degree,
                                       const Dual* input_coefficients,
                                       Dual* registers,
                                       Dual* output_coefficients) const {
  RunTaylor(degree, input_coefficients, registers, output_coefficients);
}

void ExpressionProgram::EvaluateTaylor(int degree,
                                       const DualChunk* input_coefficients,
                                       DualChunk* registers,
                                       DualChunk* output_coefficients) const {
  RunTaylor(degree, input_coefficients, registers, output_coefficients);
}

}  // namespace servokit
