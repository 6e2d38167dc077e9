// servokit's reader of expressions (modeling/expression_parser.h) against GiNaC's parser: the
// same text must give the same canonical form, node for node and coefficient for coefficient,
// whichever route built it. The texts are every expression of the shipped and test models and of
// the fuzz corpus, and cases written for each rule the reader applies itself (sums flattened and
// combined, numbers distributed over a sum, monomials with their exponents added, quotients).
#include "modeling/expression_parser.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "modeling/loader_support.h"
#include "modeling/symbolic_lock.h"
#include "modeling/yaml_document.h"
#include "tests/model_texts.h"

namespace servokit {
namespace {

using testing::ModelTexts;

const std::vector<std::string> kRuleCases = {
    "2*(x+y)",
    "-(x+y)*2",
    "(x+y)*(-3)",
    "(2*x+4*y)*x",
    "x/2/y*3",
    "x*x",
    "x*y*x^3/y",
    "3*x^(1/2)*x^(1/2)",
    "x^0",
    "x^2*x^(-2)",
    "1/(x*y)",
    "(x*y)^2",
    "(2*x)^3",
    "(-x)^2",
    "x - x",
    "0*x",
    "2*x - 2*x + 1",
    "x - y - x",
    "-x - 1",
    "-x^2",
    "-2^2",
    "1e-6*(2*x + 3*x^2*y + 4*y^3) + k*y",
    "k*y + 2*(x + y) - (x - y)*2",
    "sin(x)^2 + cos(x)^2",
    "sqrt(x^2)",
    "sqrt(4) + sqrt(2)*sqrt(2)",
    "abs(-x)",
    "exp(log(x))",
    "1.5*x + 2.5*x",
    "0.1*x + 0.2*x + 0.3",
    "Pi*x/2",
    "atan2(y, x) + atan2(1, 2)",
    "x/(x + y)",
    "(x + y)/2",
    "(x + y)*(x - y)",
    "2^(1/2)*2^(1/2)",
    "(1/2)*x",
    "x/0.5",
    "1.5e3*x + 2E-3",
    "m*(k*x + 2*k*y)*(x + y)^2",
    "(x + y)^(1/2)*(x + y)^(3/2)",
    "sin(-x) + cos(-x) + tan(0)",
    "(x*y^2*3)/(6*y)",
    "m*l^2*9*cos(x - y)*x_dot*y_dot",
    "2*sin(x)*y/3 + Pi*x",
    "exp(x)*exp(x)",
    "cos(x)*cos(x)*y",
    "x/cos(x)",
    "x/exp(y)",
    "Pi*x*Pi",
    "(2*cos(x)*y)*(3*sin(x)*y)",
    "(cos(x)*y)*(cos(x)*z)",
    "abs(x)*abs(x)",
    "-exp(x)*(x + y)",
};

std::size_t CompareRoutes(const std::vector<std::string>& texts) {
  const SymbolicLock lock;
  std::size_t compared = 0;
  const auto check_name = [](const std::string& name, bool called) -> std::optional<std::string> {
    if (called &&
        !std::count(detail::kModelFunctions.begin(), detail::kModelFunctions.end(), name)) {
      return "not a function";
    }
    return std::nullopt;
  };
  GiNaC::parser ginac;  // not strict: every new name is a new symbol, the same in every text
  for (const std::string& text : texts) {
    // One store per text: GiNaC holds 2 and 2.0 equal, so one store would give x^2 the node
    // of an x^2.0 read before it (numerically the same).
    CanonicalExpressions canonical;
    if (detail::FindLexicalProblem(text, check_name)) continue;
    GiNaC::ex parsed;
    try {
      parsed = ginac(text);
    } catch (const std::exception&) {
      continue;  // an expression the loader refuses, for GiNaC's reasons
    }
    GiNaC::symtab names = ginac.get_syms();
    names["Pi"] = GiNaC::Pi;
    INFO(text);
    ExpressionParser parser(canonical, names);
    CanonicalExpressions::Scaled read;
    REQUIRE_NOTHROW(read = parser.Parse(text));
    const CanonicalExpressions::Scaled converted = canonical.Add(parsed);
    INFO("read: " << canonical.Text(read) << ", GiNaC: " << canonical.Text(converted));
    CHECK(read.node == converted.node);
    CHECK(read.coefficient.is_equal(converted.coefficient));
    ++compared;
  }
  return compared;
}

TEST_CASE("the reader gives GiNaC's canonical form for each of its rules", "[models]") {
  CHECK(CompareRoutes(kRuleCases) == kRuleCases.size());
}

TEST_CASE("the reader gives GiNaC's canonical form for every model expression", "[models]") {
  const std::vector<std::string> texts = ModelTexts();
  // Hundreds of files' expressions, so that the comparison cannot pass on nothing.
  CHECK(CompareRoutes(texts) > 500);
}

TEST_CASE("the reader reports GiNaC's errors for text it does not take", "[models]") {
  const SymbolicLock lock;
  CanonicalExpressions canonical;
  GiNaC::symtab names;
  names["x"] = GiNaC::realsymbol("x");
  ExpressionParser parser(canonical, names);
  const auto message_of = [&](const std::string& text) -> std::string {
    try {
      parser.Parse(text);
    } catch (const std::exception& error) {
      return error.what();
    }
    return "";
  };
  const auto ginac_message_of = [&](const std::string& text) -> std::string {
    try {
      GiNaC::parser(names, true)(text);
    } catch (const std::exception& error) {
      return error.what();
    }
    return "";
  };
  for (const std::string text :
       {"x +", "x**2", "x^2^3", "(x", "x)", "1/0", "x/0", "log(0)", "0^(-1)", "y", "x y"}) {
    INFO(text);
    const std::string message = message_of(text);
    CHECK(!message.empty());
    CHECK(message == ginac_message_of(text));
  }
}

}  // namespace
}  // namespace servokit
