// Algebraic inversion of flat servo-constraint problems (paper Sect. 5.1).
//
// Mass on car (models/mass_on_car.yaml, paper Sect. 3, Eqs. 26-27), case 4 (alpha = 0, d = 0):
// y = x + s, m2 y'' = -k s (Eq. 43), so s = -(m2/k) y'' (Eq. 45) and s' = -(m2/k) y''',
// x = y - s, and m1 m2 s'' = -(m1 + m2) k s - m2 F (Eq. 44) with s'' = -(m2/k) y'''' (Eq. 46)
// gives F = (m1 + m2) y'' + m1 m2 / k y'''' (Eq. 47): relative degree 4 = 2 dof, flat.
// Cases 3 (alpha = 0, d > 0: relative degree 3, Eq. 40), 2 (0 < alpha < 90 deg) and 1
// (alpha = 90 deg), both relative degree 2 (Eqs. 31, 33), keep internal dynamics.
//
// Six-mass chain (models/mass_spring_chain.yaml), force on mass 1, output x6 (Blajer 1997b):
// relative degree 12 = 2 dof, flat. Going up the chain from the last mass's trajectory:
//   m x6'' = k (x5 - x6)                 =>  x5 = x6 + (m/k) x6''
//   m xj'' = k (x(j-1) - 2 xj + x(j+1))  =>  x(j-1) = 2 xj - x(j+1) + (m/k) xj''   (j = 5..2)
//   m x1'' + k (x1 - x2) = F             =>  F = m x1'' + k (x1 - x2)
// Each step costs two derivatives, so F needs y^(12) and x1 needs y^(10); HandChain() below
// carries the derivatives of every xj along.
//
// Gantry crane (models/gantry_crane.yaml): the load obeys m p'' = T (-sin(theta), cos(theta))
// - m g e_z with the rope tension T, so y1'' = -T sin(theta) / m and y2'' = g - T cos(theta) / m
// depend on u through T alone: the u-coefficient matrix of (y1'', y2'') has rank 1 at every
// state. The relative degrees (4, 2) of tests/analysis/larger_models_test.cpp belong to the
// linearization at rest, where sin(theta) = 0; the nonlinear crane is flat only through a
// dynamic extension (its test below). Its linearization at rest (kLinearCrane) is
// flat with (4, 2): y1 = x + L0 theta, y2 = L0 + r; the theta row gives y1'' = -g theta, so
// theta = -y1''/g, x = y1 + L0 y1''/g, r = y2 - L0, and
//   F = (mt + m) y1'' + mt L0 / g y1'''',   W = (mw + m) y2'' - m g.
//
// Pendulum (kPendulum) with the horizontal position of its bob as output, y = l sin(theta):
// y'' = l cos(theta) theta'' - l sin(theta) theta'^2 with m l^2 theta'' + m g l sin(theta) = T,
// so theta = asin(y/l), theta' = y' / (l cos(theta)), T = m l^2 theta'' + m g l sin(theta):
// relative degree 2 = 2 dof with nonlinear constraints (Newton, no closed form).
#include "solvers/algebraic_inversion.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "base/errors.h"
#include "modeling/symbolic_model.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

// Round-off of a few dozen operations on numbers of order 1 (the linear cases are solved in
// one Newton step, which is exact up to round-off).
constexpr double kRoundOff = 1e-12;

constexpr char kPendulum[] = R"(
name: pendulum_bob
description: Pendulum driven at its pivot, horizontal position of the bob as output
parameters:
  m: 2.0
  l: 0.5
  g: 9.81
coordinates: [theta]
inputs: [T]
mass_matrix:
  - [m*l^2]
forces:
  - m*g*l*sin(theta)
input_matrix:
  - [1]
outputs:
  - l*sin(theta)
)";

constexpr char kLinearCrane[] = R"(
name: gantry_crane_linearized
description: models/gantry_crane.yaml linearized at rest (theta = 0, r = 0)
parameters:
  mt: 10.0
  mw: 2.0
  m: 5.0
  g: 9.81
  L0: 2.0
coordinates: [x, r, theta]
inputs: [F, W]
mass_matrix:
  - [mt + m, 0,      m*L0]
  - [0,      mw + m, 0]
  - [m*L0,   0,      m*L0^2]
forces:
  - 0
  - -m*g
  - m*g*L0*theta
input_matrix:
  - [1, 0]
  - [0, 1]
  - [0, 0]
outputs:
  - x + L0*theta
  - L0 + r
)";

constexpr char kUnreachableOutput[] = R"(
name: unreachable_output
description: Two masses without coupling; the force drives a, the output is b
parameters:
  k: 3.0
coordinates: [a, b]
inputs: [F]
mass_matrix:
  - [1, 0]
  - [0, 1]
forces:
  - 0
  - k*b
input_matrix:
  - [1]
  - [0]
outputs:
  - b
)";

// The message of the `ErrorType` that `call` throws, or "no error" (Catch2 v2's Message()
// matcher compares whole messages only).
template <typename ErrorType, typename Call>
std::string MessageOf(Call&& call) {
  try {
    call();
  } catch (const ErrorType& error) {
    return error.what();
  }
  return "no error";
}

std::string RefusalOf(const Model& model) {
  return MessageOf<NoSolution>([&model] { const AlgebraicInverse inverse(model); });
}

// Agreement to round-off: relative for numbers away from 0, absolute kRoundOff at 0 (where
// the expected coefficient is exactly 0 and a relative test means nothing).
Approx RoundOffClose(double expected) {
  return Approx(expected).epsilon(kRoundOff).margin(expected == 0 ? kRoundOff : 0.0);
}

double ParameterValue(const Model& model, const std::string& name) {
  return model.parameters()[static_cast<Eigen::Index>(*model.FindParameter(name))];
}

// The coefficient of `symbol` in `formula` with the model's parameter values substituted.
double Coefficient(const Model& model, const GiNaC::ex& formula, const GiNaC::ex& symbol) {
  const GiNaC::ex coefficient =
      model.symbolic().SubstituteParameters(formula.expand().coeff(symbol, 1), model.parameters());
  return GiNaC::ex_to<GiNaC::numeric>(coefficient.evalf()).to_double();
}

struct InverseAnswer {
  Eigen::VectorXd q, q_dot, u;
};

// Evaluate() from q = q_dot = 0 at the model's parameters; REQUIREs success.
InverseAnswer Invert(const AlgebraicInverse& inverse,
                     const Model& model,
                     const Eigen::MatrixXd& output_derivatives) {
  InverseAnswer answer{Eigen::VectorXd::Zero(static_cast<Eigen::Index>(model.dof())),
                       Eigen::VectorXd::Zero(static_cast<Eigen::Index>(model.dof())),
                       Eigen::VectorXd()};
  std::string why;
  const bool ok = inverse.Evaluate(output_derivatives, model.parameters(), answer.q, answer.q_dot,
                                   answer.u, why);
  INFO(why);
  REQUIRE(ok);
  return answer;
}

// Mass on car case 4, paper Eq. (47): the closed form has (m1 + m2) at y'' and m1 m2 / k at
// y'''' and no other term, derived without being told it.
TEST_CASE("mass on car case 4 is flat and its closed form is Eq. (47)", "[solvers][paper]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}});
  const AlgebraicInverse inverse(model);
  CHECK(inverse.output_derivative_orders() == std::vector<int>{4});
  CHECK(inverse.highest_output_derivative() == 4);
  REQUIRE(inverse.input_formulas().size() == 1);
  const GiNaC::ex& force = inverse.input_formulas()[0];
  const double m1 = ParameterValue(model, "m1"), m2 = ParameterValue(model, "m2"),
               k = ParameterValue(model, "k");
  const std::vector<double> expected{0, 0, m1 + m2, 0, m1 * m2 / k};
  GiNaC::ex rest = force.expand();
  for (int order = 0; order <= 4; ++order) {
    const GiNaC::realsymbol& symbol = inverse.output_derivative_symbol(0, order);
    // Exact rationals evaluated in double: round-off only.
    CHECK(Coefficient(model, force, symbol) ==
          RoundOffClose(expected[static_cast<std::size_t>(order)]));
    rest -= force.expand().coeff(symbol, 1) * symbol;
  }
  CHECK(GiNaC::normal(rest.expand()).is_zero());  // nothing else: no constant term
}

// Mass on car case 4 with m1 = 1.5, m2 = 2.5, k = 7: Eq. (47) comes out in the parameters'
// symbols (alpha and d, which are 0, substituted), not in the file's numbers.
TEST_CASE("the closed form keeps the parameters as symbols", "[solvers][paper]") {
  const Model model =
      LoadModel(ModelPath("mass_on_car.yaml"),
                {{"alpha", "0"}, {"d", "0"}, {"m1", "1.5"}, {"m2", "2.5"}, {"k", "7"}});
  const AlgebraicInverse inverse(model);
  REQUIRE(inverse.input_formulas().size() == 1);
  const GiNaC::ex& force = inverse.input_formulas()[0];
  // Eq. (47) with these parameters; exact rationals evaluated in double.
  CHECK(Coefficient(model, force, inverse.output_derivative_symbol(0, 2)) ==
        Approx(1.5 + 2.5).epsilon(kRoundOff));
  CHECK(Coefficient(model, force, inverse.output_derivative_symbol(0, 4)) ==
        Approx(1.5 * 2.5 / 7).epsilon(kRoundOff));
  const GiNaC::ex& m1 = model.symbolic().parameters()[*model.FindParameter("m1")];
  const GiNaC::ex& k = model.symbolic().parameters()[*model.FindParameter("k")];
  CHECK(force.has(m1));
  CHECK(force.has(k));
}

// Mass on car case 4: Evaluate() reproduces Eqs. (45)-(47) and x = y - s at arbitrary y_d^(k).
TEST_CASE("mass on car case 4: state from Eq. (45) and force from Eq. (47)", "[solvers][paper]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}});
  const AlgebraicInverse inverse(model);
  const double m1 = ParameterValue(model, "m1"), m2 = ParameterValue(model, "m2"),
               k = ParameterValue(model, "k");
  const std::vector<std::vector<double>> samples{
      {0, 0, 0, 0, 0}, {1, 0, 0, 0, 0}, {0.3, -1.2, 2.5, -0.7, 4.1}, {-2, 0.5, -0.25, 3, -6}};
  for (const std::vector<double>& sample : samples) {
    Eigen::MatrixXd y(1, 5);
    for (Eigen::Index k_order = 0; k_order < 5; ++k_order) {
      y(0, k_order) = sample[static_cast<std::size_t>(k_order)];
    }
    const InverseAnswer answer = Invert(inverse, model, y);
    const double s = -(m2 / k) * y(0, 2), s_dot = -(m2 / k) * y(0, 3);
    const double force = (m1 + m2) * y(0, 2) + m1 * m2 / k * y(0, 4);
    // One Newton step on linear constraints: round-off only (margin for the zero samples).
    CHECK(answer.q[1] == Approx(s).epsilon(kRoundOff).margin(kRoundOff));
    CHECK(answer.q_dot[1] == Approx(s_dot).epsilon(kRoundOff).margin(kRoundOff));
    CHECK(answer.q[0] == Approx(y(0, 0) - s).epsilon(kRoundOff).margin(kRoundOff));
    CHECK(answer.q_dot[0] == Approx(y(0, 1) - s_dot).epsilon(kRoundOff).margin(kRoundOff));
    CHECK(answer.u[0] == Approx(force).epsilon(kRoundOff).margin(kRoundOff));
  }
}

// Mass on car cases 1-3 (paper Sect. 3): internal dynamics remain, of order 2 (Eqs. 34, 36)
// and 1 (Eq. 40), so there is nothing to invert algebraically.
TEST_CASE("mass on car cases 1 to 3 keep internal dynamics and are refused", "[solvers][paper]") {
  using Catch::Matchers::Contains;
  const auto refusal = [](const std::vector<ParameterOverride>& overrides) {
    return RefusalOf(LoadModel(ModelPath("mass_on_car.yaml"), overrides));
  };
  CHECK_THAT(refusal({{"alpha", "0"}, {"d", "1"}}),  // case 3
             Contains("relative degree is 3") && Contains("internal dynamics of order 1"));
  CHECK_THAT(refusal({{"alpha", "5 deg"}}),  // case 2
             Contains("relative degree is 2") && Contains("internal dynamics of order 2"));
  CHECK_THAT(refusal({{"alpha", "90 deg"}}),  // case 1
             Contains("relative degree is 2") && Contains("internal dynamics of order 2"));
}

// Six-mass chain, force on mass 1, output x6: the hand derivation in the file header.
// y[n] = y^(n), n = 0..12; returns x[j][n] = d^n x_(j+1) / dt^n and the force.
struct ChainAnswer {
  std::vector<std::vector<double>> positions;
  double force = 0;
};

ChainAnswer HandChain(const std::vector<double>& y, double m, double k) {
  ChainAnswer chain;
  chain.positions.assign(6, {});
  chain.positions[5] = y;
  for (std::size_t n = 0; n + 2 < y.size(); ++n) {
    chain.positions[4].push_back(y[n] + m / k * y[n + 2]);
  }
  for (std::size_t j = 4; j >= 1; --j) {
    const std::vector<double>& here = chain.positions[j];
    const std::vector<double>& below = chain.positions[j + 1];
    for (std::size_t n = 0; n + 2 < here.size(); ++n) {
      chain.positions[j - 1].push_back(2 * here[n] - below[n] + m / k * here[n + 2]);
    }
  }
  const std::vector<double>& first = chain.positions[0];
  chain.force = m * first[2] + k * (first[0] - chain.positions[1][0]);
  return chain;
}

TEST_CASE("six-mass chain with the last mass as output is flat with relative degree 12",
          "[solvers]") {
  const Model model = LoadModel(ModelPath("mass_spring_chain.yaml"));
  const AlgebraicInverse inverse(model);
  CHECK(inverse.output_derivative_orders() == std::vector<int>{12});
  REQUIRE(inverse.input_formulas().size() == 1);
  const double m = ParameterValue(model, "m"), k = ParameterValue(model, "k");

  SECTION("the closed form's coefficients are the hand derivation's") {
    // The recursion is linear in y, so y = e_n gives the coefficient of y^(n).
    for (int order = 0; order <= 12; ++order) {
      std::vector<double> unit(13, 0.0);
      unit[static_cast<std::size_t>(order)] = 1;
      const double expected = HandChain(unit, m, k).force;
      // Exact rationals evaluated in double: round-off only, relative to the coefficient.
      CHECK(Coefficient(model, inverse.input_formulas()[0],
                        inverse.output_derivative_symbol(0, order)) == RoundOffClose(expected));
    }
  }

  SECTION("Evaluate gives the hand derivation's states and force") {
    // y^(n) ~ omega^n with omega = sqrt(k/m), so that every term of F has a similar size.
    const double omega = std::sqrt(k / m);
    const std::vector<double> pattern{0.4, -1.1, 0.7,  1.3, -0.2, 0.9, -1.4,
                                      0.6, 1.0,  -0.8, 0.3, 1.2,  -0.5};
    std::vector<double> y(13);
    Eigen::MatrixXd output_derivatives(1, 13);
    for (std::size_t n = 0; n < 13; ++n) {
      y[n] = pattern[n] * std::pow(omega, static_cast<double>(n));
      output_derivatives(0, static_cast<Eigen::Index>(n)) = y[n];
    }
    const ChainAnswer expected = HandChain(y, m, k);
    const InverseAnswer answer = Invert(inverse, model, output_derivatives);
    // One Newton step on 12 linear constraints whose rows span omega^0..omega^11; the rows and
    // columns are equilibrated, and the errors measured were below 3e-15 relative. 1e-12
    // leaves room for other compilers and libm.
    for (std::size_t j = 0; j < 6; ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      CHECK(answer.q[jj] == Approx(expected.positions[j][0]).epsilon(kRoundOff));
      CHECK(answer.q_dot[jj] == Approx(expected.positions[j][1]).epsilon(kRoundOff));
    }
    CHECK(answer.u[0] == Approx(expected.force).epsilon(kRoundOff));
  }
}

// Gantry crane (models/gantry_crane.yaml): the load obeys m y1'' = -T sin(theta) and
// m y2'' = m g - T cos(theta) (y2 the depth below the rail), so the rope angle and tension follow
// from the load's acceleration: theta = atan2(-y1'', g - y2''), T = m |(y1'', g - y2'')|; then
// L = y2 / cos(theta), x = y1 - L sin(theta) = y1 - y2 y1'' / (y2'' - g), and the trolley's
// equation minus the load's horizontal one gives F = mt x'' + m y1''. x'' is written out below
// with N = y2 y1'', D = y2'' - g: (N/D)'' = N''/D - 2 N' D'/D^2 - N D''/D^2 + 2 N D'^2/D^3.
// This is the dynamic extension of the tension (the hoist, W at rest) by two integrators.
TEST_CASE("gantry crane: dynamic extension of the hoist, relative degrees (2, 2) -> (4, 4)",
          "[solvers]") {
  const Model model = LoadModel(ModelPath("gantry_crane.yaml"));
  const AlgebraicInverse inverse(model);
  CHECK(inverse.relative_degree() == std::vector<int>{2, 2});
  CHECK(inverse.output_derivative_orders() == std::vector<int>{4, 4});
  CHECK(inverse.integrators() == 2);
  CHECK(inverse.internal_order() == 0);
  REQUIRE(inverse.extension_steps().size() == 1);
  const StructureStep& step = inverse.extension_steps()[0];
  CHECK(step.rank == 1);
  CHECK(step.kept_rows == std::vector<std::size_t>{1});  // the depth keeps its equation
  CHECK(step.combined_rows == std::vector<std::size_t>{0});
  CHECK(step.delayed_inputs == std::vector<std::size_t>{1});  // W, the hoist

  const double mt = ParameterValue(model, "mt"), m = ParameterValue(model, "m"),
               g = ParameterValue(model, "g"), L0 = ParameterValue(model, "L0");
  Eigen::MatrixXd y(2, 5);
  y << 0.4, -0.3, 0.8, 1.5, -2.0,  //
      2.1, 0.6, -0.9, 0.7, 1.1;
  Eigen::VectorXd q = Eigen::VectorXd::Zero(3), q_dot = Eigen::VectorXd::Zero(3), u;
  std::string why;
  REQUIRE(inverse.Evaluate(y, model.parameters(), q, q_dot, u, why));
  const double theta = std::atan2(-y(0, 2), g - y(1, 2));
  const double length = y(1, 0) / std::cos(theta);
  const double n = y(1, 0) * y(0, 2), n1 = y(1, 1) * y(0, 2) + y(1, 0) * y(0, 3),
               n2 = y(1, 2) * y(0, 2) + 2 * y(1, 1) * y(0, 3) + y(1, 0) * y(0, 4);
  const double d = y(1, 2) - g, d1 = y(1, 3), d2 = y(1, 4);
  const double x_ddot =
      y(0, 2) - (n2 / d - 2 * n1 * d1 / (d * d) - n * d2 / (d * d) + 2 * n * d1 * d1 / (d * d * d));
  // Newton on nonlinear constraints, stopped at a relative residual of 1e-11.
  CHECK(q[2] == Approx(theta).epsilon(1e-10));
  CHECK(q[1] == Approx(length - L0).epsilon(1e-10));
  CHECK(q[0] == Approx(y(0, 0) - n / d).epsilon(1e-10));
  CHECK(u[0] == Approx(mt * x_ddot + m * y(0, 2)).epsilon(1e-9));
}

// PVTOL aircraft with eps = 0 (tests/data/pvtol.yaml): x'' = -u1 sin(theta),
// y'' = u1 cos(theta) - g, theta'' = u2. So with a = -x'', b = y'' + g: theta = atan2(a, b),
// u1 = |(a, b)|, and u2 = theta'' from theta = atan2(a, b) differentiated twice:
// theta' = (a' b - a b') / s with s = a^2 + b^2, and
// theta'' = ((a'' b - a b'') s - (a' b - a b') 2 (a a' + b b')) / s^2.
TEST_CASE("PVTOL with eps = 0: flat through the thrust's dynamic extension", "[solvers]") {
  const Model model = LoadModel(TestDataPath("pvtol.yaml"));
  const AlgebraicInverse inverse(model);
  CHECK(inverse.relative_degree() == std::vector<int>{2, 2});
  CHECK(inverse.output_derivative_orders() == std::vector<int>{4, 4});
  CHECK(inverse.integrators() == 2);
  REQUIRE(inverse.extension_steps().size() == 1);
  CHECK(inverse.extension_steps()[0].delayed_inputs == std::vector<std::size_t>{0});  // thrust
  const double g = ParameterValue(model, "g");
  Eigen::MatrixXd y(2, 5);
  y << 0.3, 0.5, -1.2, 0.8, 2.5,  //
      -0.2, 0.4, 0.9, -1.7, 0.6;
  Eigen::VectorXd q = Eigen::VectorXd::Zero(3), q_dot = Eigen::VectorXd::Zero(3), u;
  std::string why;
  REQUIRE(inverse.Evaluate(y, model.parameters(), q, q_dot, u, why));
  const double a = -y(0, 2), a1 = -y(0, 3), a2 = -y(0, 4);
  const double b = y(1, 2) + g, b1 = y(1, 3), b2 = y(1, 4);
  const double s = a * a + b * b;
  const double theta_dot = (a1 * b - a * b1) / s;
  const double theta_ddot =
      ((a2 * b - a * b2) * s - (a1 * b - a * b1) * 2 * (a * a1 + b * b1)) / (s * s);
  CHECK(q[2] == Approx(std::atan2(a, b)).epsilon(1e-10));
  CHECK(q_dot[2] == Approx(theta_dot).epsilon(1e-10));
  CHECK(u[0] == Approx(std::sqrt(s)).epsilon(1e-10));
  CHECK(u[1] == Approx(theta_ddot).epsilon(1e-9));
}

// A linear double-pendulum crane (the linearization of tests/data/double_pendulum_crane.yaml
// at rest) written with numeric coefficients, which GiNaC carries as floats: C M^-1 B comes out
// as a round-off residue (5.6e-18), not as an exact zero, and analyze's rank rule must still
// read relative degree 6. The independent reference is the linear flat inverse in Eigen: with
// A = M^-1 K and C A^k M^-1 B = 0 for k < 2, [C; C A; C A^2] q = [y; -y''; y''''], the same for
// q' with the odd derivatives, and y^(6) = C A^2 M^-1 (B u - K q).
TEST_CASE("numeric coefficients: a round-off residue does not lower the relative degree",
          "[solvers]") {
  const Model model = LoadModelFromString(R"(
name: linear_double_pendulum_crane
description: trolley, hook and load, linearized at rest, numeric coefficients
parameters:
  unused: 1.0
coordinates: [x, phi1, phi2]
inputs: [F]
mass_matrix:
  - [8.0, 3.0, 1.0]
  - [3.0, 3.0, 1.0]
  - [1.0, 1.0, 0.5]
forces:
  - 0
  - 29.43*phi1
  - 9.81*phi2
input_matrix:
  - [1]
  - [0]
  - [0]
outputs:
  - x + 1.0*phi1 + 0.5*phi2
)",
                                          "linear double-pendulum crane");
  const AlgebraicInverse inverse(model);
  CHECK(inverse.relative_degree() == std::vector<int>{6});
  Eigen::Matrix3d mass;
  mass << 8, 3, 1, 3, 3, 1, 1, 1, 0.5;
  const Eigen::Matrix3d stiffness = Eigen::Vector3d(0, 29.43, 9.81).asDiagonal();
  const Eigen::RowVector3d output(1, 1, 0.5);
  const Eigen::Vector3d input(1, 0, 0);
  const Eigen::Matrix3d a = mass.inverse() * stiffness;
  Eigen::Matrix3d observability;
  observability << output, output * a, output * a * a;
  Eigen::MatrixXd y(1, 7);
  y << 0.3, -0.7, 1.1, 0.4, -2.3, 5.0, -3.1;
  const Eigen::Vector3d q_expected = observability.lu().solve(Eigen::Vector3d(y(0), -y(2), y(4)));
  const Eigen::Vector3d q_dot_expected =
      observability.lu().solve(Eigen::Vector3d(y(1), -y(3), y(5)));
  const Eigen::RowVector3d top = output * a * a * mass.inverse();
  const double u_expected = (y(6) + top * stiffness * q_expected) / (top * input);
  const InverseAnswer answer = Invert(inverse, model, y);
  CHECK((answer.q - q_expected).norm() <= 1e-10 * q_expected.norm());
  CHECK((answer.q_dot - q_dot_expected).norm() <= 1e-10 * q_dot_expected.norm());
  CHECK(answer.u[0] == Approx(u_expected).epsilon(1e-10));
}

// The crane linearized at rest (kLinearCrane, file header): flat with orders (4, 2).
TEST_CASE("linearized gantry crane: orders (4, 2), closed forms and the equilibrium", "[solvers]") {
  const Model model = LoadModelFromString(kLinearCrane, "linearized crane");
  const AlgebraicInverse inverse(model);
  CHECK(inverse.output_derivative_orders() == std::vector<int>{4, 2});
  CHECK(inverse.highest_output_derivative() == 4);
  const double mt = ParameterValue(model, "mt"), mw = ParameterValue(model, "mw"),
               m = ParameterValue(model, "m"), g = ParameterValue(model, "g"),
               L0 = ParameterValue(model, "L0");

  SECTION("closed forms") {
    REQUIRE(inverse.input_formulas().size() == 2);
    const GiNaC::ex& trolley = inverse.input_formulas()[0];
    const GiNaC::ex& hoist = inverse.input_formulas()[1];
    // Exact rationals and the parameters' decimal values: round-off only.
    CHECK(Coefficient(model, trolley, inverse.output_derivative_symbol(0, 2)) ==
          Approx(mt + m).epsilon(kRoundOff));
    CHECK(Coefficient(model, trolley, inverse.output_derivative_symbol(0, 4)) ==
          Approx(mt * L0 / g).epsilon(kRoundOff));
    CHECK(Coefficient(model, trolley, inverse.output_derivative_symbol(1, 2)) ==
          Approx(0.0).margin(kRoundOff));
    CHECK(Coefficient(model, hoist, inverse.output_derivative_symbol(1, 2)) ==
          Approx(mw + m).epsilon(kRoundOff));
    CHECK(Coefficient(model, hoist, inverse.output_derivative_symbol(0, 4)) ==
          Approx(0.0).margin(kRoundOff));
  }

  SECTION("all derivatives zero give the equilibrium: q_dot = 0, F = 0, W = -m g") {
    Eigen::MatrixXd y = Eigen::MatrixXd::Zero(2, 5);
    y(0, 0) = 0.7;
    y(1, 0) = L0 + 0.3;
    const InverseAnswer answer = Invert(inverse, model, y);
    CHECK(answer.q[0] == Approx(0.7).epsilon(kRoundOff));
    CHECK(answer.q[1] == Approx(0.3).epsilon(kRoundOff));
    CHECK(answer.q[2] == Approx(0.0).margin(kRoundOff));
    CHECK(answer.q_dot.cwiseAbs().maxCoeff() == Approx(0.0).margin(kRoundOff));
    CHECK(answer.u[0] == Approx(0.0).margin(kRoundOff * m * g));
    CHECK(answer.u[1] == Approx(-m * g).epsilon(kRoundOff));
  }

  SECTION("a moving load: states and forces from the file header's closed forms") {
    Eigen::MatrixXd y(2, 5);
    y << 0.4, -0.3, 0.8, 1.5, -2.0,  //
        2.1, 0.6, -0.9, 7.0, 7.0;    // output 2 reads columns 0..2 only
    const InverseAnswer answer = Invert(inverse, model, y);
    // One Newton step on linear constraints: round-off only.
    CHECK(answer.q[0] == Approx(y(0, 0) + L0 * y(0, 2) / g).epsilon(kRoundOff));
    CHECK(answer.q[1] == Approx(y(1, 0) - L0).epsilon(kRoundOff));
    CHECK(answer.q[2] == Approx(-y(0, 2) / g).epsilon(kRoundOff));
    CHECK(answer.q_dot[0] == Approx(y(0, 1) + L0 * y(0, 3) / g).epsilon(kRoundOff));
    CHECK(answer.q_dot[1] == Approx(y(1, 1)).epsilon(kRoundOff));
    CHECK(answer.q_dot[2] == Approx(-y(0, 3) / g).epsilon(kRoundOff));
    CHECK(answer.u[0] == Approx((mt + m) * y(0, 2) + mt * L0 / g * y(0, 4)).epsilon(kRoundOff));
    CHECK(answer.u[1] == Approx((mw + m) * y(1, 2) - m * g).epsilon(kRoundOff));
  }
}

// Pendulum (kPendulum, file header): nonlinear constraints, solved by Newton.
TEST_CASE("pendulum with the bob's horizontal position: Newton on nonlinear constraints",
          "[solvers]") {
  const Model model = LoadModelFromString(kPendulum, "pendulum");
  const AlgebraicInverse inverse(model);
  CHECK(inverse.output_derivative_orders() == std::vector<int>{2});
  CHECK(inverse.input_formulas().empty());  // the constraints are not linear in theta
  const double m = ParameterValue(model, "m"), l = ParameterValue(model, "l"),
               g = ParameterValue(model, "g");

  SECTION("agrees with the closed form") {
    Eigen::MatrixXd y(1, 3);
    y << 0.3, -0.4, 1.7;
    const InverseAnswer answer = Invert(inverse, model, y);
    const double theta = std::asin(y(0, 0) / l);
    const double theta_dot = y(0, 1) / (l * std::cos(theta));
    const double theta_ddot =
        (y(0, 2) + l * std::sin(theta) * theta_dot * theta_dot) / (l * std::cos(theta));
    // Newton stops at a relative residual of 1e-11 (usually far below after the last,
    // quadratically convergent step); the angle near 0.64 rad is well conditioned.
    CHECK(answer.q[0] == Approx(theta).epsilon(1e-10));
    CHECK(answer.q_dot[0] == Approx(theta_dot).epsilon(1e-10));
    CHECK(answer.u[0] ==
          Approx(m * l * l * theta_ddot + m * g * l * std::sin(theta)).epsilon(1e-10));
  }

  SECTION("an unreachable position returns false with a reason and leaves the state") {
    Eigen::MatrixXd y(1, 3);
    y << 1.5 * l, 0, 0;  // |sin(theta)| would have to be 1.5
    Eigen::VectorXd q = Eigen::VectorXd::Constant(1, 0.1), q_dot = Eigen::VectorXd::Zero(1), u;
    std::string why;
    CHECK_FALSE(inverse.Evaluate(y, model.parameters(), q, q_dot, u, why));
    CHECK_THAT(why, Catch::Matchers::Contains("did not converge") ||
                        Catch::Matchers::Contains("singular"));
    CHECK(q[0] == 0.1);
    CHECK(q_dot[0] == 0.0);
  }

  SECTION("at theta = 90 deg the constraints and the u-coefficient are singular") {
    // y = l sin(theta) has dy/dtheta = l cos(theta) = 6e-17 l there: Newton cannot move from
    // it, and at y = l (where it is the answer) u's coefficient cos(theta) / (m l) vanishes.
    Eigen::VectorXd q = Eigen::VectorXd::Constant(1, std::acos(0.0)),
                    q_dot = Eigen::VectorXd::Zero(1);
    Eigen::VectorXd u;
    std::string why;
    Eigen::MatrixXd y(1, 3);
    y << 0.3 * l, 0, 0;
    CHECK_FALSE(inverse.Evaluate(y, model.parameters(), q, q_dot, u, why));
    CHECK_THAT(why, Catch::Matchers::Contains("Jacobian of the output constraints is singular"));
    y << l, 0, 0;
    CHECK_FALSE(inverse.Evaluate(y, model.parameters(), q, q_dot, u, why));
    CHECK_THAT(why, Catch::Matchers::Contains("coefficient matrix is singular"));
  }
}

TEST_CASE("an output the inputs never reach is refused", "[solvers]") {
  const Model model = LoadModelFromString(kUnreachableOutput, "unreachable");
  CHECK_THAT(RefusalOf(model), Catch::Matchers::Contains("output y1 never depends on the inputs"));
}

// u1 drives both outputs' second derivatives (rank 1); y2 - y1 = xc reaches u2 two
// derivatives later, and the damped mass d stays behind: after the dynamic extension the
// outputs fix 6 of 8 states, so the problem is not flat.
TEST_CASE("two inputs with a singular u-coefficient matrix: extended, internal dynamics remain",
          "[solvers]") {
  const Model model = LoadModel(TestDataPath("two_input_singular_decoupling.yaml"));
  CHECK_THAT(RefusalOf(model), Catch::Matchers::Contains("dynamic extension") &&
                                   Catch::Matchers::Contains("internal dynamics of order 2"));
  AlgebraicInverseOptions options;
  options.internal_dynamics = true;
  const AlgebraicInverse form(model, options);
  CHECK(form.internal_order() == 2);
  CHECK(form.output_derivative_orders() == std::vector<int>{4, 4});
}

// Evaluate() throws UsageError for wrong sizes (a caller's mistake, not a numerical failure)
// and for a parameter the derived structure depends on.
TEST_CASE("Evaluate rejects wrong sizes and changed structural parameters with UsageError",
          "[solvers]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}});
  const AlgebraicInverse inverse(model);
  Eigen::MatrixXd y = Eigen::MatrixXd::Zero(1, 5);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(2), q_dot = Eigen::VectorXd::Zero(2), u;
  Eigen::VectorXd parameters = model.parameters();
  std::string why;
  using Catch::Matchers::Contains;

  Eigen::MatrixXd too_few = Eigen::MatrixXd::Zero(1, 4);
  CHECK_THAT(
      MessageOf<UsageError>([&] { inverse.Evaluate(too_few, parameters, q, q_dot, u, why); }),
      Contains("output_derivatives is 1 x 4") && Contains("expected 1 x 5"));
  Eigen::VectorXd short_q = Eigen::VectorXd::Zero(1);
  CHECK_THROWS_AS(inverse.Evaluate(y, parameters, short_q, q_dot, u, why), UsageError);
  CHECK_THROWS_AS(inverse.Evaluate(y, parameters, q, short_q, u, why), UsageError);
  Eigen::VectorXd short_parameters = parameters.head(3);
  CHECK_THROWS_AS(inverse.Evaluate(y, short_parameters, q, q_dot, u, why), UsageError);

  // d = 0 made case 4 flat (case 3 is not): another d needs another derivation.
  parameters[static_cast<Eigen::Index>(*model.FindParameter("d"))] = 0.5;
  CHECK_THAT(MessageOf<UsageError>([&] { inverse.Evaluate(y, parameters, q, q_dot, u, why); }),
             Contains("parameter d = 0.5"));
  // The other parameters may change: the closed form holds for any m1, m2, k.
  parameters = model.parameters();
  parameters[static_cast<Eigen::Index>(*model.FindParameter("m1"))] = 3.0;
  y(0, 2) = 1.0;
  REQUIRE(inverse.Evaluate(y, parameters, q, q_dot, u, why));
  CHECK(u[0] == Approx(3.0 + 2.0).epsilon(kRoundOff));  // (m1 + m2) y'' with m1 = 3, m2 = 2
}

TEST_CASE("output derivative symbols are named y<i>_d with primes and checked", "[solvers]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}});
  const AlgebraicInverse inverse(model);
  CHECK(inverse.output_derivative_symbol(0, 0).get_name() == "y1_d");
  CHECK(inverse.output_derivative_symbol(0, 4).get_name() == "y1_d''''");
  CHECK_THROWS_AS(inverse.output_derivative_symbol(0, 5), std::out_of_range);
  CHECK_THROWS_AS(inverse.output_derivative_symbol(1, 0), std::out_of_range);
  CHECK_THROWS_AS(inverse.output_derivative_symbol(0, -1), std::out_of_range);
}

// DeriveAlgebraicInverse derives once per model file, parameter values and options: the same
// object for a second solve, another for another parameter value or other options.
TEST_CASE("derivations are kept per model, parameters and options", "[solvers]") {
  const Model case4 = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}});
  const Model heavier =
      LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}, {"m1", "3"}});
  const auto first = DeriveAlgebraicInverse(case4);
  CHECK(DeriveAlgebraicInverse(case4) == first);
  CHECK(DeriveAlgebraicInverse(
            LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}})) == first);
  CHECK(DeriveAlgebraicInverse(heavier) != first);
  AlgebraicInverseOptions options;
  options.internal_dynamics = true;
  CHECK(DeriveAlgebraicInverse(case4, options) != first);
  CHECK(DeriveAlgebraicInverse(case4) == first);
}

}  // namespace
}  // namespace servokit
