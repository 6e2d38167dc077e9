#pragma once
// A dual number value + tangent * epsilon (epsilon^2 = 0): forward-mode differentiation in one
// direction. Taylor mode over dual numbers (ExpressionProgram::EvaluateTaylor on Dual) gives
// the derivative of every Taylor coefficient of a motion with respect to its start or its input
// exactly, with no difference of two large values (Griewank and Walther, "Evaluating
// Derivatives", 2nd ed., 2008, Sect. 13.4: univariate Taylor propagation over a tangent).
// Each function's tangent is its derivative at the value times the argument's tangent; the
// value is computed as for a double, to the same bits.
#include <cmath>

namespace servokit {
// Its own namespace, so that its functions are found by argument-dependent lookup for dual
// numbers only: an unqualified cos(double) elsewhere in servokit never meets cos(Dual).
namespace dual {

struct Dual {
  double value = 0.0;
  double tangent = 0.0;

  Dual() = default;
  // Implicit from double: a constant, whose tangent is 0 (as literals in the recurrences).
  Dual(double constant) : value(constant) {}  // NOLINT(google-explicit-constructor)
  Dual(double v, double t) : value(v), tangent(t) {}

  Dual& operator+=(const Dual& b) {
    value += b.value;
    tangent += b.tangent;
    return *this;
  }
  Dual& operator-=(const Dual& b) {
    value -= b.value;
    tangent -= b.tangent;
    return *this;
  }
};

inline Dual operator+(const Dual& a, const Dual& b) {
  return {a.value + b.value, a.tangent + b.tangent};
}
inline Dual operator-(const Dual& a, const Dual& b) {
  return {a.value - b.value, a.tangent - b.tangent};
}
inline Dual operator-(const Dual& a) { return {-a.value, -a.tangent}; }
inline Dual operator*(const Dual& a, const Dual& b) {
  return {a.value * b.value, a.tangent * b.value + a.value * b.tangent};
}
inline Dual operator/(const Dual& a, const Dual& b) {
  const double quotient = a.value / b.value;
  return {quotient, (a.tangent - quotient * b.tangent) / b.value};
}
// Exactly zero, tangent included (a Taylor coefficient that is constant in every direction).
inline bool IsZero(const Dual& a) { return a.value == 0.0 && a.tangent == 0.0; }
inline bool IsZero(double a) { return a == 0.0; }
inline double ValueOf(const Dual& a) { return a.value; }
inline double ValueOf(double a) { return a; }

inline Dual sin(const Dual& a) { return {std::sin(a.value), std::cos(a.value) * a.tangent}; }
inline Dual cos(const Dual& a) { return {std::cos(a.value), -std::sin(a.value) * a.tangent}; }
inline Dual tan(const Dual& a) {
  const double t = std::tan(a.value);
  return {t, (1.0 + t * t) * a.tangent};
}
inline Dual sinh(const Dual& a) { return {std::sinh(a.value), std::cosh(a.value) * a.tangent}; }
inline Dual cosh(const Dual& a) { return {std::cosh(a.value), std::sinh(a.value) * a.tangent}; }
inline Dual tanh(const Dual& a) {
  const double t = std::tanh(a.value);
  return {t, (1.0 - t * t) * a.tangent};
}
inline Dual sqrt(const Dual& a) {
  const double root = std::sqrt(a.value);
  return {root, a.tangent / (2.0 * root)};
}
inline Dual exp(const Dual& a) {
  const double e = std::exp(a.value);
  return {e, e * a.tangent};
}
inline Dual log(const Dual& a) { return {std::log(a.value), a.tangent / a.value}; }
inline Dual asin(const Dual& a) {
  return {std::asin(a.value), a.tangent / std::sqrt(1.0 - a.value * a.value)};
}
inline Dual acos(const Dual& a) {
  return {std::acos(a.value), -a.tangent / std::sqrt(1.0 - a.value * a.value)};
}
inline Dual atan(const Dual& a) {
  return {std::atan(a.value), a.tangent / (1.0 + a.value * a.value)};
}
inline Dual atan2(const Dual& a, const Dual& b) {
  const double squares = a.value * a.value + b.value * b.value;
  return {std::atan2(a.value, b.value), (b.value * a.tangent - a.value * b.tangent) / squares};
}
// a^b = exp(b log a): d = a^b (b' log a + b a' / a); the log term only where b varies, so
// that a negative base with a constant exponent keeps a finite tangent.
inline Dual pow(const Dual& a, const Dual& b) {
  const double power = std::pow(a.value, b.value);
  double tangent = 0.0;  // where a does not vary, 0^(b - 1) * 0 would be NaN
  if (a.tangent != 0.0) tangent += b.value * std::pow(a.value, b.value - 1.0) * a.tangent;
  if (b.tangent != 0.0) tangent += power * std::log(a.value) * b.tangent;
  return {power, tangent};
}
// |a|: the sign of the value (of the tangent where the value is 0, the one-sided derivative).
inline Dual abs(const Dual& a) {
  const double sign = a.value != 0.0 ? (a.value > 0 ? 1.0 : -1.0)
                                     : (a.tangent > 0 ? 1.0 : (a.tangent < 0 ? -1.0 : 0.0));
  return {std::abs(a.value), sign * a.tangent};
}

}  // namespace dual

using dual::Dual;
using dual::IsZero;
using dual::ValueOf;

}  // namespace servokit
