#pragma once
// A bound on what GiNaC's normal() and expand() make of an expression, computed from its tree
// without expanding anything: the number of terms of the expanded numerator and denominator
// over a common denominator. A product of K sums of m terms each expands to up to m^K terms, and
// normal() brings a sum of fractions onto one denominator, multiplying each numerator by the
// others' denominators; both grow without bound on models of realistic size. The bound decides,
// before the work, whether a closed form is cheap enough to derive (issue #31: symbolic only
// where it is cheap).
#include <ginac/ginac.h>

#include <limits>

namespace servokit {

/// Upper bounds on the term counts of numer(normal(e)).expand() and denom(...).expand(). Functions
/// (sin, sqrt, ...) and powers with a non-integer or symbolic exponent count as one term (normal
/// keeps them as atoms). Counts saturate at infinity. Hold a SymbolicLock.
struct ExpandedTerms {
  double numerator = 1.0;
  double denominator = 1.0;
};
ExpandedTerms BoundExpandedTerms(const GiNaC::ex& expression);

/// An upper bound on the terms expression.expand() makes: those of the result, plus those of
/// every function argument inside it, wherever it occurs (expand() expands arguments too, one
/// occurrence at a time). Computed without expanding: a sum adds its terms' counts, a product
/// multiplies them, a non-negative integer power raises its base's; anything else is one term.
/// Each distinct node is visited once, so an expression built from shared subexpressions costs
/// its DAG. Saturates at infinity. Hold a SymbolicLock.
double BoundExpandTerms(const GiNaC::ex& expression);

/// expression.expand() when BoundExpandTerms(expression) <= max_terms, else the expression as it
/// is: terms that cancel do so exactly where that is cheap, and nothing is multiplied out past
/// the budget (a product of sums, a linkage's loop closure). Hold a SymbolicLock.
GiNaC::ex ExpandWithinBudget(const GiNaC::ex& expression, double max_terms);

/// CanonicalNormal(expression) (modeling/canonical_expression.h) when BoundExpandedTerms promises
/// at most max_terms terms for its numerator and denominator together, else the expression as
/// it is: the same function, left unsimplified where simplifying would cost without bound.
GiNaC::ex NormalWithinBudget(const GiNaC::ex& expression, double max_terms);

/// The Laplace expansion of det(matrix), a sum of signed products of entries, built without
/// normal() or expand() (a square matrix of at most 5 rows): what BoundExpandedTerms bounds
/// before GiNaC's own determinant() normalizes it.
GiNaC::ex LeibnizDeterminant(const GiNaC::matrix& matrix);

/// The nodes of an expression's tree (symbols, numbers, sums, products, powers, functions), each
/// shared subexpression counted wherever it occurs: what differentiating it once walks. Counting
/// stops at the first node past `limit` (a tree built from shared subexpressions, a linkage's
/// derivatives, can be far larger than its DAG). Hold a SymbolicLock.
double TreeSize(const GiNaC::ex& expression,
                double limit = std::numeric_limits<double>::infinity());

}  // namespace servokit
