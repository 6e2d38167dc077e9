// ParameterGrid: axes by parameter name (ParameterIndex), ranges and lists, the row-major
// numbering of points (first axis slowest) and the exact messages of the usage errors. The
// `--vary` text is tested with its reader, tests/studies/grid_text_test.cpp.
#include "analysis/parameter_grid.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "base/errors.h"
#include "modeling/model.h"
#include "tests/analysis/grid_helpers.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ListAxis;
using testing::ModelPath;
using testing::RangeAxis;

const Model& MassOnCar() {
  static const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  return model;
}

const std::vector<std::string>& Names() { return MassOnCar().parameter_names(); }

std::vector<double> AxisValues(const GridAxis& axis) {
  std::vector<double> values;
  for (std::size_t i = 0; i < axis.size(); ++i) values.push_back(axis.Value(i));
  return values;
}

std::string UsageErrorOf(std::vector<GridAxis> axes) {
  try {
    ParameterGrid grid(std::move(axes));
  } catch (const UsageError& error) {
    return error.what();
  }
  return "no error";
}

TEST_CASE("a parameter is found by name; an unknown one is named with the known ones",
          "[analysis]") {
  CHECK(ParameterIndex(Names(), "d") == *MassOnCar().FindParameter("d"));
  CHECK_THROWS_MATCHES(ParameterIndex(Names(), "beta"), UsageError,
                       Catch::Message("unknown parameter 'beta' (the model has m1, m2, k, d, "
                                      "alpha)"));
}

TEST_CASE("a range is n evenly spaced values from first to last, both included", "[analysis]") {
  const GridAxis axis = RangeAxis(Names(), "d", 0, 2, 5);
  CHECK(axis.name == "d");
  CHECK(axis.parameter == *MassOnCar().FindParameter("d"));
  CHECK(AxisValues(axis) == std::vector<double>{0.0, 0.5, 1.0, 1.5, 2.0});
}

TEST_CASE("a range ends exactly at its last value whatever the rounding of its step",
          "[analysis]") {
  const GridAxis axis = RangeAxis(Names(), "k", 0.1, 0.7, 7);
  CHECK(axis.Value(6) == 0.7);
  CHECK(axis.Value(3) == 0.1 + 3 * ((0.7 - 0.1) / 6));  // numpy.linspace's formula
}

TEST_CASE("a range whose span overflows is spaced without overflow: its middle is 0",
          "[analysis]") {
  // last - first = 2e308 is beyond the largest double (1.8e308). Value i is then
  // first (1 - t) + last t with t = i / (count - 1): for -a:a, a (2t - 1), whose middle t = 1/2
  // is -a/2 + a/2 = 0 exactly (halving is exact). Before: inf - inf... the middle was inf.
  const GridAxis three = RangeAxis(Names(), "d", -1e308, 1e308, 3);
  CHECK(AxisValues(three) == std::vector<double>{-1e308, 0.0, 1e308});
  const double largest = std::numeric_limits<double>::max();
  const GridAxis widest = RangeAxis(Names(), "d", -largest, largest, 5);
  const std::vector<double> values = AxisValues(widest);
  REQUIRE(values.size() == 5);
  CHECK(values[0] == -largest);
  CHECK(values[1] == Approx(-largest / 2).epsilon(1e-15));  // a (2/4 - 1)
  CHECK(values[2] == 0.0);
  CHECK(values[3] == Approx(largest / 2).epsilon(1e-15));
  CHECK(values[4] == largest);
  // Descending, and many values: finite and strictly decreasing, ends exact.
  const GridAxis down = RangeAxis(Names(), "d", 1e308, -1e308, 1001);
  double previous = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < down.size(); ++i) {
    const double value = down.Value(i);
    INFO("value " << i << " = " << value);
    REQUIRE(std::isfinite(value));
    CHECK(value < previous);
    previous = value;
  }
  CHECK(down.Value(500) == 0.0);
  CHECK(down.Value(1000) == -1e308);
}

TEST_CASE("a range whose span is finite keeps numpy's spacing, bit for bit", "[analysis]") {
  // A sweep store resumes by the grid's values: they must not change where nothing overflows.
  const GridAxis axis = RangeAxis(Names(), "d", 0.0, 1.0, 11);
  CHECK(axis.Value(3) == 0.0 + 3 * ((1.0 - 0.0) / 10));  // 0.30000000000000004, not 0.3
  CHECK(axis.Value(3) != 0.3);
  const GridAxis wide = RangeAxis(Names(), "d", -1e307, 1e307, 3);  // span 2e307 is finite
  CHECK(wide.Value(1) == -1e307 + 1 * ((1e307 - -1e307) / 2));
}

TEST_CASE("a range of one value is its first value", "[analysis]") {
  CHECK(AxisValues(RangeAxis(Names(), "d", 3, 7, 1)) == std::vector<double>{3.0});
}

TEST_CASE("a list is taken as given, in its order", "[analysis]") {
  CHECK(AxisValues(ListAxis(Names(), "m1", {3, 1, 2})) == std::vector<double>{3, 1, 2});
}

TEST_CASE("points are numbered row-major: the first axis varies slowest", "[analysis]") {
  const ParameterGrid grid(
      {ListAxis(Names(), "alpha", {1, 2}), RangeAxis(Names(), "d", 10, 30, 3)});
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
  const ParameterGrid grid({RangeAxis(Names(), "m1", 0, 1, 2), RangeAxis(Names(), "m2", 0, 2, 3),
                            RangeAxis(Names(), "k", 0, 3, 4)});
  REQUIRE(grid.num_points() == 24);
  std::vector<double> values(3);
  grid.PointValues(1 * 12 + 2 * 4 + 3, values);
  CHECK(values == std::vector<double>{1, 2, 3});
}

TEST_CASE("Apply sets only the varied parameters", "[analysis]") {
  const Model& model = MassOnCar();
  const ParameterGrid grid({ListAxis(Names(), "d", {0, 7}), RangeAxis(Names(), "alpha", 0, 1, 2)});
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

TEST_CASE("a parameter varied twice is refused", "[analysis]") {
  CHECK(UsageErrorOf({RangeAxis(Names(), "alpha", 0, 1, 3), ListAxis(Names(), "d", {1}),
                      ListAxis(Names(), "alpha", {5})}) == "parameter 'alpha' is varied twice");
}

TEST_CASE("a grid with more points than std::size_t counts is refused", "[analysis]") {
  // 2^32 * 2^32 * 2 = 2^65 points.
  CHECK(UsageErrorOf({RangeAxis(Names(), "m1", 0, 1, 4294967296),
                      RangeAxis(Names(), "m2", 0, 1, 4294967296),
                      RangeAxis(Names(), "k", 0, 1, 2)}) ==
        "the grid has more than " + std::to_string(std::numeric_limits<std::size_t>::max()) +
            " points");
}

}  // namespace
}  // namespace servokit
