#include "analysis/characteristic_polynomial.h"

#include <ginac/ginac.h>

#include <cmath>
#include <sstream>

#include "analysis/gsl_support.h"
#include "analysis/operating_point.h"
#include "models/errors.h"
#include "models/symbolic_model.h"

namespace servokit {
namespace {

using GiNaC::ex;

// Scan resolution and bisection accuracy for the sign changes printed with the conditions.
constexpr int kSignScanPoints = 400;
constexpr double kSignChangeRelativeTolerance = 1e-12;
// |q|, |u| below this at the operating point count as "at rest at q = 0, u = 0".
constexpr double kAtRestTolerance = 1e-12;

std::string Print(const ex& expression) {
  std::ostringstream out;
  out << expression;
  return out.str();
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
    const ex factored = GiNaC::factor(best);
    if (Print(factored).size() <= Print(best).size()) best = factored;
  } catch (const std::exception&) {
    // factor() only handles polynomials; leave the expanded form.
  }
  return best;
}

// The value of `expression` with `parameter` = value, or NaN if it is not a real number.
double EvaluateAt(const ex& expression, const GiNaC::realsymbol& parameter, double value) {
  const ex result = GiNaC::evalf(expression.subs(parameter == value));
  if (!GiNaC::is_a<GiNaC::numeric>(result)) return std::nan("");
  const auto& number = GiNaC::ex_to<GiNaC::numeric>(result);
  if (!number.is_real()) return std::nan("");
  return number.to_double();
}

// The root of `expression` in [left, right], where its sign differs at the ends: GSL's Brent
// solver (the conditions are smooth in the parameter).
double LocateRoot(const ex& expression,
                  const GiNaC::realsymbol& parameter,
                  double left,
                  double right) {
  const auto bracket = NarrowBracket(
      gsl_root_fsolver_brent, [&](double x) { return EvaluateAt(expression, parameter, x); }, left,
      right, kSignChangeRelativeTolerance);
  return bracket ? bracket->root : 0.5 * (left + right);
}

// Where `expression` changes sign in [low, high]: a scan, then a root in each bracket.
std::vector<double> SignChanges(const ex& expression,
                                const GiNaC::realsymbol& parameter,
                                double low,
                                double high) {
  std::vector<double> changes;
  double previous_x = low;
  double previous = EvaluateAt(expression, parameter, low);
  for (int i = 1; i <= kSignScanPoints; ++i) {
    const double x = low + (high - low) * i / kSignScanPoints;
    const double value = EvaluateAt(expression, parameter, x);
    if (std::isfinite(previous) && std::isfinite(value) && previous != 0.0) {
      if (value == 0.0) {
        changes.push_back(x);
      } else if ((value > 0) != (previous > 0)) {
        changes.push_back(LocateRoot(expression, parameter, previous_x, x));
      }
    }
    if (value != 0.0 || !std::isfinite(previous)) {
      previous = value;
      previous_x = x;
    }
  }
  return changes;
}

bool AtRest(const Model& model, Workspace& workspace) {
  const OperatingPoint point = FindOperatingPoint(model, workspace);
  return point.q.lpNorm<Eigen::Infinity>() <= kAtRestTolerance &&
         point.u.lpNorm<Eigen::Infinity>() <= kAtRestTolerance;
}

// "s < 2/3*l" when `condition` > 0 is linear in the parameter; "" otherwise. The direction
// of the inequality is the sign of the slope at the nominal parameter values.
std::string SolveLinear(const ex& condition,
                        const GiNaC::realsymbol& parameter,
                        const GiNaC::exmap& nominal) {
  const ex expanded = condition.expand();
  if (!expanded.is_polynomial(parameter) || expanded.degree(parameter) != 1) return "";
  const ex slope = expanded.coeff(parameter, 1);
  const ex boundary = GiNaC::normal(-expanded.coeff(parameter, 0) / slope);
  const ex slope_value = GiNaC::evalf(slope.subs(nominal));
  if (!GiNaC::is_a<GiNaC::numeric>(slope_value)) return "";
  const bool increasing = GiNaC::ex_to<GiNaC::numeric>(slope_value).is_positive();
  return Print(parameter) + (increasing ? " > " : " < ") + Print(Simplify(boundary));
}

}  // namespace

std::optional<CharacteristicPolynomial> DeriveCharacteristicPolynomial(const Model& model,
                                                                       std::size_t parameter,
                                                                       double low,
                                                                       double high) {
  const SymbolicModel& symbolic = model.symbolic();
  const std::size_t dof = symbolic.dof(), inputs = symbolic.num_inputs();
  if (dof + inputs > kMaxClosedFormSize) return std::nullopt;

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

  GiNaC::exmap at_rest;
  for (std::size_t k = 0; k < dof; ++k) {
    at_rest[symbolic.coordinates()[k]] = 0;
    at_rest[symbolic.velocities()[k]] = 0;
  }
  const GiNaC::realsymbol lambda("lambda");
  // Clearing denominators multiplies every coefficient by the same factor: same roots.
  ex polynomial =
      GiNaC::numer(GiNaC::normal(symbolic.RosenbrockDeterminant(lambda, at_rest))).expand();
  const int degree = polynomial.degree(lambda);

  const GiNaC::realsymbol& swept = symbolic.parameters()[parameter];
  GiNaC::exmap nominal = symbolic.ParameterValues(model.parameters());
  GiNaC::exmap others = nominal;
  others.erase(swept);

  // Make the lowest nonzero coefficient positive at the nominal values, so that "stable" reads
  // "every condition > 0".
  for (int k = 0; k <= degree; ++k) {
    const ex value = GiNaC::evalf(polynomial.coeff(lambda, k).subs(nominal));
    if (GiNaC::is_a<GiNaC::numeric>(value) && !GiNaC::ex_to<GiNaC::numeric>(value).is_zero()) {
      if (GiNaC::ex_to<GiNaC::numeric>(value).is_negative()) polynomial = (-polynomial).expand();
      break;
    }
  }

  CharacteristicPolynomial result;
  result.degree = degree;
  std::vector<ex> coefficients;  // a_0 .. a_n
  for (int k = 0; k <= degree; ++k) {
    coefficients.push_back(Simplify(polynomial.coeff(lambda, k)));
    result.coefficients.push_back(Print(coefficients.back()));
    result.nominal_coefficients.push_back(EvaluateAt(coefficients.back().subs(others), swept,
                                                     model.parameters()(Eigen::Index(parameter))));
  }
  ex printed = 0;
  for (int k = degree; k >= 0; --k) printed += coefficients[std::size_t(k)] * GiNaC::pow(lambda, k);
  result.polynomial = Print(printed);

  auto add_condition = [&](const std::string& name, const ex& condition) {
    HurwitzCondition entry;
    entry.name = name;
    entry.expression = Print(condition);
    entry.solved = SolveLinear(condition, swept, nominal);
    entry.sign_changes = SignChanges(condition.subs(others), swept, low, high);
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
  for (int order = 2; order < degree; ++order) {
    GiNaC::matrix hurwitz{static_cast<unsigned>(order), static_cast<unsigned>(order)};
    for (int i = 0; i < order; ++i) {
      for (int j = 0; j < order; ++j) hurwitz(unsigned(i), unsigned(j)) = c(2 * (j + 1) - (i + 1));
    }
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
    result.discriminant_sign_changes = SignChanges(discriminant.subs(others), swept, low, high);
  }
  return result;
}

}  // namespace servokit
