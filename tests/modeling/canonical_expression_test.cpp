// The canonical form of GiNaC expressions (modeling/canonical_expression.h): the same mathematics
// gives the same nodes, the same text and, compiled, the same bits, whatever order or sign
// GiNaC chose for its operands. GiNaC's choices follow hash values seeded with addresses; a
// test cannot steer them, so it builds the variants GiNaC may produce by hand: a sum signed
// either way inside a product, operands listed in another order, a quotient written with its
// numerator and denominator both negated.
#include "modeling/canonical_expression.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "modeling/expression_program.h"

namespace servokit {
namespace {

struct Symbols {
  GiNaC::realsymbol l{"l"}, s{"s"}, m{"m"}, x{"x"}, y{"y"};
  std::vector<GiNaC::ex> list() const { return {l, s, m, x, y}; }
};

// A sum GiNaC cannot see as the negation of another: `a - b - c` kept apart from the product,
// so that the test controls the sign of the sum inside it.
GiNaC::ex Product(const GiNaC::ex& sum, const GiNaC::ex& rest, int sign) {
  return GiNaC::ex(sign) * rest * sum;
}

TEST_CASE("a sum signed either way inside a product has one canonical form", "[models]") {
  const Symbols in;
  const GiNaC::ex positive = 2 * in.l - 3 * in.s + in.x / 7;
  const GiNaC::ex negative = 3 * in.s - 2 * in.l - in.x / 7;
  const GiNaC::ex first = Product(positive, in.m * GiNaC::pow(in.l, 2), 1);
  const GiNaC::ex second = Product(negative, in.m * GiNaC::pow(in.l, 2), -1);
  REQUIRE((first - second).expand().is_zero());
  CHECK(CanonicalText(first) == CanonicalText(second));
  CanonicalExpressions canonical(in.list());
  const CanonicalExpressions::Scaled a = canonical.Add(first);
  const CanonicalExpressions::Scaled b = canonical.Add(second);
  CHECK(a.node == b.node);
  CHECK(a.coefficient == b.coefficient);
  // The sum itself and its negation: one node, opposite coefficients.
  const CanonicalExpressions::Scaled sum = canonical.Add(positive);
  const CanonicalExpressions::Scaled negated = canonical.Add(negative);
  CHECK(sum.node == negated.node);
  CHECK(sum.coefficient == -negated.coefficient);
}

TEST_CASE("compiled, a sum and its negation give exactly negated bits", "[models]") {
  // Round-off depends on the order of the additions; the compiler follows the canonical order
  // with the first term positive, so -(a - b - c) is computed as the negation of a - b - c.
  const Symbols in;
  const GiNaC::ex sum = GiNaC::numeric(1, 3) * in.x - GiNaC::sin(in.y) * in.l + in.s / 7 - 0.1;
  const ExpressionProgram program = CompileExpressions(
      {sum, -sum, (-sum).expand(), in.m * sum, -(in.m * (-sum).expand())}, in.list());
  std::vector<double> registers(program.num_registers()), outputs(program.num_outputs());
  const std::vector<double> inputs = {0.7, 1.3, 2.9, 0.123456789, -5.4321};
  program.Evaluate(inputs.data(), registers.data(), outputs.data());
  CHECK(outputs[1] == -outputs[0]);
  CHECK(outputs[2] == -outputs[0]);
  CHECK(outputs[4] == outputs[3]);
  CHECK(outputs[0] == Approx(0.123456789 / 3 - std::sin(-5.4321) * 0.7 + 1.3 / 7 - 0.1));
}

TEST_CASE("canonical text: GiNaC's syntax, quotients for negative powers", "[models]") {
  const Symbols in;
  const auto& [l, s, m, x, y] = std::tie(in.l, in.s, in.m, in.x, in.y);
  CHECK(CanonicalText(x / y) == "x/y");
  CHECK(CanonicalText(2 * l - 3 * s) == "2*l-3*s");
  CHECK(CanonicalText(3 * s - 2 * l) == "-(2*l-3*s)");
  CHECK(CanonicalText(x - 1) == "x-1");
  CHECK(CanonicalText(x / 2) == "1/2*x");
  CHECK(CanonicalText(-x * y / 3) == "-1/3*x*y");
  CHECK(CanonicalText(GiNaC::pow(x, -2)) == "1/x^2");
  CHECK(CanonicalText(2 / x) == "2/x");
  CHECK(CanonicalText(-1 / (x + y)) == "-1/(x+y)");
  CHECK(CanonicalText(GiNaC::sqrt(x)) == "sqrt(x)");
  CHECK(CanonicalText(y / GiNaC::sqrt(x)) == "y/sqrt(x)");
  CHECK(CanonicalText(GiNaC::pow(x + y, GiNaC::numeric(3, 2))) == "(x+y)^(3/2)");
  CHECK(CanonicalText(2 * l / (3 * l + 2 * s)) == "2*l/(3*l+2*s)");
  CHECK(CanonicalText(x * GiNaC::pow(y, -1) * GiNaC::pow(l, -2)) == "x/(l^2*y)");
  CHECK(CanonicalText(GiNaC::atan2(y, x)) == "atan2(y,x)");
  CHECK(CanonicalText(GiNaC::pow(GiNaC::sin(x), 2)) == "sin(x)^2");
  CHECK(CanonicalText(GiNaC::pow(x, -y)) == "x^(-y)");
  CHECK(CanonicalText(GiNaC::numeric(-2, 3)) == "-2/3");
  CHECK(CanonicalText(GiNaC::Pi * x) == "Pi*x");
}

TEST_CASE("operands are ordered by structure, not by GiNaC's hash order", "[models]") {
  // Symbols by name, then powers, products, sums and functions; numbers last.
  const Symbols in;
  CHECK(CanonicalText(GiNaC::sin(in.x) + in.y * in.x + GiNaC::pow(in.s, 2) + in.m + 4) ==
        "m+s^2+x*y+sin(x)+4");
  CHECK(CanonicalText(in.y * in.x * in.l * in.s * in.m) == "l*m*s*x*y");
}

TEST_CASE("two different symbols of one name are refused unless ordered", "[models]") {
  const GiNaC::realsymbol first("x"), second("x");
  REQUIRE_THROWS_AS(CanonicalText(first + 2 * second), std::invalid_argument);
  // Listed, they stay apart in the order of the list.
  CanonicalExpressions canonical({second, first});
  const CanonicalExpressions::Scaled a = canonical.Add(first);
  const CanonicalExpressions::Scaled b = canonical.Add(second);
  CHECK(a.node != b.node);
  CHECK(canonical.Compare(b.node, a.node) < 0);
}

// Functions whose arguments differ only by a number are distinct in the order too, so that a
// sum of them is sorted the same whatever order its terms come in (a tie would leave GiNaC's).
TEST_CASE("functions of multiples of one argument are ordered by the multiple", "[models]") {
  const Symbols in;
  CanonicalExpressions canonical(in.list());
  const auto twice = canonical.Add(GiNaC::sin(2 * in.x));
  const auto thrice = canonical.Add(GiNaC::sin(3 * in.x));
  const auto negated = canonical.Add(GiNaC::sin(-in.x));
  CHECK(canonical.Compare(twice.node, thrice.node) < 0);
  CHECK(canonical.Compare(thrice.node, twice.node) > 0);
  CHECK(canonical.Compare(negated.node, canonical.Add(GiNaC::sin(in.x)).node) != 0);
  const auto forward = canonical.Sum({thrice, twice, negated});
  const auto backward = canonical.Sum({negated, twice, thrice});
  CHECK(forward.node == backward.node);
  CHECK(canonical.Text(forward) == canonical.Text(backward));
}

}  // namespace
}  // namespace servokit
