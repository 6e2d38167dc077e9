// Every malformed model file gives one ModelError that names the file, the key and the entry
// (docs/model-files.md, "The explicit form"). Each case edits one line of a valid model
// (the mass on a car).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "modeling/model.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::TestDataPath;

const std::string kSource = "models/bad.yaml";

const std::string kValidModel = R"(name: test
parameters:
  m1: 1.0
  m2: 2.0
  k: 5.0
  d: 1.0
  alpha: 5 deg
coordinates: [x, s]
inputs: [F]
mass_matrix:
  - [m1 + m2, m2*cos(alpha)]
  - [m2*cos(alpha), m2]
forces:
  - 0
  - k*s + d*s_dot
input_matrix:
  - [1]
  - [0]
outputs:
  - x + s*cos(alpha)
)";

// kValidModel with the one occurrence of `from` replaced by `to`.
std::string Edit(const std::string& from, const std::string& to) {
  const std::size_t at = kValidModel.find(from);
  REQUIRE(at != std::string::npos);
  REQUIRE(kValidModel.find(from, at + 1) == std::string::npos);
  std::string text = kValidModel;
  return text.replace(at, from.size(), to);
}

// The message of the ModelError that `load` throws; any other outcome fails the test.
template <typename Load>
std::string ModelErrorMessage(const Load& load) {
  try {
    load();
  } catch (const ModelError& error) {
    return error.what();
  }
  FAIL("no ModelError was thrown");
  return {};
}

std::string ErrorOf(const std::string& text) {
  return ModelErrorMessage([&] { LoadModelFromString(text, kSource); });
}

void RequireError(const std::string& text, const std::string& message) {
  CHECK(ErrorOf(text) == kSource + ": " + message);
}

TEST_CASE("the unedited model is valid", "[models]") {
  CHECK_NOTHROW(LoadModelFromString(kValidModel, kSource));
}

TEST_CASE("a missing file is reported with its path", "[models]") {
  REQUIRE_THROWS_MATCHES(
      LoadModel("/nonexistent/model.yaml"), ModelError,
      Catch::Message(
          "/nonexistent/model.yaml: cannot read the model file (No such file or directory)"));
}

TEST_CASE("a directory is not a model file", "[models]") {
  CHECK_THAT(ModelErrorMessage([] { LoadModel(TestDataPath("")); }),
             Catch::Contains(": cannot read the model file"));
}

TEST_CASE("bad YAML is reported with line and column", "[models]") {
  // The unclosed "[x, s" of line 4 is noticed where yaml-cpp expected its end, at line 5.
  const std::string path = TestDataPath("models_bad_yaml.yaml");
  REQUIRE_THROWS_MATCHES(LoadModel(path), ModelError,
                         Catch::Message(path + ":5:7: bad YAML: end of sequence flow not found"));
}

TEST_CASE("the top level must be a map", "[models]") {
  CHECK_THAT(ErrorOf("- name\n- test\n"),
             Catch::StartsWith(kSource + ": top level: expected a map with the keys name, "
                                         "parameters,"));
  CHECK_THAT(ErrorOf(""), Catch::StartsWith(kSource + ": top level: expected a map"));
}

TEST_CASE("a missing required key is named", "[models]") {
  RequireError(Edit("forces:\n  - 0\n  - k*s + d*s_dot\n", ""), "forces: missing required key");
  RequireError(Edit("name: test\n", ""), "name: missing required key");
}

TEST_CASE("an unknown top-level key is an error, so typos do not pass", "[models]") {
  RequireError(Edit("mass_matrix:", "mass_matrx:"),
               "mass_matrx: unknown key (expected name, parameters, coordinates, inputs, "
               "mass_matrix, forces, input_matrix, outputs, description, constraints, q0 or kind)");
}

// modeling/loaded_model.h: the reader takes `kind: multibody` (or no kind) as this format, so
// LoadModel accepts it; a linear model file is not one of its own.
TEST_CASE("kind: multibody is accepted; kind: linear and unknown kinds are named", "[models]") {
  CHECK_NOTHROW(LoadModelFromString(kValidModel + "kind: multibody\n", kSource));
  RequireError(kValidModel + "kind: linear\n",
               "kind: a linear model (Matrix Market matrices), which only the linear analysis "
               "and its sweep read; this needs a multibody model");
  RequireError(kValidModel + "kind: rigid\n",
               "kind: unknown kind 'rigid' (expected linear, multibody, lagrangian or "
               "planar-bodies)");
}

TEST_CASE("a duplicate top-level key is an error", "[models]") {
  RequireError(kValidModel + "name: again\n", "name: duplicate key");
}

TEST_CASE("the name must be a string", "[models]") {
  RequireError(Edit("name: test", "name: [a, b]"), "name: expected a non-empty string");
}

TEST_CASE("the description is optional but must be a string", "[models]") {
  CHECK(LoadModelFromString(kValidModel + "description: a car\n", kSource).description() ==
        "a car");
  RequireError(kValidModel + "description: [a]\n", "description: expected a string");
}

TEST_CASE("a parameter value must be a number or a number of degrees", "[models]") {
  RequireError(Edit("k: 5.0", "k: abc"), "parameters.k: not a number (use e.g. 5 or \"5 deg\")");
  RequireError(Edit("alpha: 5 deg", "alpha: 5 grad"),
               "parameters.alpha: not a number (use e.g. 5 or \"5 deg\")");
  RequireError(Edit("k: 5.0", "k: [5]"), "parameters.k: not a number (use e.g. 5 or \"5 deg\")");
}

TEST_CASE("parameters must be a map", "[models]") {
  RequireError(Edit("parameters:\n  m1: 1.0\n  m2: 2.0\n  k: 5.0\n  d: 1.0\n  alpha: 5 deg\n",
                    "parameters: [m1, m2]\n"),
               "parameters: expected a map of name: value (use {} for none)");
}

TEST_CASE("a name used twice is an error naming both places", "[models]") {
  RequireError(Edit("d: 1.0", "x: 1.0"), "coordinates[0]: duplicate name 'x' (also parameters.x)");
  RequireError(Edit("d: 1.0", "k: 1.0"), "parameters.k: duplicate name 'k' (also parameters.k)");
  RequireError(Edit("inputs: [F]", "inputs: [s]"),
               "inputs[0]: duplicate name 's' (also coordinates[1])");
}

TEST_CASE("a name may not clash with a function", "[models]") {
  RequireError(Edit("d: 1.0", "sin: 1.0"),
               "parameters.sin: name 'sin' clashes with the function sin()");
}

TEST_CASE("a name may not clash with pi or the parser's constants", "[models]") {
  RequireError(Edit("d: 1.0", "pi: 1.0"), "parameters.pi: name 'pi' is reserved for a constant");
  RequireError(Edit("coordinates: [x, s]", "coordinates: [x, I]"),
               "coordinates[1]: name 'I' is reserved for a constant");
}

TEST_CASE("a name may not clash with the velocity of a coordinate", "[models]") {
  RequireError(Edit("d: 1.0", "s_dot: 1.0"),
               "parameters.s_dot: name 's_dot' clashes with the velocity of coordinate 's'");
}

TEST_CASE("a name must be an identifier", "[models]") {
  RequireError(Edit("coordinates: [x, s]", "coordinates: [x, 2s]"),
               "coordinates[1]: invalid name '2s' (use letters, digits and _, starting with a "
               "letter)");
  RequireError(Edit("inputs: [F]", "inputs: [F G]"),
               "inputs[0]: invalid name 'F G' (use letters, digits and _, starting with a "
               "letter)");
}

TEST_CASE("coordinates and inputs must not be empty", "[models]") {
  RequireError(Edit("coordinates: [x, s]", "coordinates: []"),
               "coordinates: expected at least one name");
  RequireError(Edit("inputs: [F]", "inputs: []"), "inputs: expected at least one name");
  RequireError(Edit("inputs: [F]", "inputs: F"), "inputs: expected a list of names, e.g. [x, s]");
}

TEST_CASE("more inputs than coordinates is an error", "[models]") {
  RequireError(Edit("inputs: [F]", "inputs: [F, G, T]"),
               "inputs: 3 inputs for 2 coordinates; a system has at most as many inputs as "
               "coordinates");
}

TEST_CASE("an expression with a syntax error is named with its text", "[models]") {
  RequireError(Edit("k*s + d*s_dot", "k*s +"),
               "forces[1]: syntax error in \"k*s +\": unexpected token, got: EOF");
  RequireError(Edit("k*s + d*s_dot", "cos(s, s)"), "forces[1]: cos() takes 1 argument, found 2");
}

TEST_CASE("a long expression's syntax error quotes its first 160 bytes and its length",
          "[models]") {
  // 1999 terms "k*s + " (6 bytes each) and "k*s +", a sum without its last operand: 11999
  // bytes, of which the message quotes 160.
  std::string sum;
  for (int i = 0; i < 1999; ++i) sum += "k*s + ";
  sum += "k*s +";
  const std::string message = ErrorOf(Edit("k*s + d*s_dot", sum));
  CHECK(message == kSource + ": forces[1]: syntax error in \"" + sum.substr(0, 160) +
                       "... (11999 bytes)\": unexpected token, got: EOF");
}

// Found by fuzzing (issue #7; the inputs are in tests/fuzz/regressions/): GiNaC's parser
// dereferences a null pointer on cos(), and computes number^number exactly, for ever.
TEST_CASE("parentheses and function arguments are checked before GiNaC parses", "[models]") {
  RequireError(Edit("k*s + d*s_dot", "cos()"), "forces[1]: empty argument of cos()");
  RequireError(Edit("k*s + d*s_dot", "atan2(s)"), "forces[1]: atan2() takes 2 arguments, found 1");
  RequireError(Edit("k*s + d*s_dot", "atan2(s, )"), "forces[1]: empty argument of atan2()");
  RequireError(Edit("k*s + d*s_dot", "k*(s, s)"), "forces[1]: ',' outside a function's arguments");
  RequireError(Edit("k*s + d*s_dot", "k*s)"), "forces[1]: ')' without '('");
  RequireError(Edit("k*s + d*s_dot", "k*(s"), "forces[1]: '(' without ')'");
  RequireError(Edit("k*s + d*s_dot", "k*()"), "forces[1]: empty parentheses");
  RequireError(Edit("k*s + d*s_dot", std::string(101, '(') + "s" + std::string(101, ')')),
               "forces[1]: parentheses nested deeper than 100");
  CHECK_NOTHROW(LoadModelFromString(
      Edit("k*s + d*s_dot", std::string(100, '(') + "s" + std::string(100, ')')), kSource));
}

// A long enough line overflowed the stack in GiNaC's recursive parser (exit 139).
TEST_CASE("chains of powers are bounded", "[models]") {
  std::string chain = "s";
  for (int i = 0; i < 11; ++i) chain += "^1";
  RequireError(Edit("k*s + d*s_dot", chain), "forces[1]: more than 10 powers in a chain a^b^c...");
  // Powers that are not chained do not count: a polynomial in s.
  std::string polynomial = "s";
  for (int i = 2; i < 30; ++i) polynomial += " + s^" + std::to_string(i);
  CHECK_NOTHROW(LoadModelFromString(Edit("k*s + d*s_dot", polynomial), kSource));
}

// GiNaC's parser gives a sign after an operator the whole rest of the expression (checked
// against GiNaC 1.8 directly): 2*-s+1 is 2*(1-s), s^-2+1 is s^(-1), s - -s + 1 is 2s - 1, and
// - -s+1 is s - 1. Found while fuzzing (x^-x-9 became x^(-9-x)), issue #7.
TEST_CASE("a sign after an operator is refused: GiNaC would read it differently", "[models]") {
  const std::string hint =
      "': put the signed operand in parentheses, as 2*(-x) (GiNaC would read 2*-x+1 as 2*(-x+1))";
  RequireError(Edit("k*s + d*s_dot", "2*-s+1"), "forces[1]: '-' right after '*" + hint);
  RequireError(Edit("k*s + d*s_dot", "s^-2+1"), "forces[1]: '-' right after '^" + hint);
  RequireError(Edit("k*s + d*s_dot", "s - -s + 1"), "forces[1]: '-' right after '-" + hint);
  RequireError(Edit("k*s + d*s_dot", "s/+s"), "forces[1]: '+' right after '/" + hint);
  RequireError(Edit("k*s + d*s_dot", "(- -s+1)"), "forces[1]: '-' right after '-" + hint);
}

TEST_CASE("a sign that opens an expression, parenthesis or argument reads as usual", "[models]") {
  // f_2(s) for the forms GiNaC reads conventionally, against the value written out in C++.
  const double s = 0.7;
  const std::vector<std::pair<std::string, double>> cases = {
      {"-s*3 + 1", -s * 3 + 1},
      {"-s^2 + 1", -(s * s) + 1},
      {"(-s + 1)*2", (-s + 1) * 2},
      {"2*(-s) + 1", 2 * (-s) + 1},
      {"s^(-2) + 1", 1 / (s * s) + 1},
      {"atan2(-s + 1, 2)", std::atan2(-s + 1, 2)},
      {"+s - 1", s - 1},
  };
  for (const auto& [expression, expected] : cases) {
    INFO(expression);
    const Model model = LoadModelFromString(Edit("k*s + d*s_dot", expression), kSource);
    Workspace workspace(model);
    Evaluate(model, workspace, Eigen::Vector2d(0.1, s), Eigen::Vector2d::Zero(), Quantity::kForces);
    CHECK(workspace.forces(1) == Approx(expected).epsilon(1e-15));
  }
}

TEST_CASE("powers GiNaC would compute for ever are refused", "[models]") {
  // 523^25 = 9.17e67 (25 log10(523) = 67.96); as an exponent it is far above 1000. The message
  // gives it to six significant digits; std::pow in double (relative error ~1e-15) is a second
  // method for GiNaC's exact integer, far below the sixth digit unless that digit sits on a
  // rounding boundary (it does not: 523^25 = 9.1736512e67).
  char exponent[32];
  std::snprintf(exponent, sizeof exponent, "%.6g", std::pow(523.0, 25.0));
  RequireError(Edit("k*s + d*s_dot", "s - 9^(523^25)"), "forces[1]: exponent too large (" +
                                                            std::string(exponent) +
                                                            "; at most 1000 in absolute value)");
  RequireError(Edit("k*s + d*s_dot", "s^2000"),
               "forces[1]: exponent too large (2000; at most 1000 in absolute value)");
  // (2^1000)^1000 = 2^1e6 = 10^301029.996
  RequireError(Edit("k*s + d*s_dot", "(2^1000)^1000*s"),
               "forces[1]: number too large to compute (about 10^301030)");
  // GiNaC expands 8^(9^322 - s) into 8^(9^322) 8^(-s) (a fuzzed input hung for minutes);
  // 9^322 = 10^307.3.
  RequireError(Edit("k*s + d*s_dot", "s + 8^(2*(9^322 - s))"),
               "forces[1]: a number in an exponent too large (about 10^307; at most 1000 in "
               "absolute value: GiNaC would compute a^(n + x) as a^n a^x, a^n exactly)");
  CHECK_NOTHROW(
      LoadModelFromString(Edit("k*s + d*s_dot", "s + 2^(1000 - s) + sin(2^(s + 300))"), kSource));
  // What stays in range is still read: 10^400/10^399 = 10 exactly.
  CHECK_NOTHROW(
      LoadModelFromString(Edit("k*s + d*s_dot", "10^400/10^399*s - 2^(-3^2)*s"), kSource));
}

TEST_CASE("a decimal exponent beyond 10000 is out of range", "[models]") {
  RequireError(Edit("k*s + d*s_dot", "0e20300000000000000000099*s"),
               "forces[1]: number out of range '0e20300000000000000000099'");
  RequireError(Edit("k*s + d*s_dot", "1e-10001*s"), "forces[1]: number out of range '1e-10001'");
  CHECK_NOTHROW(LoadModelFromString(Edit("k*s + d*s_dot", "1e-300*s + 1e+3*s"), kSource));
}

TEST_CASE("an expression that has no derivative is a clear error", "[models]") {
  RequireError(Edit("k*s + d*s_dot", "0^s"),
               "derivatives: cannot differentiate the model's expressions: power::eval(): "
               "division by zero");
}

TEST_CASE("an unknown symbol is named", "[models]") {
  RequireError(Edit("k*s + d*s_dot", "kk*s + d*s_dot"), "forces[1]: unknown symbol 'kk'");
  RequireError(Edit("k*s + d*s_dot", "k*s + d*x_ddot"), "forces[1]: unknown symbol 'x_ddot'");
}

TEST_CASE("an input may not appear in an expression", "[models]") {
  RequireError(Edit("k*s + d*s_dot", "k*s + F"),
               "forces[1]: 'F' is an input; expressions may use parameters, coordinates and "
               "velocities only");
}

TEST_CASE("an unsupported function is named with the supported ones", "[models]") {
  RequireError(Edit("k*s + d*s_dot", "k*gamma(s)"),
               "forces[1]: unsupported function 'gamma' (supported: sin, cos, tan, asin, acos, "
               "atan, atan2, exp, log, sqrt, sinh, cosh, tanh, abs)");
  RequireError(Edit("k*s + d*s_dot", "k*sin s"),
               "forces[1]: function 'sin' needs its argument in parentheses");
}

TEST_CASE("characters and numbers that are not part of the expression language", "[models]") {
  RequireError(Edit("k*s + d*s_dot", "k*s; d"), "forces[1]: unexpected character ';'");
  RequireError(Edit("k*s + d*s_dot", "2s"), "forces[1]: malformed number '2s'");
  RequireError(Edit("k*s + d*s_dot", "k*s**2"),
               "forces[1]: syntax error in \"k*s**2\": unexpected token, got: \"*\"");
}

TEST_CASE("expressions GiNaC evaluates to something unusable are named", "[models]") {
  RequireError(Edit("k*s + d*s_dot", "sqrt(-1)*s"),
               "forces[1]: complex number I in \"sqrt(-1)*s\"");
  RequireError(Edit("k*s + d*s_dot", "1e400*s"),
               "forces[1]: number out of range 1.0E400 in \"1e400*s\"");
  CHECK_THAT(ErrorOf(Edit("k*s + d*s_dot", "k/0")),
             Catch::StartsWith(kSource + ": forces[1]: invalid expression \"k/0\": "));
}

TEST_CASE("an empty or structured entry is not an expression", "[models]") {
  RequireError(Edit("  - 0\n", "  -\n"), "forces[0]: empty expression");
  RequireError(Edit("  - 0\n", "  - [0]\n"),
               "forces[0]: expected an expression, found a list or map");
}

TEST_CASE("the mass matrix must have dof rows of dof entries", "[models]") {
  RequireError(Edit("  - [m2*cos(alpha), m2]\n", "  - [m2*cos(alpha), m2]\n  - [0, 0]\n"),
               "mass_matrix: expected 2 rows (one per coordinate), found 3");
  RequireError(Edit("[m2*cos(alpha), m2]", "[m2]"),
               "mass_matrix[1]: expected a row of 2 entries (one per coordinate), found 1");
  RequireError(Edit("[m2*cos(alpha), m2]", "m2"),
               "mass_matrix[1]: expected a row of 2 entries (one per coordinate), found no list");
}

TEST_CASE("the input matrix must have dof rows of one entry per input", "[models]") {
  RequireError(Edit("  - [1]\n", "  - [1, 0]\n"),
               "input_matrix[0]: expected a row of 1 entry (one per input), found 2");
  RequireError(Edit("  - [1]\n  - [0]\n", "  - [1]\n"),
               "input_matrix: expected 2 rows (one per coordinate), found 1");
}

TEST_CASE("forces must have one entry per coordinate", "[models]") {
  RequireError(Edit("  - 0\n", ""), "forces: expected 2 entries (one per coordinate), found 1");
  RequireError(Edit("forces:\n  - 0\n  - k*s + d*s_dot\n", "forces: 0\n"),
               "forces: expected a list of expressions");
}

TEST_CASE("the mass matrix must be symmetric", "[models]") {
  // GiNaC prints products in its own order (cos(alpha)*m2), so only the frame is compared.
  const std::string message = ErrorOf(Edit("  - [m2*cos(alpha), m2]", "  - [m2, m2]"));
  CHECK_THAT(message, Catch::StartsWith(kSource + ": mass_matrix[0][1]: differs from "
                                                  "mass_matrix[1][0] ("));
  CHECK_THAT(message, Catch::EndsWith(" vs m2); the mass matrix must be symmetric"));
}

TEST_CASE("a mass matrix symmetric only by a trigonometric identity is accepted", "[models]") {
  // sin^2 + cos^2 = 1 is invisible to expand() and normal(): the random-point check decides.
  CHECK_NOTHROW(LoadModelFromString(
      Edit("  - [m2*cos(alpha), m2]", "  - [m2*cos(alpha)*(sin(s)^2 + cos(s)^2), m2]"), kSource));
  // The same check sees a difference far below what expand() would show as a "simple" term.
  CHECK_THAT(ErrorOf(Edit("  - [m2*cos(alpha), m2]",
                          "  - [m2*cos(alpha)*(sin(s)^2 + cos(s)^2 + 1/1000000), m2]")),
             Catch::StartsWith(kSource + ": mass_matrix[0][1]: differs from mass_matrix[1][0]"));
}

TEST_CASE("a mass matrix or input matrix that depends on velocities is an error", "[models]") {
  RequireError(Edit("[m2*cos(alpha), m2]", "[m2*cos(alpha), m2 + s_dot^2]"),
               "mass_matrix[1][1]: depends on the velocity 's_dot'; M(q) may depend on parameters "
               "and coordinates only");
  RequireError(Edit("  - [0]\n", "  - [x_dot]\n"),
               "input_matrix[1][0]: depends on the velocity 'x_dot'; B(q) may depend on "
               "parameters and coordinates only");
}

TEST_CASE("as many outputs as inputs are needed", "[models]") {
  RequireError(Edit("  - x + s*cos(alpha)\n", "  - x\n  - s\n"),
               "outputs: 2 outputs for 1 input; servo-constraint problems need as many outputs as "
               "inputs");
}

TEST_CASE("an output that depends on a velocity names it", "[models]") {
  RequireError(Edit("x + s*cos(alpha)", "x + s_dot"),
               "outputs[0]: depends on the velocity 's_dot'; y = h(q) may depend on parameters "
               "and coordinates only");
}

}  // namespace
}  // namespace servokit
