// The fast path of a sweep point (the compiled zero-dynamics polynomial) against the general
// path (Classify: V* and the normal form), point by point on grids that include the special
// points: alpha = 0 (tangential), alpha = 90 deg (ideal), d = 0 (critical, flat at alpha = 0),
// s = 0 (ideal), s = 2l/3 (tangential), and a polynomial of degree 4 (three masses, output
// the driven one: roots by GSL's companion-matrix solver).
#include "analysis/sweep_point.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <variant>

#include "models/loaded_model.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

void CheckSamePoint(const SweepPoint& fast, const SweepPoint& general) {
  REQUIRE(fast.ok == general.ok);
  CHECK(fast.realization == general.realization);
  CHECK(fast.rank == general.rank);
  CHECK(fast.relative_degree == general.relative_degree);
  CHECK(fast.differentiation_index == general.differentiation_index);
  CHECK(fast.internal_dynamics_order == general.internal_dynamics_order);
  CHECK(fast.stability == general.stability);
  REQUIRE(fast.eigenvalues.size() == general.eigenvalues.size());
  for (std::size_t k = 0; k < fast.eigenvalues.size(); ++k) {
    // Polynomial roots against eigenvalues of the zero-dynamics matrix: both backward stable,
    // agreeing to round-off times the conditioning of the roots.
    CHECK(std::abs(fast.eigenvalues[k] - general.eigenvalues[k]) <=
          1e-8 * std::max(1.0, std::abs(general.eigenvalues[k])));
  }
}

void CompareOnGrid(const std::string& path,
                   const std::string& parameter,
                   const std::vector<double>& values,
                   const std::vector<ParameterOverride>& overrides = {}) {
  const Model model = LoadModel(path, overrides);
  REQUIRE(model.has_zero_dynamics_polynomial());
  Workspace workspace(model);
  const ClassificationOptions options;
  const auto index = Eigen::Index(*model.FindParameter(parameter));
  for (const double value : values) {
    INFO(parameter << " = " << value);
    workspace.parameters(index) = value;
    const SweepPoint fast = AnalyzeSweepPoint(model, workspace, options, SweepPath::kFast);
    const SweepPoint general = AnalyzeSweepPoint(model, workspace, options, SweepPath::kGeneral);
    CheckSamePoint(fast, general);
  }
}

std::vector<double> Grid(double low, double high, int count) {
  std::vector<double> values;
  for (int i = 0; i < count; ++i) values.push_back(low + (high - low) * i / (count - 1));
  return values;
}

TEST_CASE("fast and general sweep points agree for the mass on car", "[analysis]") {
  const std::vector<double> angles = Grid(0.0, std::numbers::pi / 2, 91);
  CompareOnGrid(ModelPath("mass_on_car.yaml"), "alpha", angles, {{"d", "1"}});
  CompareOnGrid(ModelPath("mass_on_car.yaml"), "alpha", angles, {{"d", "0"}});
  CompareOnGrid(ModelPath("mass_on_car.yaml"), "d", Grid(0.0, 2.0, 41), {{"alpha", "0"}});
}

TEST_CASE("fast and general sweep points agree for the rotational arm", "[analysis]") {
  std::vector<double> positions = Grid(0.0, 1.0, 101);
  positions.push_back(2.0 / 3.0);
  CompareOnGrid(ModelPath("rotational_arm.yaml"), "s", positions);
  CompareOnGrid(ModelPath("rotational_arm_tip.yaml"), "s", Grid(0.05, 1.0, 20));
}

TEST_CASE("fast and general sweep points agree on a zero dynamics of degree 4", "[analysis]") {
  CompareOnGrid(TestDataPath("three_mass_chain.yaml"), "c", Grid(0.0, 5.0, 26));
  CompareOnGrid(TestDataPath("three_mass_chain.yaml"), "k", Grid(1.0, 1000.0, 26));
}

TEST_CASE("the fast path of a model with a constant push falls back to the general path",
          "[analysis]") {
  // f(0,0) = [0, a] with no input on z: q = 0 is not an equilibrium, so the general path
  // decides (here: no equilibrium at all).
  const Model model = LoadModel(TestDataPath("no_equilibrium.yaml"));
  Workspace workspace(model);
  const SweepPoint point = AnalyzeSweepPoint(model, workspace, {}, SweepPath::kFast);
  CHECK_FALSE(point.ok);
  CHECK_THAT(point.error, Catch::Contains("no equilibrium"));
}

// Mass on car at alpha = 90 deg (paper Eq. 36 with y_d = 0): m2 s'' + d s' + k s = 0 with the
// file's m2 = 2, d = 1, k = 5, so s = (-1 +- i sqrt(39)) / 4.
TEST_CASE("AnalyzePoint classifies a multibody model, and its sweep point agrees", "[analysis]") {
  const LoadedModel model = LoadModelFile(ModelPath("mass_on_car.yaml"), {{"alpha", "90 deg"}});
  PointWorkspace workspace(model);
  const ModelAnalysis analysis = AnalyzePoint(model, workspace, {});
  const auto* classification = std::get_if<Classification>(&analysis);
  REQUIRE(classification != nullptr);
  const std::complex<double> zero(-0.25, std::sqrt(39.0) / 4);
  const std::vector<std::complex<double>>& eigenvalues = classification->zero_dynamics.eigenvalues;
  REQUIRE(eigenvalues.size() == 2);
  // Eigenvalues of a 2 x 2 matrix: round-off of its entries.
  CHECK(std::abs(eigenvalues[0] - zero) < 1e-12);
  CHECK(std::abs(eigenvalues[1] - std::conj(zero)) < 1e-12);
  CHECK(classification->decoupling.realization == Realization::kIdealOrthogonal);
  const SweepPoint point = AnalyzeSweepPoint(model, workspace, {});
  REQUIRE(point.ok);
  REQUIRE(point.eigenvalues.size() == 2);
  CHECK(std::abs(point.eigenvalues[0] - zero) < 1e-12);
  CHECK(point.max_real_part == Approx(-0.25));
}

}  // namespace
}  // namespace servokit
