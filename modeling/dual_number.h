#pragma once
// A dual number value + tangent * epsilon (epsilon^2 = 0): forward-mode differentiation in one
// direction. Taylor mode over dual numbers (ExpressionProgram::EvaluateTaylor on Dual) gives
// the derivative of every Taylor coefficient of a motion with respect to its start or its input
// exactly, with no difference of two large values (Griewank and Walther, "Evaluating
// Derivatives", 2nd ed., 2008, Sect. 13.4: univariate Taylor propagation over a tangent).
// Each function's tangent is its derivative at the value times the argument's tangent; the
// value is computed as for a double, to the same bits.
//
// The tangent is a double (Dual: one direction), or a fixed number of them (DualChunk: as many
// directions in one pass, vector mode, Griewank and Walther Sect. 3.1): the value and the
// derivative of each function are then computed once for all of them, and every direction's
// tangent is the same expression as Dual's, to the same bits.
#include <array>
#include <cmath>
#include <cstddef>

namespace servokit {
// Its own namespace, so that its functions are found by argument-dependent lookup for dual
// numbers only: an unqualified cos(double) elsewhere in servokit never meets cos(Dual).
namespace dual {

/// K tangents with the arithmetic a tangent needs (sums, and products with a double).
template <std::size_t K>
struct Tangents {
  std::array<double, K> d{};

  Tangents& operator+=(const Tangents& b) {
    for (std::size_t i = 0; i < K; ++i) d[i] += b.d[i];
    return *this;
  }
  Tangents& operator-=(const Tangents& b) {
    for (std::size_t i = 0; i < K; ++i) d[i] -= b.d[i];
    return *this;
  }
};
template <std::size_t K>
Tangents<K> operator+(Tangents<K> a, const Tangents<K>& b) {
  return a += b;
}
template <std::size_t K>
Tangents<K> operator-(Tangents<K> a, const Tangents<K>& b) {
  return a -= b;
}
template <std::size_t K>
Tangents<K> operator-(Tangents<K> a) {
  for (double& x : a.d) x = -x;
  return a;
}
template <std::size_t K>
Tangents<K> operator*(double s, Tangents<K> a) {
  for (double& x : a.d) x = s * x;
  return a;
}
template <std::size_t K>
Tangents<K> operator*(Tangents<K> a, double s) {
  for (double& x : a.d) x = x * s;
  return a;
}
template <std::size_t K>
Tangents<K> operator/(Tangents<K> a, double s) {
  for (double& x : a.d) x = x / s;
  return a;
}

// The tangent's directions, one at a time: a double is one direction.
inline constexpr std::size_t Directions(double) { return 1; }
template <std::size_t K>
constexpr std::size_t Directions(const Tangents<K>&) {
  return K;
}
inline double& Direction(double& t, std::size_t) { return t; }
inline double Direction(const double& t, std::size_t) { return t; }
template <std::size_t K>
double& Direction(Tangents<K>& t, std::size_t i) {
  return t.d[i];
}
template <std::size_t K>
double Direction(const Tangents<K>& t, std::size_t i) {
  return t.d[i];
}

template <typename Tangent>
struct BasicDual {
  double value = 0.0;
  Tangent tangent{};

  BasicDual() = default;
  // Implicit from double: a constant, whose tangent is 0 (as literals in the recurrences).
  BasicDual(double constant) : value(constant) {}  // NOLINT(google-explicit-constructor)
  BasicDual(double v, const Tangent& t) : value(v), tangent(t) {}

  BasicDual& operator+=(const BasicDual& b) {
    value += b.value;
    tangent += b.tangent;
    return *this;
  }
  BasicDual& operator-=(const BasicDual& b) {
    value -= b.value;
    tangent -= b.tangent;
    return *this;
  }
};

/// One direction.
using Dual = BasicDual<double>;
/// kChunk directions in one pass (Workspace's forward-mode Jacobians).
inline constexpr std::size_t kChunk = 8;
using DualChunk = BasicDual<Tangents<kChunk>>;

template <typename T>
BasicDual<T> operator+(const BasicDual<T>& a, const BasicDual<T>& b) {
  return {a.value + b.value, a.tangent + b.tangent};
}
template <typename T>
BasicDual<T> operator-(const BasicDual<T>& a, const BasicDual<T>& b) {
  return {a.value - b.value, a.tangent - b.tangent};
}
template <typename T>
BasicDual<T> operator-(const BasicDual<T>& a) {
  return {-a.value, -a.tangent};
}
// Products and quotients direction by direction, in place: the hot path of a chunk's pass
// (temporaries of whole tangent arrays kept them out of line, 14% of a 400-pendulum analyze).
template <typename T>
[[gnu::always_inline]] inline BasicDual<T> operator*(const BasicDual<T>& a, const BasicDual<T>& b) {
  BasicDual<T> product(a.value * b.value);
  for (std::size_t i = 0; i < Directions(product.tangent); ++i) {
    Direction(product.tangent, i) =
        Direction(a.tangent, i) * b.value + a.value * Direction(b.tangent, i);
  }
  return product;
}
template <typename T>
[[gnu::always_inline]] inline BasicDual<T> operator/(const BasicDual<T>& a, const BasicDual<T>& b) {
  const double quotient = a.value / b.value;
  BasicDual<T> result(quotient);
  for (std::size_t i = 0; i < Directions(result.tangent); ++i) {
    Direction(result.tangent, i) =
        (Direction(a.tangent, i) - quotient * Direction(b.tangent, i)) / b.value;
  }
  return result;
}
// Mixed with a double: the double is a constant (as BasicDual(double) would make it).
template <typename T>
BasicDual<T> operator+(const BasicDual<T>& a, double b) {
  return a + BasicDual<T>(b);
}
template <typename T>
BasicDual<T> operator+(double a, const BasicDual<T>& b) {
  return BasicDual<T>(a) + b;
}
template <typename T>
BasicDual<T> operator-(const BasicDual<T>& a, double b) {
  return a - BasicDual<T>(b);
}
template <typename T>
BasicDual<T> operator-(double a, const BasicDual<T>& b) {
  return BasicDual<T>(a) - b;
}
template <typename T>
BasicDual<T> operator*(const BasicDual<T>& a, double b) {
  return a * BasicDual<T>(b);
}
template <typename T>
BasicDual<T> operator*(double a, const BasicDual<T>& b) {
  return BasicDual<T>(a) * b;
}
template <typename T>
BasicDual<T> operator/(const BasicDual<T>& a, double b) {
  return a / BasicDual<T>(b);
}
template <typename T>
BasicDual<T> operator/(double a, const BasicDual<T>& b) {
  return BasicDual<T>(a) / b;
}

// Exactly zero, tangent included (a Taylor coefficient that is constant in every direction).
template <typename T>
bool IsZero(const BasicDual<T>& a) {
  if (a.value != 0.0) return false;
  for (std::size_t i = 0; i < Directions(a.tangent); ++i) {
    if (Direction(a.tangent, i) != 0.0) return false;
  }
  return true;
}
inline bool IsZero(double a) { return a == 0.0; }
template <typename T>
double ValueOf(const BasicDual<T>& a) {
  return a.value;
}
inline double ValueOf(double a) { return a; }

template <typename T>
BasicDual<T> sin(const BasicDual<T>& a) {
  return {std::sin(a.value), std::cos(a.value) * a.tangent};
}
template <typename T>
BasicDual<T> cos(const BasicDual<T>& a) {
  return {std::cos(a.value), -std::sin(a.value) * a.tangent};
}
template <typename T>
BasicDual<T> tan(const BasicDual<T>& a) {
  const double t = std::tan(a.value);
  return {t, (1.0 + t * t) * a.tangent};
}
template <typename T>
BasicDual<T> sinh(const BasicDual<T>& a) {
  return {std::sinh(a.value), std::cosh(a.value) * a.tangent};
}
template <typename T>
BasicDual<T> cosh(const BasicDual<T>& a) {
  return {std::cosh(a.value), std::sinh(a.value) * a.tangent};
}
template <typename T>
BasicDual<T> tanh(const BasicDual<T>& a) {
  const double t = std::tanh(a.value);
  return {t, (1.0 - t * t) * a.tangent};
}
template <typename T>
BasicDual<T> sqrt(const BasicDual<T>& a) {
  const double root = std::sqrt(a.value);
  return {root, a.tangent / (2.0 * root)};
}
template <typename T>
BasicDual<T> exp(const BasicDual<T>& a) {
  const double e = std::exp(a.value);
  return {e, e * a.tangent};
}
template <typename T>
BasicDual<T> log(const BasicDual<T>& a) {
  return {std::log(a.value), a.tangent / a.value};
}
template <typename T>
BasicDual<T> asin(const BasicDual<T>& a) {
  return {std::asin(a.value), a.tangent / std::sqrt(1.0 - a.value * a.value)};
}
template <typename T>
BasicDual<T> acos(const BasicDual<T>& a) {
  return {std::acos(a.value), -a.tangent / std::sqrt(1.0 - a.value * a.value)};
}
template <typename T>
BasicDual<T> atan(const BasicDual<T>& a) {
  return {std::atan(a.value), a.tangent / (1.0 + a.value * a.value)};
}
template <typename T>
BasicDual<T> atan2(const BasicDual<T>& a, const BasicDual<T>& b) {
  const double squares = a.value * a.value + b.value * b.value;
  return {std::atan2(a.value, b.value), (b.value * a.tangent - a.value * b.tangent) / squares};
}
// a^b = exp(b log a): d = a^b (b' log a + b a' / a); the log term only where b varies, so
// that a negative base with a constant exponent keeps a finite tangent (per direction).
template <typename T>
BasicDual<T> pow(const BasicDual<T>& a, const BasicDual<T>& b) {
  const double power = std::pow(a.value, b.value);
  BasicDual<T> result(power);
  for (std::size_t i = 0; i < Directions(a.tangent); ++i) {
    const double a_tangent = Direction(a.tangent, i), b_tangent = Direction(b.tangent, i);
    double tangent = 0.0;  // where a does not vary, 0^(b - 1) * 0 would be NaN
    if (a_tangent != 0.0) tangent += b.value * std::pow(a.value, b.value - 1.0) * a_tangent;
    if (b_tangent != 0.0) tangent += power * std::log(a.value) * b_tangent;
    Direction(result.tangent, i) = tangent;
  }
  return result;
}
// |a|: the sign of the value (of the tangent where the value is 0, the one-sided derivative,
// per direction).
template <typename T>
BasicDual<T> abs(const BasicDual<T>& a) {
  BasicDual<T> result(std::abs(a.value));
  for (std::size_t i = 0; i < Directions(a.tangent); ++i) {
    const double t = Direction(a.tangent, i);
    const double sign =
        a.value != 0.0 ? (a.value > 0 ? 1.0 : -1.0) : (t > 0 ? 1.0 : (t < 0 ? -1.0 : 0.0));
    Direction(result.tangent, i) = sign * t;
  }
  return result;
}

}  // namespace dual

using dual::Dual;
using dual::DualChunk;
using dual::IsZero;
using dual::kChunk;
using dual::ValueOf;

}  // namespace servokit
