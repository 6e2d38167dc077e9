// The `--vary` grammar (application/grid_arguments.h): range a:b:n, list v1,v2,..., degrees, and
// the exact messages of the usage errors, which name the option. The same reader serves both model
// kinds: only the parameter names come from the model.
#include "application/grid_arguments.h"

#include <catch2/catch.hpp>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "models/errors.h"
#include "models/linear_model.h"
#include "models/model.h"
#include "models/units.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;

const std::vector<std::string>& MassOnCar() {
  static const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  return model.parameter_names();
}

std::vector<double> AxisValues(const GridAxis& axis) {
  std::vector<double> values;
  for (std::size_t i = 0; i < axis.size(); ++i) values.push_back(axis.Value(i));
  return values;
}

std::string UsageErrorOf(const std::vector<std::string>& texts) {
  try {
    ParseParameterGrid(MassOnCar(), texts);
  } catch (const UsageError& error) {
    return error.what();
  }
  return "no error";
}

TEST_CASE("a range a:b:n is n evenly spaced values from a to b, both included", "[reports]") {
  const GridAxis axis = ParseGridAxis(MassOnCar(), "d=0:2:5");
  CHECK(axis.name == "d");
  CHECK(axis.parameter == 3);  // m1, m2, k, d, alpha
  CHECK(AxisValues(axis) == std::vector<double>{0.0, 0.5, 1.0, 1.5, 2.0});
}

TEST_CASE("n = 1 is the single value a", "[reports]") {
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "d=3:7:1")) == std::vector<double>{3.0});
}

TEST_CASE("deg is accepted on each value of a range or list, with or without a blank",
          "[reports]") {
  const double ninety = *ParseQuantity("90 deg");
  CHECK(ninety == std::numbers::pi / 2);
  for (const char* text : {"alpha=0deg:90deg:3", "alpha=0 deg:90 deg:3", "alpha=0:90deg:3"}) {
    INFO(text);
    CHECK(AxisValues(ParseGridAxis(MassOnCar(), text)) ==
          std::vector<double>{0.0, ninety / 2, ninety});
  }
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "alpha=90deg, 0.5,45 deg")) ==
        std::vector<double>{ninety, 0.5, *ParseQuantity("45 deg")});
}

TEST_CASE("a list is taken as given, in its order; one value is a list of one", "[reports]") {
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "m1=3,1,2")) == std::vector<double>{3, 1, 2});
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "m1=4")) == std::vector<double>{4});
}

TEST_CASE("the first --vary varies slowest", "[reports]") {
  const ParameterGrid grid = ParseParameterGrid(MassOnCar(), {"alpha=1,2", "d=10:30:3"});
  REQUIRE(grid.num_points() == 6);
  std::vector<double> values(2);
  grid.PointValues(4, values);
  CHECK(values == std::vector<double>{2, 20});
}

TEST_CASE("--vary errors name the argument and the problem", "[reports]") {
  CHECK(UsageErrorOf({"beta=0:1:3"}) ==
        "--vary beta=0:1:3: unknown parameter 'beta' (the model has m1, m2, k, d, alpha)");
  CHECK(UsageErrorOf({"alpha"}) ==
        "--vary alpha: expected name=a:b:n or name=v1,v2,... (e.g. --vary alpha=0deg:90deg:91)");
  CHECK(UsageErrorOf({"=1,2"}) ==
        "--vary =1,2: expected name=a:b:n or name=v1,v2,... (e.g. --vary alpha=0deg:90deg:91)");
  CHECK(UsageErrorOf({"alpha=0:1"}) ==
        "--vary alpha=0:1: a range is a:b:n, e.g. alpha=0deg:90deg:91 (n values from a to b)");
  CHECK(UsageErrorOf({"alpha=0:1:2:3"}) ==
        "--vary alpha=0:1:2:3: a range is a:b:n, e.g. alpha=0deg:90deg:91 (n values from a to b)");
  CHECK(UsageErrorOf({"alpha=0:x:3"}) ==
        "--vary alpha=0:x:3: 'x' is not a number (use e.g. 0.5 or \"5 deg\")");
  CHECK(UsageErrorOf({"alpha=1,,2"}) ==
        "--vary alpha=1,,2: '' is not a number (use e.g. 0.5 or \"5 deg\")");
  CHECK(UsageErrorOf({"alpha=0:1:0"}) ==
        "--vary alpha=0:1:0: the number of values must be at least 1, got 0");
  CHECK(UsageErrorOf({"alpha=0:1:-2"}) ==
        "--vary alpha=0:1:-2: the number of values must be at least 1, got -2");
  CHECK(UsageErrorOf({"alpha=0:1:2.5"}) ==
        "--vary alpha=0:1:2.5: '2.5' is not a whole number of values");
  CHECK(UsageErrorOf({"alpha=0:1:3", "d=1", "alpha=5"}) ==
        "--vary alpha: the parameter is varied twice (give all its values in one --vary)");
}

TEST_CASE("a grid with more points than std::size_t counts is refused", "[reports]") {
  CHECK(UsageErrorOf({"m1=0:1:4294967296", "m2=0:1:4294967296", "k=0:1:2"}) ==
        "--vary: the grid has more than " +
            std::to_string(std::numeric_limits<std::size_t>::max()) + " points");
}

TEST_CASE("a linear model's parameters are read by the same grammar", "[reports]") {
  const LinearModel model = LoadLinearModel(testing::TestDataPath("linear/tiny.yaml"));
  // tiny.yaml: parameters m, k, d, alpha.
  const ParameterGrid grid = ParseParameterGrid(model.parameter_names(), {"d=0:1:3"});
  REQUIRE(grid.num_points() == 3);
  CHECK(grid.axes().front().parameter == 2);
  CHECK_THROWS_WITH(ParseParameterGrid(model.parameter_names(), {"q=1:2:3"}),
                    "--vary q=1:2:3: unknown parameter 'q' (the model has m, k, d, alpha)");
}

}  // namespace
}  // namespace servokit
