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
