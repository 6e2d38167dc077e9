// ParameterGrid: the `--vary` forms (range a:b:n, list v1,v2,...), degrees, the row-major
// numbering of points (first axis slowest) and the exact messages of the usage errors.
#include "analysis/parameter_grid.h"

#include <catch2/catch.hpp>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "models/errors.h"
#include "models/units.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;

const Model& MassOnCar() {
  static const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  return model;
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

TEST_CASE("a range a:b:n is n evenly spaced values from a to b, both included", "[analysis]") {
  const GridAxis axis = ParseGridAxis(MassOnCar(), "d=0:2:5");
  CHECK(axis.name == "d");
  CHECK(axis.parameter == *MassOnCar().FindParameter("d"));
  CHECK(AxisValues(axis) == std::vector<double>{0.0, 0.5, 1.0, 1.5, 2.0});
}

TEST_CASE("a range ends exactly at b whatever the rounding of its step", "[analysis]") {
  const GridAxis axis = ParseGridAxis(MassOnCar(), "k=0.1:0.7:7");
  CHECK(axis.Value(6) == 0.7);
  CHECK(axis.Value(3) == 0.1 + 3 * ((0.7 - 0.1) / 6));  // numpy.linspace's formula
}

TEST_CASE("n = 1 is the single value a", "[analysis]") {
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "d=3:7:1")) == std::vector<double>{3.0});
}

TEST_CASE("deg is accepted on each value of a range or list, with or without a blank",
          "[analysis]") {
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

TEST_CASE("a list is taken as given, in its order; one value is a list of one", "[analysis]") {
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "m1=3,1,2")) == std::vector<double>{3, 1, 2});
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "m1=4")) == std::vector<double>{4});
}

TEST_CASE("points are numbered row-major: the first --vary varies slowest", "[analysis]") {
  const ParameterGrid grid = ParseParameterGrid(MassOnCar(), {"alpha=1,2", "d=10:30:3"});
  REQUIRE(grid.num_points() == 6);
  const std::vector<std::vector<double>> expected = {{1, 10}, {1, 20}, {1, 30},
                                                     {2, 10}, {2, 20}, {2, 30}};
  std::vector<double> values(2);
  for (std::size_t point = 0; point < grid.num_points(); ++point) {
    grid.PointValues(point, values);
    CHECK(values == expected[point]);
  }
}

TEST_CASE("three axes are a mixed-radix number, the last axis its lowest digit", "[analysis]") {
  const ParameterGrid grid = ParseParameterGrid(MassOnCar(), {"m1=0:1:2", "m2=0:2:3", "k=0:3:4"});
  REQUIRE(grid.num_points() == 24);
  std::vector<double> values(3);
  grid.PointValues(1 * 12 + 2 * 4 + 3, values);
  CHECK(values == std::vector<double>{1, 2, 3});
}

TEST_CASE("Apply sets only the varied parameters", "[analysis]") {
  const Model& model = MassOnCar();
  const ParameterGrid grid = ParseParameterGrid(model, {"d=0,7", "alpha=0:1:2"});
  Eigen::VectorXd parameters = model.parameters();
  grid.Apply(3, parameters);  // d = 7, alpha = 1
  Eigen::VectorXd expected = model.parameters();
  expected[static_cast<Eigen::Index>(*model.FindParameter("d"))] = 7;
  expected[static_cast<Eigen::Index>(*model.FindParameter("alpha"))] = 1;
  CHECK(parameters == expected);
}

TEST_CASE("a grid without axes is the one point of the model's own parameters", "[analysis]") {
  const ParameterGrid grid({});
  CHECK(grid.num_points() == 1);
}

TEST_CASE("--vary errors name the argument and the problem", "[analysis]") {
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

TEST_CASE("a grid with more points than std::size_t counts is refused", "[analysis]") {
  CHECK(UsageErrorOf({"m1=0:1:4294967296", "m2=0:1:4294967296", "k=0:1:2"}) ==
        "--vary: the grid has more than " +
            std::to_string(std::numeric_limits<std::size_t>::max()) + " points");
}

}  // namespace
}  // namespace servokit
