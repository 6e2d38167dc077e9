#include "modeling/expression_program.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

namespace servokit {
namespace {

// The compiled program and GiNaC's evalf (17 significant digits) evaluate the same expression
// in a different order: the expressions below have no cancellation, so they agree to a few ulps.
constexpr double kRelativeTolerance = 1e-13;
constexpr int kRandomPoints = 25;
constexpr unsigned kSeed = 42u;

// Three real inputs with domains where every test expression below is defined and far from
// zero crossings: x in [0.2, 1.5], y in [0.3, 2.0], z in [-0.9, 0.9] (z crosses 0 on purpose
// for abs and its derivative, which are exact there).
struct Inputs {
  GiNaC::realsymbol x{"x"}, y{"y"}, z{"z"};
  std::vector<GiNaC::ex> symbols() const { return {x, y, z}; }
};

std::vector<std::vector<double>> RandomPoints() {
  std::mt19937 random(kSeed);
  std::uniform_real_distribution<double> x(0.2, 1.5), y(0.3, 2.0), z(-0.9, 0.9);
  std::vector<std::vector<double>> points;
  for (int i = 0; i < kRandomPoints; ++i) {
    points.push_back({x(random), y(random), z(random)});
  }
  return points;
}

double GinacValue(const GiNaC::ex& expression,
                  const std::vector<GiNaC::ex>& symbols,
                  const std::vector<double>& point) {
  GiNaC::exmap values;
  for (std::size_t i = 0; i < symbols.size(); ++i) {
    values[symbols[i]] = GiNaC::numeric(point[i]);
  }
  const GiNaC::ex value = expression.subs(values).evalf();
  REQUIRE(GiNaC::is_a<GiNaC::numeric>(value));
  REQUIRE(GiNaC::ex_to<GiNaC::numeric>(value).is_real());
  return GiNaC::ex_to<GiNaC::numeric>(value).to_double();
}

std::vector<double> Run(const ExpressionProgram& program, const std::vector<double>& inputs) {
  std::vector<double> registers(program.num_registers()), outputs(program.num_outputs());
  program.Evaluate(inputs.data(), registers.data(), outputs.data());
  return outputs;
}

// Compiles all expressions into one program and compares every output with GiNaC at random
// points.
void CheckAgainstGinac(const std::vector<GiNaC::ex>& expressions, const Inputs& inputs) {
  const ExpressionProgram program = CompileExpressions(expressions, inputs.symbols());
  REQUIRE(program.num_inputs() == 3);
  REQUIRE(program.num_outputs() == expressions.size());
  for (const std::vector<double>& point : RandomPoints()) {
    const std::vector<double> outputs = Run(program, point);
    for (std::size_t k = 0; k < expressions.size(); ++k) {
      INFO("expression " << expressions[k] << " at x=" << point[0] << " y=" << point[1]
                         << " z=" << point[2]);
      CHECK(
          outputs[k] ==
          Approx(GinacValue(expressions[k], inputs.symbols(), point)).epsilon(kRelativeTolerance));
    }
  }
}

TEST_CASE("every supported function evaluates as GiNaC evaluates it", "[models]") {
  const Inputs in;
  const auto& [x, y, z] = std::tie(in.x, in.y, in.z);
  CheckAgainstGinac({GiNaC::sin(x), GiNaC::cos(z), GiNaC::tan(x), GiNaC::asin(z), GiNaC::acos(z),
                     GiNaC::atan(y), GiNaC::exp(x), GiNaC::log(y), GiNaC::sqrt(x * y),
                     GiNaC::sinh(z), GiNaC::cosh(z), GiNaC::tanh(z), GiNaC::abs(z), GiNaC::Pi * x},
                    in);
}

TEST_CASE("atan2 covers all four quadrants", "[models]") {
  const Inputs in;
  const auto& [x, y, z] = std::tie(in.x, in.y, in.z);
  CheckAgainstGinac({GiNaC::atan2(y, x), GiNaC::atan2(y, -x), GiNaC::atan2(-y, -x),
                     GiNaC::atan2(-y, x), GiNaC::atan2(z, x)},
                    in);
}

TEST_CASE("integer, negative, half-integer and general powers", "[models]") {
  const Inputs in;
  const auto& [x, y, z] = std::tie(in.x, in.y, in.z);
  const GiNaC::numeric half(1, 2);
  CheckAgainstGinac(
      {GiNaC::pow(x, 2), GiNaC::pow(x, 3), GiNaC::pow(x + y, 7), GiNaC::pow(y, 40),
       GiNaC::pow(x, -1), GiNaC::pow(x, -3), GiNaC::pow(x, half), GiNaC::pow(x, -half),
       GiNaC::pow(x, GiNaC::numeric(3, 2)), GiNaC::pow(y, GiNaC::numeric(-5, 2)),
       GiNaC::pow(x, GiNaC::numeric(1, 3)), GiNaC::pow(x, y), GiNaC::pow(2, x),
       GiNaC::pow(y, GiNaC::numeric(0.7)), GiNaC::pow(z, 2) + 1},
      in);
}

TEST_CASE("sums, differences, products and quotients with rational coefficients", "[models]") {
  const Inputs in;
  const auto& [x, y, z] = std::tie(in.x, in.y, in.z);
  const GiNaC::numeric five_thirds(5, 3);
  CheckAgainstGinac({x + y, y - x, -x - y, -x, x / y, -x * y, 1 / (x + y), five_thirds * x - 3,
                     -2 * x / (y * y), x * y * GiNaC::pow(z + 2, -2) / GiNaC::sqrt(y),
                     GiNaC::numeric(-1, 7) + x, GiNaC::numeric(2.5) * z * z},
                    in);
}

TEST_CASE("derivatives GiNaC writes for the supported functions compile", "[models]") {
  const Inputs in;
  const auto& [x, y, z] = std::tie(in.x, in.y, in.z);
  // With real symbols GiNaC writes abs'(z) as z/abs(z) (no csgn or step appears) and
  // abs''(z) as 0; atan2, sqrt, tan and the inverse functions give powers and sums.
  const std::vector<GiNaC::ex> functions = {GiNaC::abs(z) * x,      GiNaC::abs(GiNaC::sin(z)),
                                            GiNaC::atan2(y, z + 2), GiNaC::sqrt(x + y),
                                            GiNaC::tan(x),          GiNaC::asin(z),
                                            GiNaC::acos(z),         GiNaC::atan(y * z),
                                            GiNaC::log(x * y),      GiNaC::tanh(z),
                                            GiNaC::pow(x, y),       GiNaC::exp(-z * z)};
  std::vector<GiNaC::ex> derivatives;
  for (const GiNaC::ex& function : functions) {
    for (const GiNaC::realsymbol& symbol : {in.x, in.y, in.z}) {
      derivatives.push_back(function.diff(symbol));
      derivatives.push_back(function.diff(symbol, 2));
    }
  }
  CheckAgainstGinac(derivatives, in);
}

TEST_CASE("the derivative of abs is the sign of its argument", "[models]") {
  const Inputs in;
  const ExpressionProgram program = CompileExpressions({GiNaC::abs(in.z).diff(in.z)}, in.symbols());
  CHECK(Run(program, {1.0, 1.0, -0.5}).at(0) == -1.0);
  CHECK(Run(program, {1.0, 1.0, 0.25}).at(0) == 1.0);
}

TEST_CASE("a common subexpression is computed once", "[models]") {
  const Inputs in;
  const GiNaC::ex shared = GiNaC::sin(in.x) * in.y;
  // sin(x), sin(x)*y, cos(sin(x)*y), the sum: 4 instructions; without sharing sin(x)*y would be
  // built twice (6).
  const ExpressionProgram program =
      CompileExpressions({shared + GiNaC::cos(shared), shared, GiNaC::sin(in.x)}, in.symbols());
  CHECK(program.num_instructions() == 4);
  CHECK(program.num_registers() == program.num_inputs() + program.num_instructions());
  const std::vector<double> outputs = Run(program, {0.5, 2.0, 0.0});
  const double expected_shared = std::sin(0.5) * 2.0;
  CHECK(outputs[0] == Approx(expected_shared + std::cos(expected_shared)));
  CHECK(outputs[1] == Approx(expected_shared));
  CHECK(outputs[2] == Approx(std::sin(0.5)));
}

TEST_CASE("constant outputs need no instructions and share one register", "[models]") {
  const Inputs in;
  const ExpressionProgram program =
      CompileExpressions({0, GiNaC::numeric(3, 2), 0, GiNaC::Pi}, in.symbols());
  CHECK(program.num_instructions() == 0);
  CHECK(program.num_registers() == program.num_inputs() + 3);  // 0, 3/2, pi
  const std::vector<double> outputs = Run(program, {1.0, 2.0, 3.0});
  CHECK(outputs == std::vector<double>{0.0, 1.5, 0.0, std::numbers::pi});
}

TEST_CASE("unsupported constructs are rejected with their text", "[models]") {
  const Inputs in;
  const GiNaC::realsymbol stranger("w");
  const auto compile = [&](const GiNaC::ex& expression) {
    return CompileExpressions({expression}, in.symbols());
  };
  REQUIRE_THROWS_MATCHES(compile(in.x + stranger), std::invalid_argument,
                         Catch::Message("cannot compile symbol that is not an input: w"));
  REQUIRE_THROWS_WITH(compile(GiNaC::lgamma(in.x)), Catch::Contains("lgamma(x)"));
  REQUIRE_THROWS_WITH(compile(GiNaC::Euler * in.x), Catch::Contains("Euler"));
  REQUIRE_THROWS_WITH(compile(GiNaC::I * in.x), Catch::Contains("complex number: I"));
  REQUIRE_THROWS_WITH(compile(GiNaC::csgn(in.x).diff(in.x)), Catch::Contains("csgn"));
  REQUIRE_THROWS_WITH(compile(GiNaC::lst{in.x, in.y}), Catch::Contains("{x,y}"));
  REQUIRE_THROWS_WITH(compile(GiNaC::numeric("1e400") * in.x),
                      Catch::Contains("outside the range of double"));
}

TEST_CASE("input symbols must be distinct symbols", "[models]") {
  const Inputs in;
  REQUIRE_THROWS_AS(CompileExpressions({in.x}, {in.x, in.x}), std::invalid_argument);
  REQUIRE_THROWS_AS(CompileExpressions({in.x}, {in.x + 1}), std::invalid_argument);
}

}  // namespace
}  // namespace servokit
