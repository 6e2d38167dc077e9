// Derivatives on canonical forms (modeling/expanded_derivative.h) against GiNaC. For every
// expression of the shipped and test models and of the fuzz corpus, and for each of its symbols
// x, d/dx multiplied out must be the canonical form of expand(diff(e, x)), node for node and
// coefficient for coefficient; the derivative along rates (each symbol s moving at a rate s')
// that of expand(sum_s diff(e, s) s'). Where the route refuses (a quotient by a sum, which
// expand() rewrites inside), the loader derives with GiNaC; the test counts derivatives taken
// and refused so that it cannot pass on nothing. Then Lagrange's equations:
// ExpandedLagrangeEquations against KineticMassMatrix and LagrangeForces, expanded, on energies
// of the forms users write.
#include "modeling/expanded_derivative.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "modeling/lagrangian_model.h"
#include "modeling/loader_support.h"
#include "modeling/symbolic_lock.h"
#include "tests/model_texts.h"

namespace servokit::detail {
namespace {

using Scaled = CanonicalExpressions::Scaled;

// The most pairs of terms a product may multiply out, as the loader allows.
constexpr double kMaxProducts = kMaxExpandedTerms;

struct Counts {
  int taken = 0, refused = 0;
};

// Real symbols by name, shared by every text, as the loader's are real.
class Symbols {
 public:
  const GiNaC::realsymbol& operator[](const std::string& name) {
    return symbols_.try_emplace(name, name).first->second;
  }

 private:
  std::map<std::string, GiNaC::realsymbol> symbols_;
};

// The largest |numeric factor| of the terms of an expanded expression.
double LargestCoefficient(const GiNaC::ex& expanded) {
  const auto coefficient = [](const GiNaC::ex& term) {
    GiNaC::numeric number = 1;
    if (GiNaC::is_a<GiNaC::numeric>(term))
      return std::abs(GiNaC::ex_to<GiNaC::numeric>(term).to_double());
    if (GiNaC::is_a<GiNaC::mul>(term)) {
      for (const GiNaC::ex& factor : term) {
        if (GiNaC::is_a<GiNaC::numeric>(factor)) number *= GiNaC::ex_to<GiNaC::numeric>(factor);
      }
    }
    return std::abs(number.to_double());
  };
  if (!GiNaC::is_a<GiNaC::add>(expanded)) return coefficient(expanded);
  double largest = 0.0;
  for (const GiNaC::ex& term : expanded) largest = std::max(largest, coefficient(term));
  return largest;
}

// Compares both derivatives of `expression` (see above), adding to `counts`. With floating-point
// coefficients a product of sums multiplied out in another order rounds differently (GiNaC's
// order follows its hash values): there the two agree to rounding.
void CompareDerivatives(const GiNaC::ex& expression, Symbols& symbols, Counts& counts) {
  bool has_floats = false;
  for (auto node = expression.preorder_begin(); node != expression.preorder_end(); ++node) {
    has_floats = has_floats || (GiNaC::is_a<GiNaC::numeric>(*node) &&
                                !GiNaC::ex_to<GiNaC::numeric>(*node).is_rational());
  }
  std::vector<GiNaC::realsymbol> held;
  for (auto node = expression.preorder_begin(); node != expression.preorder_end(); ++node) {
    if (GiNaC::is_a<GiNaC::realsymbol>(*node)) {
      held.push_back(GiNaC::ex_to<GiNaC::realsymbol>(*node));
    }
  }
  std::sort(held.begin(), held.end(),
            [](const auto& a, const auto& b) { return a.get_name() < b.get_name(); });
  held.erase(std::unique(held.begin(), held.end(),
                         [](const auto& a, const auto& b) { return a.is_equal(b); }),
             held.end());
  CanonicalExpressions canonical;
  const Scaled value = canonical.Add(expression);
  ExpandedDerivatives derive(canonical, kMaxProducts);
  const auto compare = [&](std::size_t direction, const GiNaC::ex& derivative) {
    const std::optional<Scaled> derived = derive.Derive(value, direction);
    if (!derived) {
      ++counts.refused;
      return;
    }
    const GiNaC::ex expanded = derivative.expand();
    const Scaled expected = canonical.Add(expanded);
    INFO("derived: " << canonical.Text(*derived) << ", GiNaC: " << canonical.Text(expected));
    ++counts.taken;
    if (derived->node == expected.node && derived->coefficient.is_equal(expected.coefficient)) {
      return;
    }
    CHECK(has_floats);
    const GiNaC::ex difference = (canonical.Expression(*derived) - expanded).expand();
    CHECK(LargestCoefficient(difference) <= 1e-14 * LargestCoefficient(expanded));
  };
  std::vector<std::pair<CanonicalExpressions::NodeId, Scaled>> rates;
  GiNaC::ex along_rates = 0;
  for (const GiNaC::realsymbol& symbol : held) {
    const CanonicalExpressions::NodeId node = canonical.Add(symbol).node;
    INFO("d/d" << symbol.get_name());
    compare(derive.AddDirection({{node, canonical.Number(1)}}), expression.diff(symbol));
    const GiNaC::realsymbol& rate = symbols[symbol.get_name() + "_rate"];
    rates.emplace_back(node, canonical.Add(rate));
    along_rates += expression.diff(symbol) * rate;
  }
  INFO("along the rates");
  compare(derive.AddDirection(rates), along_rates);
}

int CompareOnTexts(const std::vector<std::string>& texts, Counts& counts) {
  const SymbolicLock lock;
  const auto any_name = [](const std::string& name, bool called) -> std::optional<std::string> {
    if (called && !std::count(kModelFunctions.begin(), kModelFunctions.end(), name)) {
      return "not a function";
    }
    return std::nullopt;
  };
  Symbols symbols;
  int compared = 0;
  for (const std::string& text : texts) {
    if (FindLexicalProblem(text, any_name)) continue;
    GiNaC::ex expression;
    try {
      // The names first (any name is a symbol), then the text again with real symbols.
      GiNaC::parser discover;
      discover(text);
      GiNaC::symtab names;
      for (const auto& [name, symbol] : discover.get_syms()) names[name] = symbols[name];
      names["Pi"] = GiNaC::Pi;
      expression = GiNaC::parser(names, /*strict=*/true)(text);
      static_cast<void>(expression.diff(symbols["probe"]));
    } catch (const std::exception&) {
      continue;  // refused by the loader, for GiNaC's reasons
    }
    INFO(text);
    try {
      CompareDerivatives(expression, symbols, counts);
    } catch (const std::exception& error) {
      // GiNaC cannot differentiate it (a pole of a derivative): the loader reports that.
      continue;
    }
    ++compared;
  }
  return compared;
}

TEST_CASE("derivatives on canonical forms are GiNaC's, multiplied out", "[modeling]") {
  const std::vector<std::string> cases = {
      "m*l^2*9*cos(a - b)*a_dot*b_dot",
      "m/2*(a_dot + b_dot)^2 + c*a*b",
      "(x + y)^3*z",
      "x^(-2)*y + x^(1/2)",
      "sin(x)^2*cos(y) + exp(x*y) + sinh(x - y)*cosh(2*x)",
      "tan(x*y) + log(x) + abs(x)",
      "exp(x)*exp(y)*x",
      "sqrt(x)*y",
      "atan(x + y)",             // 1/(1 + (x + y)^2): refused
      "atan2(y, x) + x/(x + y)"  // quotients by sums: refused
  };
  Counts counts;
  CHECK(CompareOnTexts(cases, counts) == int(cases.size()));
  CHECK(counts.taken > 10);
  CHECK(counts.refused >= 4);
}

TEST_CASE("derivatives on canonical forms agree with GiNaC on every model expression",
          "[modeling]") {
  Counts counts;
  CHECK(CompareOnTexts(testing::ModelTexts(), counts) > 500);
  // Most of them polynomials in their atoms: taken.
  CHECK(counts.taken > 1000);
  CHECK(counts.taken > 4 * counts.refused);
}

// Energies as a user writes them: a double pendulum in absolute angles, a cart written with a
// square of a sum, dissipation and generalized forces.
TEST_CASE("Lagrange's equations on canonical forms are GiNaC's, multiplied out", "[modeling]") {
  const SymbolicLock lock;
  const GiNaC::realsymbol a("a"), b("b"), x("x"), a_dot("a_dot"), b_dot("b_dot"), x_dot("x_dot");
  const GiNaC::realsymbol m("m"), l("l"), g("g"), c("c"), d("d"), f("f");
  const std::vector<GiNaC::realsymbol> coordinates = {a, b, x}, velocities = {a_dot, b_dot, x_dot};
  Energies energies;
  energies.kinetic = m * l * l / 2 * (2 * a_dot * a_dot + b_dot * b_dot) +
                     m * l * l * GiNaC::cos(a - b) * a_dot * b_dot +
                     m / 2 * GiNaC::pow(x_dot + l * GiNaC::cos(a) * a_dot, 2);
  energies.potential = -m * g * l * (2 * GiNaC::cos(a) + GiNaC::cos(b)) + c / 2 * x * x;
  energies.dissipation = d / 2 * GiNaC::pow(a_dot - b_dot, 2);
  energies.generalized_forces = GiNaC::matrix(3, 1);
  energies.generalized_forces(2, 0) = f * (x + a) * (x - b);
  TermBudget ginac_budget, canonical_budget;
  const std::vector<GiNaC::ex> momenta = Momenta(energies.kinetic, velocities);
  const GiNaC::matrix mass = KineticMassMatrix(momenta, velocities, ginac_budget);
  const GiNaC::matrix forces =
      LagrangeForces(energies, momenta, coordinates, velocities, ginac_budget);

  CanonicalExpressions canonical;
  CanonicalEnergies canonical_energies{canonical.Add(energies.kinetic),
                                       canonical.Add(energies.potential),
                                       canonical.Add(energies.dissipation),
                                       {}};
  std::vector<CanonicalExpressions::NodeId> coordinate_nodes, velocity_nodes;
  for (std::size_t k = 0; k < 3; ++k) {
    canonical_energies.generalized_forces.push_back(
        canonical.Add(energies.generalized_forces(unsigned(k), 0)));
    coordinate_nodes.push_back(canonical.Add(coordinates[k]).node);
    velocity_nodes.push_back(canonical.Add(velocities[k]).node);
  }
  const std::optional<CanonicalEquationsOfMotion> derived = ExpandedLagrangeEquations(
      canonical, canonical_energies, coordinate_nodes, velocity_nodes, canonical_budget);
  REQUIRE(derived);
  const auto same = [&](const Scaled& value, const GiNaC::ex& expected) {
    const Scaled converted = canonical.Add(expected.expand());
    INFO("derived: " << canonical.Text(value) << ", GiNaC: " << canonical.Text(converted));
    CHECK(value.node == converted.node);
    CHECK(value.coefficient.is_equal(converted.coefficient));
  };
  for (unsigned i = 0; i < 3; ++i) {
    for (unsigned j = 0; j < 3; ++j) same(derived->mass_matrix[i * 3 + j], mass(i, j));
    same(derived->forces[i], forces(i, 0));
  }
  CHECK(canonical_budget.used() == ginac_budget.used());
  CHECK(ExpandsToQuadraticForm(canonical, canonical_energies.kinetic, derived->mass_matrix,
                               velocity_nodes));
  // A term linear in a velocity is no quadratic form.
  const Scaled not_quadratic = canonical.Add(energies.kinetic + c * x_dot);
  CHECK_FALSE(
      ExpandsToQuadraticForm(canonical, not_quadratic, derived->mass_matrix, velocity_nodes));
}

TEST_CASE("Lagrange's equations on canonical forms refuse a quotient by a sum", "[modeling]") {
  const SymbolicLock lock;
  const GiNaC::realsymbol x("x"), x_dot("x_dot");
  CanonicalExpressions canonical;
  const CanonicalEnergies energies{canonical.Add(x_dot * x_dot / (1 + x * x)),
                                   canonical.Number(0),
                                   canonical.Number(0),
                                   {canonical.Number(0)}};
  TermBudget budget;
  CHECK_FALSE(ExpandedLagrangeEquations(canonical, energies, {canonical.Add(x).node},
                                        {canonical.Add(x_dot).node}, budget));
}

}  // namespace
}  // namespace servokit::detail
