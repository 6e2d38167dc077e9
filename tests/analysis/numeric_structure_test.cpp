// The structure algorithm's numeric route (analysis/numeric_structure.h) and the Taylor series
// of a motion it reads (modeling/motion_series.h): the series against a pendulum's closed-form
// derivatives, and the numeric route against the symbolic one, a second derivation, on every
// model file the tests and the shipped models have.
#include "analysis/numeric_structure.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "analysis/nonlinear_structure.h"
#include "base/errors.h"
#include "modeling/motion_series.h"
#include "modeling/symbolic_lock.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

// m l^2 theta'' + m g l sin(theta) + d theta' = u, y = l sin(theta): the derivatives of y by
// hand, with alpha = theta'' and its derivative theta''' from differentiating the equation.
TEST_CASE("motion series: a damped pendulum's output derivatives in closed form",
          "[modeling][motion_series]") {
  const Model model = LoadModelFromString(R"(
name: pendulum
parameters: {m: 1.3, l: 0.7, g: 9.81, d: 0.4}
coordinates: [theta]
inputs: [u]
mass_matrix: [[m*l^2]]
forces: [m*g*l*sin(theta) + d*theta_dot]
input_matrix: [[1]]
outputs: [l*sin(theta)]
)",
                                          "pendulum");
  const double m = 1.3, l = 0.7, g = 9.81, d = 0.4;
  const double theta = 0.4, omega = -0.9, u = 2.5;
  const double alpha = (u - m * g * l * std::sin(theta) - d * omega) / (m * l * l);
  const double jerk = (-m * g * l * std::cos(theta) * omega - d * alpha) / (m * l * l);
  const std::vector<double> expected = {
      l * std::sin(theta),
      l * std::cos(theta) * omega,
      -l * std::sin(theta) * omega * omega + l * std::cos(theta) * alpha,
      -l * std::cos(theta) * omega * omega * omega - 3 * l * std::sin(theta) * omega * alpha +
          l * std::cos(theta) * jerk,
  };
  const auto one = [](double value) { return Eigen::VectorXd::Constant(1, value); };
  const MotionStart start{one(theta), one(omega), one(u)};
  MotionSeries::Scratch scratch;
  MotionSeries motion(model, model.parameters(), start, {one(0), one(0), one(0)}, scratch);
  CHECK(motion.Acceleration().value[0] == Approx(alpha).epsilon(1e-14));
  for (int k = 0; k < 4; ++k) {
    INFO("order " << k);
    CHECK(motion.OutputDerivative(k).value[0] == Approx(expected[std::size_t(k)]).epsilon(1e-13));
  }
  // The tangents along u: d alpha / du = 1 / (m l^2), and y's derivatives' by the same hand
  // (omega and theta do not depend on u at t = 0; d jerk / du = -d / (m l^2)^2).
  const double dalpha = 1.0 / (m * l * l), djerk = -d * dalpha / (m * l * l);
  const std::vector<double> along_u = {
      0.0, 0.0, l * std::cos(theta) * dalpha,
      -3 * l * std::sin(theta) * omega * dalpha + l * std::cos(theta) * djerk};
  MotionSeries along(model, model.parameters(), start, {one(0), one(0), one(1)}, scratch);
  CHECK(along.Acceleration().tangent[0] == Approx(dalpha).epsilon(1e-14));
  for (int k = 0; k < 4; ++k) {
    INFO("order " << k);
    CHECK(along.OutputDerivative(k).value[0] == Approx(expected[std::size_t(k)]).epsilon(1e-13));
    CHECK(along.OutputDerivative(k).tangent[0] ==
          Approx(along_u[std::size_t(k)]).epsilon(1e-13).margin(1e-15));
  }
  // Along theta: d/dtheta of y' = -l sin(theta) omega.
  MotionSeries along_theta(model, model.parameters(), start, {one(1), one(0), one(0)}, scratch);
  CHECK(along_theta.OutputDerivative(1).tangent[0] ==
        Approx(-l * std::sin(theta) * omega).epsilon(1e-14));
}

// A tracking motion: m x'' = u, z'' = -k (z - x), w'' = v, with y1 = x + c sin(x) made to follow
// y1_d'' = Y2 + Y3 t + Y4 t^2 / 2 + ... through u, and v = 0. By hand: y1 then follows every
// desired derivative from order 2 on; x'' = (Y2 + c sin(x) x'^2) / (1 + c cos(x)) at t = 0, and
// y2 = z + w has y2 = z = -k (z'' - x'') = k^2 (z - x) + k x''.
TEST_CASE("motion series: a tracking motion follows the kept output in closed form",
          "[modeling][motion_series]") {
  const Model model = LoadModelFromString(R"(
name: tracking
parameters: {m: 1.7, k: 3.0, c: 0.4}
coordinates: [x, z, w]
inputs: [u, v]
mass_matrix: [[m, 0, 0], [0, 1, 0], [0, 0, 1]]
forces: [0, k*(z - x), 0]
input_matrix: [[1, 0], [0, 0], [0, 1]]
outputs: [x + c*sin(x), z + w]
)",
                                          "tracking");
  const double k = 3.0, c = 0.4;
  const double x = 0.3, z = -0.2, x_dot = 0.8;
  const std::vector<double> desired = {0.0, 0.0, 0.7, -0.5, 1.1, 0.6, -0.9};
  Eigen::VectorXd q(3), q_dot(3);
  q << x, z, 0.1;
  q_dot << x_dot, 0.4, -0.3;
  const Eigen::VectorXd zero3 = Eigen::VectorXd::Zero(3), zero2 = Eigen::VectorXd::Zero(2);
  auto tracking = std::make_shared<MotionSeries::Tracking>();
  tracking->outputs = {0};
  tracking->inputs = {0};
  tracking->desired = {desired};
  MotionSeries::Scratch scratch;
  const MotionSeries start(model, model.parameters(), {q, q_dot, zero2}, {zero3, zero3, zero2},
                           scratch);
  Eigen::VectorXd along_x = zero3;
  along_x[0] = 1.0;
  MotionSeries motion(start, {along_x, zero3, zero2}, tracking);
  for (int order = 2; order < 7; ++order) {
    INFO("order " << order);
    CHECK(motion.OutputDerivative(order).value[0] ==
          Approx(desired[std::size_t(order)]).epsilon(1e-12));
    CHECK(motion.OutputDerivative(order).tangent[0] == Approx(0.0).margin(1e-11));
  }
  const auto acceleration = [&](double position) {
    return (desired[2] + c * std::sin(position) * x_dot * x_dot) / (1.0 + c * std::cos(position));
  };
  const double x_ddot = acceleration(x);
  CHECK(motion.Acceleration().value[0] == Approx(x_ddot).epsilon(1e-14));
  CHECK(motion.OutputDerivative(4).value[1] == Approx(k * k * (z - x) + k * x_ddot).epsilon(1e-13));
  // Along x(0): -k^2 + k dx''/dx, the latter by hand from the quotient above.
  const double numerator = desired[2] + c * std::sin(x) * x_dot * x_dot;
  const double denominator = 1.0 + c * std::cos(x);
  const double dx_ddot =
      (c * std::cos(x) * x_dot * x_dot * denominator + numerator * c * std::sin(x)) /
      (denominator * denominator);
  CHECK(motion.OutputDerivative(4).tangent[1] == Approx(-k * k + k * dx_ddot).epsilon(1e-13));
}

TEST_CASE("motion series: a singular mass matrix gives NaN, not a number", "[modeling]") {
  const Model model = LoadModelFromString(R"(
name: degenerate
parameters: {m: 1.0}
coordinates: [x]
inputs: [u]
mass_matrix: [[m*x^2]]
forces: [0]
input_matrix: [[1]]
outputs: [x]
)",
                                          "degenerate");
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(1), one = Eigen::VectorXd::Ones(1);
  MotionSeries::Scratch scratch;
  MotionSeries motion(model, model.parameters(), {zero, zero, one}, {zero, zero, one}, scratch);
  CHECK(std::isnan(motion.OutputDerivative(2).value[0]));
  CHECK(std::isnan(motion.OutputDerivative(2).tangent[0]));
}

// The symbolic route's verdict on a model, or its error.
struct SymbolicVerdict {
  std::optional<NonlinearStructure> structure;
  std::string error;
};

// Dynamic extensions the numeric route derived and CompareRoutes checked.
int extensions_compared = 0;

void CompareRoutes(const Model& model, const std::string& label) {
  INFO(label);
  const SymbolicLock lock;  // the symbolic structure's expressions
  SymbolicVerdict symbolic;
  try {
    symbolic.structure = DeriveNonlinearStructure(model);
  } catch (const NoSolution& error) {
    symbolic.error = error.what();
  }
  std::optional<NumericStructure> numeric;
  std::string numeric_error;
  try {
    numeric = DeriveNumericStructure(model, {});
  } catch (const NoSolution& error) {
    numeric_error = error.what();
  }
  const std::size_t m = model.num_outputs();
  if (!numeric) {
    // The numeric route fails only where the symbolic one fails the same way.
    CHECK(numeric_error == symbolic.error);
    return;
  }
  REQUIRE(symbolic.structure);
  CHECK(numeric->relative_degree == symbolic.structure->relative_degree);
  if (numeric->rank_nearby < m) {
    // A dynamic extension: the numeric route takes one step where its kept rows have relative
    // degree 2, and must then agree with the symbolic route in every number it reports.
    const NonlinearStructure& expected = *symbolic.structure;
    REQUIRE(expected.extended());
    const StructureStep& first = expected.extension_steps.front();
    CHECK(first.rank == numeric->rank_nearby);
    if (!numeric->extension) {
      bool kept_above_two = false;
      for (std::size_t row : first.kept_rows)
        kept_above_two = kept_above_two || expected.relative_degree[row] != 2;
      CHECK((expected.extension_steps.size() > 1 || kept_above_two));
      return;
    }
    ++extensions_compared;
    const NumericExtension& extension = *numeric->extension;
    CHECK(expected.extension_steps.size() == 1);
    CHECK(extension.step.kept_rows == first.kept_rows);
    CHECK(extension.step.combined_rows == first.combined_rows);
    CHECK(extension.step.delayed_inputs == first.delayed_inputs);
    CHECK(extension.highest_derivative == expected.highest_derivative);
    CHECK(extension.constraints == expected.constraints.size());
    CHECK(extension.reference_rank == expected.reference_rank);
    return;
  }
  CHECK_FALSE(symbolic.structure->extended());
  CHECK(numeric->reference_rank == symbolic.structure->reference_rank);
}

std::vector<std::string> ModelFiles() {
  std::vector<std::string> files;
  for (const std::string& directory :
       {ModelPath(""), TestDataPath(""), TestDataPath("energy_forms")}) {
    for (const auto& entry : std::filesystem::directory_iterator(directory)) {
      if (entry.path().extension() == ".yaml") files.push_back(entry.path().string());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST_CASE("numeric and symbolic routes agree on every model file", "[analysis][routes]") {
  int compared = 0;
  for (const std::string& file : ModelFiles()) {
    std::optional<Model> model;
    try {
      model = LoadModel(file);
    } catch (const Error&) {
      continue;  // the error-case files, and linear models (another analysis)
    }
    CompareRoutes(*model, file);
    ++compared;
  }
  CHECK(compared >= 25);
  // The gantry crane in its three forms, the PVTOL, the elastic-joint arm, and a two-input
  // model whose decoupling matrix is singular.
  CHECK(extensions_compared >= 6);
}

// The paper's four cases of the mass on car (Sect. 3): relative degrees 2, 2, 3 and 4 by the
// zero parameters the symbolic route substitutes exactly and the numeric one evaluates.
TEST_CASE("numeric and symbolic routes agree on the mass on car's four cases",
          "[analysis][paper]") {
  for (const auto& [alpha, d] : std::vector<std::pair<std::string, std::string>>{
           {"5 deg", "1"}, {"5 deg", "0"}, {"0", "1"}, {"0", "0"}, {"90 deg", "1"}}) {
    const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", alpha}, {"d", d}});
    CompareRoutes(model, "alpha = " + alpha + ", d = " + d);
  }
}

// tests/data/product_of_eight_sums.yaml: relative degree 3 by hand (its description). The
// symbolic route keeps M^-1 (B u - f) as derived where normalising it would expand 5^8 terms,
// and both routes find the hand-derived degree.
TEST_CASE("a force that is a product of eight sums: relative degree 3 on both routes",
          "[analysis][routes]") {
  const Model model = LoadModel(TestDataPath("product_of_eight_sums.yaml"));
  const SymbolicLock lock;
  CHECK(DeriveNonlinearStructure(model).relative_degree == std::vector<int>{3});
  CHECK(DeriveNumericStructure(model, {}).relative_degree == std::vector<int>{3});
}

// The summary says which route decided. The gantry crane's one-step extension with kept rows
// of relative degree 2 is numeric: the load's accelerations both follow the rope tension, the
// hoist W is delayed twice, (4, 4), flat. The spring chain's kept row has relative degree 4, so
// the symbolic route takes it; its numbers by hand in tests/data/spring_chain_extension.yaml:
// (4, 4) extended to (6, 6), 2 integrators, flat.
// What a summary of an extended model must say, derived by hand.
struct ExpectedExtension {
  std::string route;
  std::vector<int> relative_degree, extended_relative_degree;
  std::vector<std::string> delayed_inputs;
  int integrators = 0;
};

void CheckSummary(const Model& model, const ExpectedExtension& expected) {
  const NonlinearStructureSummary summary = SummarizeNonlinearStructure(model, {});
  INFO(model.name());
  CHECK(summary.route == expected.route);
  CHECK(summary.derived);
  CHECK(summary.relative_degree == expected.relative_degree);
  CHECK(summary.extended_relative_degree == expected.extended_relative_degree);
  CHECK(summary.delayed_inputs == expected.delayed_inputs);
  CHECK(summary.integrators == expected.integrators);
  CHECK(summary.internal_order == 0);  // both flat
  CHECK(summary.defined_at_operating_point);
}

TEST_CASE("the summary names its route, with the extensions' numbers by hand",
          "[analysis][routes]") {
  CheckSummary(LoadModel(ModelPath("gantry_crane.yaml")),
               {kNumericRoute, {2, 2}, {4, 4}, {"W"}, 2});
  // Full pivoting on k [[1, 1], [1, 1]] keeps the first row and column: u1 is delayed.
  CheckSummary(LoadModel(TestDataPath("spring_chain_extension.yaml")),
               {kSymbolicRoute, {4, 4}, {6, 6}, {"u1"}, 2});
}

// The numeric route stops at its work budget with NoSolution naming the output and the order,
// rather than going on to ever dearer derivatives: here the mass on car with alpha = 0, d = 0,
// whose relative degree is 4 (paper Sect. 3, case 4), under a budget too small for order 2's
// gradient, and then under the default budget, where it is found.
TEST_CASE("the numeric route stops at its work budget", "[analysis][routes]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}});
  NonlinearStructureOptions options;
  CHECK(DeriveNumericStructure(model, options).relative_degree == std::vector<int>{4});
  options.max_work = 1.0;
  try {
    DeriveNumericStructure(model, options);
    FAIL("no NoSolution past the work budget");
  } catch (const NoSolution& error) {
    const std::string message = error.what();
    INFO(message);
    CHECK(message.find("output y1: deciding whether the inputs appear in its derivative of "
                       "order ") == 0);
    CHECK(message.find("past its work budget (1 Taylor operations)") != std::string::npos);
  }
}

// The rows a dynamic extension keeps are the pivots' rows of the coefficient matrix at the
// reference state, not where the pivoting moved those rows to. The gantry crane in absolute
// coordinates at rest (inputs F, W, lambda; rows xL'', zL'', c''): the load's horizontal row
// vanishes there (its rope is vertical), so the kept rows must be zL'' and c'', with the columns
// of W and lambda. Taking Eigen's P instead of its inverse kept xL'' and c'', whose block is
// singular, and the combined row then divided by (xL - x)^2 = 0 at rest.
TEST_CASE("a dynamic extension keeps the rows that are regular at the reference", "[analysis]") {
  Eigen::MatrixXd reference(3, 3);
  reference << 0.0, 0.0, 0.0,  //
      0.0, 0.0, 0.8,           //
      0.0, -2.0, 11.2;
  const StructureStep step = KeptRowsAndColumns(reference, 2, 2);
  CHECK(step.kept_rows == std::vector<std::size_t>{1, 2});
  CHECK(step.delayed_inputs == std::vector<std::size_t>{1, 2});
  // Rows and columns each in another order: the pivots follow the entries, not the positions.
  Eigen::MatrixXd shuffled(3, 3);
  shuffled << 11.2, -2.0, 0.0,  //
      0.0, 0.0, 0.0,            //
      0.8, 0.0, 0.0;
  const StructureStep moved = KeptRowsAndColumns(shuffled, 2, 2);
  CHECK(moved.kept_rows == std::vector<std::size_t>{0, 2});
  CHECK(moved.delayed_inputs == std::vector<std::size_t>{0, 1});
}

}  // namespace
}  // namespace servokit
