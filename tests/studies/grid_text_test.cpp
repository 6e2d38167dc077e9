// The `--vary` grammar (studies/grid_text.h): range a:b:n, list v1,v2,..., degrees, and
// the exact messages of the usage errors, which name the option. The same reader serves both model
// kinds: only the parameter names come from the model.
#include "studies/grid_text.h"

#include <catch2/catch.hpp>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "base/errors.h"
#include "modeling/linear_model.h"
#include "modeling/model.h"
#include "modeling/units.h"
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
    ParseParameterGrid(MassOnCar(), "--vary", texts);
  } catch (const UsageError& error) {
    return error.what();
  }
  return "no error";
}

TEST_CASE("a range a:b:n is n evenly spaced values from a to b, both included", "[reports]") {
  const GridAxis axis = ParseGridAxis(MassOnCar(), "--vary", "d=0:2:5");
  CHECK(axis.name == "d");
  CHECK(axis.parameter == 3);  // m1, m2, k, d, alpha
  CHECK(AxisValues(axis) == std::vector<double>{0.0, 0.5, 1.0, 1.5, 2.0});
}

TEST_CASE("n = 1 is the single value a", "[reports]") {
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "--vary", "d=3:7:1")) == std::vector<double>{3.0});
}

TEST_CASE("deg is accepted on each value of a range or list, with or without a blank",
          "[reports]") {
  const double ninety = *ParseQuantity("90 deg");
  CHECK(ninety == std::numbers::pi / 2);
  for (const char* text : {"alpha=0deg:90deg:3", "alpha=0 deg:90 deg:3", "alpha=0:90deg:3"}) {
    INFO(text);
    // A range with a value in degrees is spaced evenly in degrees: its middle is "45 deg".
    CHECK(AxisValues(ParseGridAxis(MassOnCar(), "--vary", text)) ==
          std::vector<double>{0.0, *ParseQuantity("45 deg"), ninety});
  }
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "--vary", "alpha=90deg, 0.5,45 deg")) ==
        std::vector<double>{ninety, 0.5, *ParseQuantity("45 deg")});
}

TEST_CASE("a list is taken as given, in its order; one value is a list of one", "[reports]") {
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "--vary", "m1=3,1,2")) ==
        std::vector<double>{3, 1, 2});
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "--vary", "m1=4")) == std::vector<double>{4});
}

TEST_CASE("the first --vary varies slowest", "[reports]") {
  const ParameterGrid grid = ParseParameterGrid(MassOnCar(), "--vary", {"alpha=1,2", "d=10:30:3"});
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
        "--vary alpha=0:1: a range is a:b:n, a:b:n=N or a:b:step=h, e.g. alpha=0deg:90deg:n=91 "
        "(91 values from a to b) or alpha=0deg:90deg:step=1deg");
  CHECK(UsageErrorOf({"alpha=0:1:2:3"}) ==
        "--vary alpha=0:1:2:3: a range is a:b:n, a:b:n=N or a:b:step=h, e.g. "
        "alpha=0deg:90deg:n=91 (91 values from a to b) or alpha=0deg:90deg:step=1deg");
  CHECK(UsageErrorOf({"alpha=0:1:step=0"}) ==
        "--vary alpha=0:1:step=0: the step h of a:b:step=h must be > 0");
  CHECK(UsageErrorOf({"alpha=0:1:step=-0.5"}) ==
        "--vary alpha=0:1:step=-0.5: the step h of a:b:step=h must be > 0");
  CHECK(UsageErrorOf({"alpha=1:0:step=0.5"}) ==
        "--vary alpha=1:0:step=0.5: a:b:step=h needs a <= b");
  CHECK(UsageErrorOf({"alpha=0:1:step=x"}) ==
        "--vary alpha=0:1:step=x: 'x' is not a number (use e.g. 0.5 or \"5 deg\")");
  CHECK(UsageErrorOf({"alpha=0:1:n=0"}) ==
        "--vary alpha=0:1:n=0: the number of values must be at least 1, got 0");
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
  const ParameterGrid grid = ParseParameterGrid(model.parameter_names(), "--vary", {"d=0:1:3"});
  REQUIRE(grid.num_points() == 3);
  CHECK(grid.axes().front().parameter == 2);
  CHECK_THROWS_WITH(ParseParameterGrid(model.parameter_names(), "--vary", {"q=1:2:3"}),
                    "--vary q=1:2:3: unknown parameter 'q' (the model has m, k, d, alpha)");
}

// ---- explicit forms, units and warnings (issue #17) ---------------------------------------------

const Model& MassOnCarModel() {
  static const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  return model;
}

GridParameters MassOnCarParameters() {
  return {MassOnCarModel().parameter_names(), MassOnCarModel().parameter_display_units()};
}

std::vector<std::string> WarningsOf(const std::string& text) {
  std::vector<std::string> warnings;
  ParseGridAxis(MassOnCarParameters(), "--vary", text, &warnings);
  return warnings;
}

TEST_CASE("a:b:n=N is N values from a to b, as a:b:N", "[reports]") {
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "--vary", "d=0:2:n=5")) ==
        AxisValues(ParseGridAxis(MassOnCar(), "--vary", "d=0:2:5")));
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "--vary", "d=3:7:n=1")) == std::vector<double>{3.0});
}

TEST_CASE("a:b:step=h is a, a + h, ... up to b, b included within a rounding tolerance",
          "[reports]") {
  // (1 - 0) / 0.1 = 10.000000000000002 in floating point: whole within 1e-9, so 11 values and
  // the last is exactly 1.
  const std::vector<double> tenths =
      AxisValues(ParseGridAxis(MassOnCar(), "--vary", "d=0:1:step=0.1"));
  REQUIRE(tenths.size() == 11);
  CHECK(tenths.front() == 0.0);
  CHECK(tenths.back() == 1.0);
  CHECK(tenths[3] == Approx(0.3).epsilon(1e-15));
  // 1 / 0.3 = 3.33: b is not reached; the values stop at 0.9.
  const std::vector<double> thirds =
      AxisValues(ParseGridAxis(MassOnCar(), "--vary", "d=0:1:step=0.3"));
  REQUIRE(thirds.size() == 4);
  CHECK(thirds.back() == Approx(0.9).epsilon(1e-15));
  CHECK(thirds.back() < 1.0);
  // a = b is one value; a step larger than b - a too.
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "--vary", "d=2:2:step=1")) ==
        std::vector<double>{2.0});
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "--vary", "d=2:3:step=5")) ==
        std::vector<double>{2.0});
  // Degrees: 0, 5, ..., 90 is 19 values, each exactly what "<v> deg" converts to.
  const GridAxis alpha = ParseGridAxis(MassOnCar(), "--vary", "alpha=0deg:90deg:step=5deg");
  REQUIRE(alpha.size() == 19);
  CHECK(alpha.display_unit == DisplayUnit::kDegree);
  for (std::size_t i = 0; i < alpha.size(); ++i) {
    const double degrees = 5.0 * static_cast<double>(i);
    CHECK(alpha.Value(i) == DegreesToRadians(degrees));
    CHECK(alpha.DisplayValue(alpha.Value(i)) == degrees);
  }
}

TEST_CASE("ranges whose span overflows the largest double are read without overflow", "[reports]") {
  // b - a = 2e308 overflows: a:b:3 is a, (a + b) / 2 = 0, b (parameter_grid.h), and
  // a:b:step=h counts (b - a) / h as b/h - a/h = 2 steps. Before: the middle value was inf, and
  // the step form said "the step h is too small".
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "--vary", "d=-1e308:1e308:3")) ==
        std::vector<double>{-1e308, 0.0, 1e308});
  CHECK(AxisValues(ParseGridAxis(MassOnCar(), "--vary", "d=-1e308:1e308:step=1e308")) ==
        std::vector<double>{-1e308, 0.0, 1e308});
  // 2e308 / 3e307 = 6.67 steps: the whole ones, up to -1e308 + 6 * 3e307 = 8e307.
  const std::vector<double> sixths =
      AxisValues(ParseGridAxis(MassOnCar(), "--vary", "d=-1e308:1e308:step=3e307"));
  REQUIRE(sixths.size() == 7);
  CHECK(sixths.back() == Approx(8e307).epsilon(1e-15));
}

TEST_CASE("a --vary in degrees, or of a parameter the model gives in degrees, is shown in degrees",
          "[reports]") {
  // mass_on_car.yaml: alpha: 5 deg, the others in SI.
  const std::vector<DisplayUnit> units = MassOnCarModel().parameter_display_units();
  CHECK(units == std::vector<DisplayUnit>{DisplayUnit::kSI, DisplayUnit::kSI, DisplayUnit::kSI,
                                          DisplayUnit::kSI, DisplayUnit::kDegree});
  const GridAxis listed = ParseGridAxis(MassOnCarParameters(), "--vary", "alpha=5deg,30deg");
  CHECK(listed.display_unit == DisplayUnit::kDegree);
  CHECK(listed.ColumnName() == "alpha_deg");
  // The given degrees come back exactly, although 5 pi/180 * 180/pi need not be 5.
  CHECK(listed.DisplayValue(listed.Value(0)) == 5.0);
  CHECK(listed.DisplayValue(listed.Value(1)) == 30.0);
  // Declared in degrees by the model: bare numbers are degrees (issue #34), radians are named.
  const GridAxis bare = ParseGridAxis(MassOnCarParameters(), "--vary", "alpha=0.5,1");
  CHECK(bare.display_unit == DisplayUnit::kDegree);
  CHECK(bare.Value(0) == *ParseQuantity("0.5 deg"));
  CHECK(bare.DisplayValue(bare.Value(1)) == 1.0);
  const GridAxis radians = ParseGridAxis(MassOnCarParameters(), "--vary", "alpha=0.5rad,1rad");
  CHECK(radians.display_unit == DisplayUnit::kDegree);
  CHECK(radians.Value(0) == 0.5);
  CHECK(radians.DisplayValue(0.5) == Approx(0.5 * 180.0 / std::numbers::pi).epsilon(1e-15));
  // A deg on any value marks the axis, whatever the model says.
  CHECK(ParseGridAxis(MassOnCarParameters(), "--vary", "d=0:1:3").display_unit == DisplayUnit::kSI);
  CHECK(ParseGridAxis(MassOnCar(), "--vary", "d=0deg:1deg:n=3").display_unit ==
        DisplayUnit::kDegree);
  // A range in degrees is evenly spaced in degrees: 0deg:90deg:91 reads 0, 1, ..., 90.
  const GridAxis range = ParseGridAxis(MassOnCar(), "--vary", "alpha=0deg:90deg:91");
  for (std::size_t i = 0; i < range.size(); ++i) {
    CHECK(range.DisplayValue(range.Value(i)) == static_cast<double>(i));
    CHECK(range.Value(i) == *ParseQuantity(std::to_string(i) + " deg"));
  }
}

TEST_CASE("a bare a:b:n that MATLAB would read as start:step:end warns, saying both spellings",
          "[reports]") {
  CHECK(WarningsOf("d=0:5:90") ==
        std::vector<std::string>{
            "--vary d=0:5:90 is read as 90 values from 0 to 5 (servokit's a:b:n), not as "
            "MATLAB's start:step:end (0, 5, ..., 90); write d=0:5:n=90 for the first, "
            "d=0:90:step=5 for the second"});
  CHECK(WarningsOf("d=-1:2:61").size() == 1);  // (61 + 1) / 2 = 31 steps
  // No warning: explicit forms, a unit, n <= b, b <= a, or (n - a)/b not whole.
  for (const char* text : {"d=0:5:n=90", "d=0:90:step=5", "d=0:2:21", "d=0:90:5", "d=5:0:90",
                           "m1=1:3:2", "d=0.01:0.1:50", "d=0:1:1"}) {
    INFO(text);
    CHECK(WarningsOf(text).empty());
  }
  CHECK(WarningsOf("alpha=0deg:5deg:90").empty());
}

TEST_CASE("an angle without a unit spanning more than a turn warns", "[reports]") {
  // An angle the model gives in SI (here the mass on car's names without their units): 0..90
  // without a unit is 90 rad.
  static const std::vector<DisplayUnit> kAllSi;
  const auto si_warnings = [](const std::string& text) {
    std::vector<std::string> warnings;
    ParseGridAxis(GridParameters{MassOnCar(), kAllSi}, "--vary", text, &warnings);
    return warnings;
  };
  CHECK(si_warnings("alpha=0:90:n=91") ==
        std::vector<std::string>{
            "--vary alpha=0:90:n=91: the values of the angle 'alpha' carry no unit and span 90 "
            "rad, more than a full turn (2 pi); they are read as radians (SI): if you meant "
            "degrees, write them with deg (e.g. 0deg:90deg:n=91)"});
  CHECK(si_warnings("alpha=0,10").size() == 1);
  CHECK(si_warnings("alpha=0:6:n=7").empty());        // within a turn
  CHECK(si_warnings("alpha=0deg:90deg:91").empty());  // a unit
  CHECK(si_warnings("alpha=0rad:90rad:91").empty());  // named: radians meant
  // Given in degrees by the model: bare numbers are degrees, nothing to warn (issue #34).
  CHECK(WarningsOf("alpha=0:90:n=91").empty());
  CHECK(WarningsOf("d=0:90:n=91").empty());  // not an angle
  CHECK(IsAngleLike("theta", DisplayUnit::kSI));
  CHECK(IsAngleLike("joint_angle", DisplayUnit::kSI));
  CHECK(IsAngleLike("q", DisplayUnit::kDegree));
  CHECK_FALSE(IsAngleLike("alphabet", DisplayUnit::kSI));
  CHECK_FALSE(IsAngleLike("k", DisplayUnit::kSI));
}

TEST_CASE("a varied parameter whose column clashes with another column is refused", "[reports]") {
  // A model with parameters named like fixed columns, and one named like another's "_deg"
  // column.
  const Model model = LoadModelFromString(R"(name: clash
parameters: {re: 1.0, error: 2.0, a: 5 deg, a_deg: 1.0, k: 3.0}
coordinates: [x]
inputs: [F]
mass_matrix: [[1]]
forces: [re*error*a_deg*k*x + a*x]
input_matrix: [[1]]
outputs: [x]
)",
                                          "clash.yaml");
  const GridParameters parameters{model.parameter_names(), model.parameter_display_units()};
  const auto error_of = [&](const std::vector<std::string>& texts) -> std::string {
    try {
      ParseParameterGrid(parameters, "--vary", texts);
    } catch (const UsageError& error) {
      return error.what();
    }
    return "no error";
  };
  CHECK(error_of({"re=1,2"}) ==
        "--vary: parameter 're': its column 're' would also be a fixed column of eigenvalues.csv "
        "(a table cannot have two columns of one name); rename the parameter in the model file "
        "to vary it");
  CHECK(error_of({"error=1,2"}) ==
        "--vary: parameter 'error': its column 'error' would also be a fixed column of points.csv "
        "(a table cannot have two columns of one name); rename the parameter in the model file "
        "to vary it");
  CHECK(error_of({"a_deg=1,2", "a=1,2"}) ==
        "--vary: parameter 'a': its column 'a_deg' would also be the column of the varied "
        "parameter 'a_deg' (a table cannot have two columns of one name); rename the parameter "
        "in the model file to vary it");
  // k is no longer a column name: eigenvalues.csv numbers its eigenvalues in eigenvalue_index.
  CHECK(error_of({"k=1,2"}) == "no error");
}

}  // namespace
}  // namespace servokit
