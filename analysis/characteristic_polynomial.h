#pragma once
// The characteristic polynomial of the linearized zero dynamics in closed form (GiNaC), for
// reports and for the threshold finder's closed-form conditions:
//   p(lambda) = det [[M lambda^2 + D lambda + K, -B], [H, 0]]  at q = 0, q' = 0, u = 0,
// whose roots are the invariant zeros (analysis/zero_dynamics.h, route 2), with the model's
// parameters kept as symbols. Then the Routh-Hurwitz (Stodola) conditions: every root is in
// the open left half plane iff all Hurwitz determinants have the sign of the leading
// coefficient; and, for oscillation, the discriminant.
//
// Symbolic work: call once per model and parameter, never per point. Thread-safe: the GiNaC
// part runs under SymbolicLock (modeling/symbolic_lock.h).
#include <optional>
#include <string>
#include <vector>

#include "modeling/model.h"

namespace servokit {

/// One Routh-Hurwitz condition: `expression` > 0 (with the leading coefficient made positive),
/// and where it changes sign in the swept parameter at the other parameters' nominal values.
struct HurwitzCondition {
  std::string name;                  // "a2", "Delta2", ...
  std::string expression;            // factored, in the model's symbols
  std::string solved;                // e.g. "s < 2/3*l" when linear in the swept parameter, else ""
  std::vector<double> sign_changes;  // values of the parameter in the searched range
};

struct CharacteristicPolynomial {
  std::string variable = "lambda";
  // a_0 .. a_n, factored; all texts here are canonical (modeling/canonical_expression.h): the
  // same in every run.
  std::vector<std::string> coefficients;
  // a_0 .. a_n at the model's nominal parameter values.
  std::vector<double> nominal_coefficients;
  std::string polynomial;                         // a_n*lambda^n + ... + a_0
  int degree = 0;                                 // = order of the zero dynamics where a_n != 0
  std::vector<HurwitzCondition> hurwitz;          // a_n, Delta_1 .. Delta_n (leading sign fixed)
  std::string discriminant;                       // of p in lambda, factored ("" if degree < 2)
  std::vector<double> discriminant_sign_changes;  // where the number of complex roots may change
};

/// Derives the closed form for `parameter` swept over [low, high]. Returns nullopt when the
/// closed form does not apply: the operating point is not q = 0, u = 0 (then M, K, D would
/// depend on where the equilibrium moves), or the model is too large for a symbolic
/// determinant (more than kMaxClosedFormSize rows, no symbolic Jacobians, or an expansion past
/// SymbolicModel::kMaxPolynomialTerms terms, bounded before expanding for up to 5 rows). Sign
/// changes are located to relative 1e-12 by GSL's Brent solver on the expression evaluated
/// numerically.
std::optional<CharacteristicPolynomial> DeriveCharacteristicPolynomial(const Model& model,
                                                                       std::size_t parameter,
                                                                       double low,
                                                                       double high);

/// Rows of the Rosenbrock matrix (dof + inputs) up to which the determinant is taken
/// symbolically; larger models get no closed form (the cost grows like n!).
inline constexpr std::size_t kMaxClosedFormSize = 8;

}  // namespace servokit
