// The fast path of a sweep point (the compiled zero-dynamics polynomial) against the general
// path (Classify: V* and the normal form), point by point on grids that include the special
// points: alpha = 0 (tangential), alpha = 90 deg (ideal), d = 0 (critical, flat at alpha = 0),
// s = 0 (ideal), s = 2l/3 (tangential), and a polynomial of degree 4 (three masses, output
// the driven one: roots by GSL's companion-matrix solver).
#include "analysis/sweep_point.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <variant>

#include "analysis/classification.h"
#include "base/errors.h"
#include "modeling/loaded_model.h"
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

// ---- hostile points (issue #29): a sweep point decides as `analyze` does ---------------------
//
// `analyze` is Classify with its default options (the QZ cross-check included, which records a
// disagreement but fails nothing: analysis/classification.h). The mass on car (file comment of
// tests/analysis/edge_cases_test.cpp) has det M = m1 m2 + m2^2 sin^2(alpha) and the zero
// dynamics m2 sin^2(alpha) s'' + d s' + k s = 0, so the grid holds: M exactly singular (m1 = 0
// at alpha = 0, or m2 = 0), singular to working precision (m1 = 1e-300 or 1e-20 against m2 = 1
// at alpha = 0), not isolated (k = 0), overflowing entries, products or roots (1e300, 1e308,
// -d / (m2 sin^2 alpha) beyond the largest double), and regular points among them.

struct SweepAgainstAnalyze {
  int failures = 0, successes = 0;
};

SweepAgainstAnalyze CompareWithAnalyze(const Model& model,
                                       const std::vector<std::vector<double>>& axes) {
  Workspace workspace(model);
  SweepAgainstAnalyze counts;
  std::vector<std::size_t> index(axes.size(), 0);
  for (;;) {
    Eigen::VectorXd values(static_cast<Eigen::Index>(axes.size()));
    for (std::size_t a = 0; a < axes.size(); ++a) values(Eigen::Index(a)) = axes[a][index[a]];
    INFO("parameters " << values.transpose());
    workspace.parameters = values;
    std::optional<Classification> analyzed;
    std::string analyze_error;
    try {
      analyzed = Classify(model, workspace);
    } catch (const NoSolution& error) {
      analyze_error = error.what();
    }
    workspace.parameters = values;
    const SweepPoint point = AnalyzeSweepPoint(model, workspace, ClassificationOptions{});
    REQUIRE(point.ok == analyzed.has_value());
    if (!point.ok) {
      CHECK(point.error == analyze_error);
      ++counts.failures;
    } else {
      CHECK(point.realization == analyzed->decoupling.realization);
      CHECK(point.rank == static_cast<long>(analyzed->decoupling.rank));
      CHECK(point.relative_degree == analyzed->structure.relative_degree);
      CHECK(point.internal_dynamics_order == analyzed->structure.internal_dynamics_order);
      CHECK(point.stability == analyzed->zero_dynamics.stability);
      CHECK(point.eigenvalues.size() == analyzed->zero_dynamics.eigenvalues.size());
      ++counts.successes;
    }
    std::size_t a = axes.size();
    while (a-- > 0 && ++index[a] == axes[a].size()) index[a] = 0;
    if (a == std::size_t(-1)) return counts;
  }
}

TEST_CASE("a sweep point fails exactly where analyze fails, with analyze's message", "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  REQUIRE(model.parameter_names() == std::vector<std::string>{"m1", "m2", "k", "d", "alpha"});
  const std::vector<double> masses = {0.0, 1e-300, 1e-20, 1.0, 1e300};
  const SweepAgainstAnalyze counts =
      CompareWithAnalyze(model, {masses,
                                 masses,
                                 {0.0, 1e-300, 5.0, 1e300, 1e308},
                                 {0.0, 1.0, -1.0, 1e300, -1e300, 1e308, -1e308},
                                 {0.0, 5.0 * std::numbers::pi / 180.0, std::numbers::pi / 2}});
  // Both kinds occur (the grid is mostly hostile: 2625 points).
  CHECK(counts.failures > 1000);
  CHECK(counts.successes > 100);
}

TEST_CASE("the issue's sweep points are analyze's errors: singular M and overflowing damping",
          "[analysis]") {
  // alpha = 0, d = 1: M = [[m1 + 2, 2], [2, 2]], det M = 2 m1, reciprocal condition (1-norm)
  // m1 / 8: 0 at m1 = 0, and 1.25e-21 at m1 = 1e-20 (where m1 + 2 even rounds to 2), far below
  // analyze's limit 1e3 epsilon = 2.2e-13. Before: "tangential, asymptotically-stable" for both.
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "1"}});
  Workspace workspace(model);
  const auto m1 = Eigen::Index(*model.FindParameter("m1"));
  for (const double mass : {0.0, 1e-20}) {
    INFO("m1 = " << mass);
    workspace.parameters(m1) = mass;
    const SweepPoint point = AnalyzeSweepPoint(model, workspace, ClassificationOptions{});
    CHECK_FALSE(point.ok);
    CHECK_THAT(point.error, Catch::StartsWith("the mass matrix is singular to working precision"));
  }
  // alpha = 5 deg, d = +-1e308: the root -d / (m2 sin^2 alpha), of magnitude 6.6e309, is beyond
  // the largest double. Before: "critical" (the other root, -k / d = -+5e-308, taken as 0).
  const Model car = LoadModel(ModelPath("mass_on_car.yaml"));
  Workspace car_workspace(car);
  const auto d = Eigen::Index(*car.FindParameter("d"));
  for (const double damping : {1e308, -1e308}) {
    INFO("d = " << damping);
    car_workspace.parameters(d) = damping;
    const SweepPoint point = AnalyzeSweepPoint(car, car_workspace, ClassificationOptions{});
    CHECK_FALSE(point.ok);
    CHECK_THAT(point.error, Catch::Contains("overflows the range of double"));
  }
}

TEST_CASE("a polynomial whose roots span the double range does not hang the sweep", "[analysis]") {
  // Three-mass chain (tests/data/three_mass_chain.yaml) at m = 9.7e-96, k = 1.3e87: the zero
  // dynamics (masses 2 and 3 held by the springs, output x1 = 0) have omega^2 ~ k / m ~ 1e182,
  // so their polynomial of degree 4 has a_0 / a_4 ~ (k / m)^2 ~ 1e364, beyond the largest
  // double. GSL's companion-matrix balancing never returned on it; the general path decides,
  // as analyze does.
  const Model model =
      LoadModel(TestDataPath("three_mass_chain.yaml"), {{"m", "9.7442633457176142e-96"},
                                                        {"k", "1.2631608502875726e+87"},
                                                        {"c", "-2.6137286962951665e-72"}});
  Workspace workspace(model);
  const Classification analyzed = Classify(model, workspace);
  const SweepPoint point = AnalyzeSweepPoint(model, workspace, ClassificationOptions{});
  REQUIRE(point.ok);
  CHECK(point.stability == analyzed.zero_dynamics.stability);
  CHECK(point.internal_dynamics_order == 4);  // 2 dof - relative degree 2
}

}  // namespace
}  // namespace servokit
