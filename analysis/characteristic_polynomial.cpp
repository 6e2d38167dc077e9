#include "analysis/characteristic_polynomial.h"

#include <ginac/ginac.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "analysis/operating_point.h"
#include "base/errors.h"
#include "modeling/canonical_expression.h"
#include "modeling/expansion_bound.h"
#include "modeling/expression_program.h"
#include "modeling/symbolic_lock.h"
#include "modeling/symbolic_model.h"
#include "numerics/gsl_support.h"

namespace servokit {
namespace {

using GiNaC::ex;

// Rows up to which LeibnizDeterminant writes the Laplace expansion the budget bounds (5! = 120
// products); larger determinants (up to kMaxClosedFormSize) are taken unbounded.
constexpr unsigned kMaxBoundedRows = 5;

// Scan resolution and bisection accuracy for the sign changes printed with the conditions.
constexpr int kSignScanPoints = 400;
constexpr double kSignChangeRelativeTolerance = 1e-12;
// |q|, |u| below this at the operating point count as "at rest at q = 0, u = 0".
constexpr double kAtRestTolerance = 1e-12;

std::string Print(const ex& expression) { return CanonicalText(expression); }

// `expression` as GiNaC's factor() gives it, with every factor expanded: factor() writes a
// factor in a form (nested or expanded, signed either way) that depends on GiNaC's
// hash-dependent term order, while the expanded factors and their product are unique up to
// signs, which CanonicalText settles.
ex CanonicalFactors(const ex& expression) {
  const ex factored = GiNaC::factor(expression);
  if (GiNaC::is_a<GiNaC::mul>(factored)) {
    ex product = 1;
    for (std::size_t i = 0; i < factored.nops(); ++i) product *= CanonicalFactors(factored.op(i));
    return product;
  }
  if (GiNaC::is_a<GiNaC::power>(factored)) {
    return GiNaC::pow(factored.op(0).expand(), factored.op(1));
  }
  return factored.expand();
}

// A factored form where GiNaC can factor (polynomials), with cos^2 written as 1 - sin^2 when
// that is shorter (m2*sin(alpha)^2 rather than m2*(1-cos(alpha)^2)).
ex Simplify(const ex& expression) {
  ex best = expression.expand();
  const ex with_sine = best.subs(GiNaC::pow(GiNaC::cos(GiNaC::wild(0)), 2) ==
                                     1 - GiNaC::pow(GiNaC::sin(GiNaC::wild(0)), 2),
                                 GiNaC::subs_options::algebraic)
                           .expand();
  if (Print(with_sine).size() < Print(best).size()) best = with_sine;
  try {
    const ex factored = CanonicalFactors(best);
    if (Print(factored).size() <= Print(best).size()) best = factored;
  } catch (const std::exception&) {
    // factor() only handles polynomials; leave the expanded form.
  }
  return best;
}

// An expression of the model's parameters, compiled once and evaluated with one parameter
// varied and the others at their nominal values. Compiled, not GiNaC's evalf: evalf sums in
// GiNaC's hash-dependent order, so its last bits, and the roots located from them, would
// change from run to run.
class ParameterFunction {
 public:
  ParameterFunction(const ex& expression,
                    const SymbolicModel& symbolic,
                    const Eigen::VectorXd& values,
                    std::size_t parameter)
      : inputs_(values.data(), values.data() + values.size()), parameter_(parameter) {
    const std::vector<ex> symbols(symbolic.parameters().begin(), symbolic.parameters().end());
    try {
      program_ = CompileExpressions({expression}, symbols);
      registers_.resize(program_.num_registers());
      compiled_ = true;
    } catch (const std::invalid_argument&) {
      // Not a real function of the parameters (a complex constant): no value anywhere.
    }
  }

  // The value at parameter = x, or NaN where it is not a finite real number.
  double operator()(double x) const {
    if (!compiled_) return std::nan("");
    inputs_[parameter_] = x;
    double value = 0.0;
    program_.Evaluate(inputs_.data(), registers_.data(), &value);
    return std::isfinite(value) ? value : std::nan("");
  }

 private:
  ExpressionProgram program_;
  mutable std::vector<double> inputs_;
  mutable std::vector<double> registers_;
  std::size_t parameter_;
  bool compiled_ = false;
};

// The root of `function` in [left, right], where its sign differs at the ends: GSL's Brent
// solver (the conditions are smooth in the parameter).
double LocateRoot(const ParameterFunction& function, double left, double right) {
  const auto bracket =
      NarrowBracket(gsl_root_fsolver_brent, function, left, right, kSignChangeRelativeTolerance);
  return bracket ? bracket->root : 0.5 * (left + right);
}

// Where `function` changes sign in [low, high]: a scan, then a root in each bracket.
std::vector<double> SignChanges(const ParameterFunction& function, double low, double high) {
  std::vector<double> changes;
  double previous_x = low;
  double previous = function(low);
  for (int i = 1; i <= kSignScanPoints; ++i) {
    const double x = low + (high - low) * i / kSignScanPoints;
    const double value = function(x);
    if (std::isfinite(previous) && std::isfinite(value) && previous != 0.0) {
      if (value == 0.0) {
        changes.push_back(x);
      } else if ((value > 0) != (previous > 0)) {
        changes.push_back(LocateRoot(function, previous_x, x));
      }
    }
    if (value != 0.0 || !std::isfinite(previous)) {
      previous = value;
      previous_x = x;
    }
  }
  return changes;
}

// An upper bound on the expanded terms of a polynomial in the coefficients whose every monomial
// is a product of `factors` of them, with at most `monomials` monomials: monomials * T^factors,
// T the terms of the longest coefficient. What the Hurwitz determinants and the discriminant
// are bounded by before GiNaC expands them (a parameter inside cosh and sin gives coefficients of
// dozens of terms, whose discriminant of degree 6 never finished; issue #31).
double ProductTermsBound(double monomials, double longest_coefficient, int factors) {
  return monomials * std::pow(longest_coefficient, factors);
}

// An upper bound on the monomials of the discriminant of a polynomial of degree n in its
// coefficients a_0..a_n: the discriminant is homogeneous of degree 2n - 2 and isobaric of
// weight n(n - 1) (each a_k weighing k), so its monomials are among the exponent vectors e with
// sum e_k = 2n - 2 and sum k e_k = n(n - 1), counted here (18 for n = 4 against 16 in fact, 338
// for n = 6 against 246).
double DiscriminantMonomialsBound(int degree) {
  const int total = 2 * degree - 2, weight = degree * (degree - 1);
  // count[d][w]: exponent vectors of the coefficients so far with sum d and weight w.
  std::vector<std::vector<double>> count(total + 1, std::vector<double>(weight + 1, 0.0));
  count[0][0] = 1;
  for (int k = 0; k <= degree; ++k) {  // add a_k with exponents 1, 2, ... (as a coin change)
    for (int d = 1; d <= total; ++d) {
      for (int w = k; w <= weight; ++w) count[d][w] += count[d - 1][w - k];
    }
  }
  return count[total][weight];
}

bool AtRest(const Model& model, Workspace& workspace) {
  const OperatingPoint point = FindOperatingPoint(model, workspace);
  return point.q.lpNorm<Eigen::Infinity>() <= kAtRestTolerance &&
         point.u.lpNorm<Eigen::Infinity>() <= kAtRestTolerance;
}

// "s < 2/3*l" when `condition` > 0 is linear in the parameter; "" otherwise. The direction
// of the inequality is the sign of the slope at the nominal parameter values.
std::string SolveLinear(const ex& condition,
                        const SymbolicModel& symbolic,
                        const Eigen::VectorXd& nominal,
                        std::size_t parameter) {
  const GiNaC::realsymbol& symbol = symbolic.parameters()[parameter];
  const ex expanded = condition.expand();
  if (!expanded.is_polynomial(symbol) || expanded.degree(symbol) != 1) return "";
  const ex slope = expanded.coeff(symbol, 1);
  const ex boundary = GiNaC::normal(-expanded.coeff(symbol, 0) / slope);
  const double slope_value =
      ParameterFunction(slope, symbolic, nominal, parameter)(nominal(Eigen::Index(parameter)));
  if (!std::isfinite(slope_value)) return "";
  return Print(symbol) + (slope_value > 0 ? " > " : " < ") + Print(Simplify(boundary));
}

}  // namespace

std::optional<CharacteristicPolynomial> DeriveCharacteristicPolynomial(const Model& model,
                                                                       std::size_t parameter,
                                                                       double low,
                                                                       double high) {
  const SymbolicModel& symbolic = model.symbolic();
  const std::size_t dof = symbolic.dof(), inputs = symbolic.num_inputs();
  if (dof + inputs > kMaxClosedFormSize || !symbolic.has_symbolic_jacobians()) return std::nullopt;

  // The closed form is taken at q = 0, u = 0: check that this is the operating point at the
  // nominal values and at both ends of the range.
  Workspace workspace(model);
  for (const double value : {model.parameters()(Eigen::Index(parameter)), low, high}) {
    workspace.parameters(Eigen::Index(parameter)) = value;
    try {
      if (!AtRest(model, workspace)) return std::nullopt;
    } catch (const NoSolution&) {
      return std::nullopt;
    }
  }

  // From here on GiNaC: one derivation under the lock (modeling/symbolic_lock.h). The sign
  // changes are located on compiled programs, but only a few dozen times per condition.
  const SymbolicLock lock;
  GiNaC::exmap at_rest;
  for (std::size_t k = 0; k < dof; ++k) {
    at_rest[symbolic.coordinates()[k]] = 0;
    at_rest[symbolic.velocities()[k]] = 0;
  }
  const GiNaC::realsymbol lambda("lambda");
  const GiNaC::matrix rosenbrock = symbolic.RosenbrockMatrix(lambda, at_rest);
  // The zero-dynamics polynomial's expansion budget (modeling/symbolic_model.h), bounded before
  // anything is expanded where the Laplace expansion is small enough to write.
  if (rosenbrock.rows() <= kMaxBoundedRows &&
      BoundExpandedTerms(LeibnizDeterminant(rosenbrock)).numerator >
          SymbolicModel::kMaxPolynomialTerms) {
    return std::nullopt;
  }
  // Clearing denominators multiplies every coefficient by the same factor: same roots.
  ex polynomial = GiNaC::numer(GiNaC::normal(rosenbrock.determinant())).expand();
  const int degree = polynomial.degree(lambda);

  const Eigen::VectorXd& nominal = model.parameters();
  const double nominal_value = nominal(Eigen::Index(parameter));
  const auto function_of_swept = [&](const ex& expression) {
    return ParameterFunction(expression, symbolic, nominal, parameter);
  };

  // Make the lowest nonzero coefficient positive at the nominal values, so that "stable" reads
  // "every condition > 0".
  for (int k = 0; k <= degree; ++k) {
    const double value = function_of_swept(polynomial.coeff(lambda, k))(nominal_value);
    if (std::isfinite(value) && value != 0.0) {
      if (value < 0.0) polynomial = (-polynomial).expand();
      break;
    }
  }

  // The conditions' budget, checked before any of them is expanded (the Hurwitz determinants'
  // in their loop below). resultant(p, p') = +-a_n disc(p): a product of 2n - 1 coefficients
  // per monomial.
  double longest = 1;
  for (int k = 0; k <= degree; ++k) {
    longest = std::max(longest, BoundExpandedTerms(polynomial.coeff(lambda, k)).numerator);
  }
  if (degree >= 2 && ProductTermsBound(DiscriminantMonomialsBound(degree), longest,
                                       2 * degree - 1) > SymbolicModel::kMaxPolynomialTerms) {
    return std::nullopt;
  }

  CharacteristicPolynomial result;
  result.degree = degree;
  std::vector<ex> coefficients;  // a_0 .. a_n
  for (int k = 0; k <= degree; ++k) {
    coefficients.push_back(Simplify(polynomial.coeff(lambda, k)));
    result.coefficients.push_back(Print(coefficients.back()));
    result.nominal_coefficients.push_back(function_of_swept(coefficients.back())(nominal_value));
  }
  ex printed = 0;
  for (int k = degree; k >= 0; --k) printed += coefficients[std::size_t(k)] * GiNaC::pow(lambda, k);
  result.polynomial = Print(printed);

  auto add_condition = [&](const std::string& name, const ex& condition) {
    HurwitzCondition entry;
    entry.name = name;
    entry.expression = Print(condition);
    entry.solved = SolveLinear(condition, symbolic, nominal, parameter);
    entry.sign_changes = SignChanges(function_of_swept(condition), low, high);
    result.hurwitz.push_back(std::move(entry));
  };
  // Stodola: every coefficient positive; Hurwitz: the determinants Delta_2 .. Delta_(n-1)
  // (Delta_1 = a_(n-1) and Delta_n = a_0 Delta_(n-1) add nothing once the coefficients are
  // positive).
  for (int k = degree; k >= 0; --k) {
    add_condition("a" + std::to_string(k), coefficients[std::size_t(k)]);
  }
  auto c = [&](int index) -> ex {  // c_i = a_(n-i), zero outside 0..n
    return index < 0 || index > degree ? ex(0) : coefficients[std::size_t(degree - index)];
  };
  double factorial = 1;  // order!, multiplied up in the loop
  for (int order = 2; order < degree; ++order) {
    GiNaC::matrix hurwitz{static_cast<unsigned>(order), static_cast<unsigned>(order)};
    for (int i = 0; i < order; ++i) {
      for (int j = 0; j < order; ++j) hurwitz(unsigned(i), unsigned(j)) = c(2 * (j + 1) - (i + 1));
    }
    // Bounded through its Laplace expansion where that is small enough to write, else as at
    // most order! products of `order` coefficients.
    factorial *= order;
    const double bound = order <= int(kMaxBoundedRows)
                             ? BoundExpandedTerms(LeibnizDeterminant(hurwitz)).numerator
                             : ProductTermsBound(factorial, longest, order);
    if (bound > SymbolicModel::kMaxPolynomialTerms) return std::nullopt;
    add_condition("Delta" + std::to_string(order), Simplify(hurwitz.determinant()));
  }
  if (degree >= 2) {
    // disc = (-1)^(n(n-1)/2) resultant(p, p') / a_n: its sign tells real from complex pairs.
    // resultant() wants polynomials in every symbol: stand-in symbols replace cos(alpha) and
    // the like while it runs.
    GiNaC::exmap stand_ins;
    const ex polynomial_only = polynomial.to_polynomial(stand_ins);
    GiNaC::exmap back;
    for (const auto& [symbol, original] : stand_ins) back[symbol] = original;
    const int sign = (degree * (degree - 1) / 2) % 2 == 0 ? 1 : -1;
    const ex resultant =
        GiNaC::resultant(polynomial_only, polynomial_only.diff(lambda), lambda).subs(back);
    const ex discriminant =
        Simplify(GiNaC::normal(sign * resultant / polynomial.coeff(lambda, degree)));
    result.discriminant = Print(discriminant);
    result.discriminant_sign_changes = SignChanges(function_of_swept(discriminant), low, high);
  }
  return result;
}

}  // namespace servokit
