// The operating point and the options of the classification.
#include <catch2/catch.hpp>

#include "analysis/classification.h"
#include "base/errors.h"
#include "base/option_check.h"
#include "tests/analysis/classify_helpers.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

TEST_CASE("default classification options are valid", "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  CHECK_NOTHROW(ClassificationOptions{}.Validate(model));
}

TEST_CASE("a bad tolerance is rejected with the field, its value and the rule", "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  ClassificationOptions options;
  options.rank_tolerance = -1;
  CHECK_THROWS_WITH(options.Validate(model),
                    Catch::Contains("rank_tolerance = -1") && Catch::Contains("must be > 0"));
}

TEST_CASE("y0 of the wrong size is an option error naming the values and the size", "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  Workspace workspace(model);
  OperatingPointOptions options;
  options.y0 = Eigen::Vector2d(1, 2);
  CHECK_THROWS_AS(FindOperatingPoint(model, workspace, options), OptionError);
  // mass on car: one output, the car's position x.
  CHECK_THROWS_WITH(FindOperatingPoint(model, workspace, options),
                    "OperatingPointOptions::y0 = [1, 2]: must have 1 value, one per output");
}

TEST_CASE("mass on car at y0 = 1.5: the car moves, the spring stays relaxed", "[analysis]") {
  // f(q, 0) = [0, k s] = B F forces s = 0 and F = 0; then x = y0.
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  Workspace workspace(model);
  OperatingPointOptions options;
  options.y0 = Eigen::VectorXd::Constant(1, 1.5);
  const OperatingPoint point = FindOperatingPoint(model, workspace, options);
  CHECK(point.q(0) == Approx(1.5).epsilon(1e-12));
  CHECK(point.q(1) == Approx(0.0).margin(1e-12));
  CHECK(point.u(0) == Approx(0.0).margin(1e-12));
  CHECK(point.y(0) == Approx(1.5).epsilon(1e-12));
}

TEST_CASE("a model without an equilibrium is reported as no solution", "[analysis]") {
  // f2 = a + z^2 > 0 for every z, and no input acts on z.
  const Model model = LoadModel(TestDataPath("no_equilibrium.yaml"));
  Workspace workspace(model);
  CHECK_THROWS_AS(FindOperatingPoint(model, workspace), NoSolution);
  CHECK_THROWS_WITH(FindOperatingPoint(model, workspace), Catch::Contains("no equilibrium found"));
}

}  // namespace
}  // namespace servokit

namespace servokit {
namespace {

// Issue #33: outputs whose rest point lies on a curve of equilibria. The TORA observed at its
// cart (tests/data/tora.yaml, a = 0: y = x) leaves the rotor angle free at rest, and so does the
// inertia-wheel pendulum observed at its pendulum (c = 0: y = q1) for the wheel angle. Without a
// named point that is an error that says so and how to name one; at a point named by q_guess
// the problem is classified there. Held at y = 0 the free angle obeys, linearized, theta'' = 0
// (TORA: m e (theta'' cos(theta) - theta'^2 sin(theta)) = -(M + m) x'' - k x = 0; wheel:
// d12 q2'' = mbar sin(q1) - d11 q1'' = 0): a double zero at 0, the motion along the curve.
TEST_CASE("a curve of equilibria is classified at the point named on it", "[analysis]") {
  struct Case {
    std::string file, parameter;
  };
  for (const Case& tested : {Case{"tora.yaml", "a"}, Case{"inertia_wheel_pendulum.yaml", "c"}}) {
    INFO(tested.file);
    const Model model = LoadModel(TestDataPath(tested.file), {{tested.parameter, "0"}});
    Workspace workspace(model);
    CHECK_THROWS_WITH(
        Classify(model, workspace),
        Catch::Contains("is not isolated") &&
            Catch::Contains("a curve of equilibria passes through it along dq = [0, ") &&
            Catch::Contains("name a point on it with --q0"));
    ClassificationOptions options;
    options.operating_point.q_guess = Eigen::Vector2d(0.0, 0.5);
    const Classification c = Classify(model, workspace, options);
    CHECK(c.operating_point.q(1) == 0.5);
    REQUIRE(c.operating_point.curve_direction.has_value());
    CHECK(std::abs(c.operating_point.curve_direction->x()) < 1e-14);
    CHECK(std::abs(c.operating_point.curve_direction->y()) == Approx(1.0).epsilon(1e-14));
    REQUIRE(c.zero_dynamics.eigenvalues.size() == 2);
    for (const std::complex<double>& zero : c.zero_dynamics.eigenvalues) {
      CHECK(std::abs(zero) < 1e-12);
    }
    CHECK(c.zero_dynamics.stability == Stability::kCritical);
    CHECK_THAT(c.zero_dynamics.stability_note, Catch::Contains("curve of equilibria"));
  }
}

}  // namespace
}  // namespace servokit

namespace servokit {
namespace {

// Issue #33: where no equilibrium exists the message says it may not, beside the advice on
// the start. The TORA at rest has k x = 0, so y = x + a sin(theta) reaches at most a = 0.002:
// y0 = 0.01 has no equilibrium, and Newton's residual stays away from 0.
TEST_CASE("an output out of reach at rest: the message says there may be no equilibrium",
          "[analysis]") {
  const Model model = LoadModel(TestDataPath("tora.yaml"));
  Workspace workspace(model);
  ClassificationOptions options;
  options.operating_point.y0 = Eigen::VectorXd::Constant(1, 0.01);
  CHECK_THROWS_WITH(
      Classify(model, workspace, options),
      Catch::Contains("there may be no equilibrium holding y0") && Catch::Contains("--q0"));
}

}  // namespace
}  // namespace servokit
