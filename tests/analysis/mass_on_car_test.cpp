// Mass on car, paper Sect. 3 and 4.1 (Eqs. 26-47, Fig. 6), with m1 = 1, m2 = 2, k = 5
// (docs/model-files.md, "Shipped models").
// Closed forms, derived again by hand:
//  - P = sin^2(a) / (m1 + m2 sin^2(a)) (Eq. 30): H M^-1 B with det M = m2 (m1 + m2 sin^2 a).
//  - Zero dynamics = zeros of det [[M s^2 + D s + K, -B], [H, 0]] = m2 sin^2(a) s^2 + d s + k,
//    which is Eq. (36) with y_d'' = 0 (Eq. 34 at a = 90 deg); at a = 0 it drops to d s + k
//    (Eq. 40) and, with d = 0, to the constant k: no zero dynamics (flat, Eq. 47).
//  - Index = 1 + highest derivative of y_d in F_d: 3 (Eqs. 33, 35), 4 (Eq. 42), 5 (Eq. 47).
#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>

#include "tests/analysis/classify_helpers.h"

namespace servokit {
namespace {

using testing::ClassifyFile;
using testing::ModelPath;
using testing::QuadraticRoots;

constexpr double kM1 = 1.0, kM2 = 2.0, kK = 5.0;

double PaperP(double alpha) {
  const double s2 = std::sin(alpha) * std::sin(alpha);
  return s2 / (kM1 + kM2 * s2);
}

Classification MassOnCar(const std::string& alpha, const std::string& d) {
  return ClassifyFile(ModelPath("mass_on_car.yaml"), {{"alpha", alpha}, {"d", d}});
}

void CheckEigenvalues(const Classification& c, const std::vector<std::complex<double>>& expected) {
  const auto& eigenvalues = c.zero_dynamics.eigenvalues;
  REQUIRE(eigenvalues.size() == expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    // Eigen-solver round-off on a 2x2 matrix: well below 1e-9 relative.
    CHECK(eigenvalues[i].real() == Approx(expected[i].real()).epsilon(1e-9).margin(1e-9));
    CHECK(eigenvalues[i].imag() == Approx(expected[i].imag()).epsilon(1e-9).margin(1e-9));
  }
  REQUIRE(c.cross_check.has_value());
  CHECK(c.cross_check->agrees);
}

TEST_CASE("case 1, vertical mass: ideal orthogonal, index 3, Eq. (34) zero dynamics",
          "[analysis][paper]") {
  const Classification c = MassOnCar("90 deg", "1");
  CHECK(c.decoupling.realization == Realization::kIdealOrthogonal);
  CHECK(c.decoupling.decoupling_matrix(0, 0) == Approx(1.0 / (kM1 + kM2)));  // Eq. (30) at 90 deg
  CHECK(c.decoupling.rank == 1);
  CHECK(c.structure.relative_degree == std::vector<int>{2});
  CHECK(c.structure.differentiation_index == 3);
  CHECK(c.structure.projected_index == 1);
  CHECK(c.structure.internal_dynamics_order == 2);
  CHECK_FALSE(c.flat);
  CheckEigenvalues(c, QuadraticRoots(kM2, 1.0, kK));  // Eq. (34): m2 s'' + d s' + k s = 0
  CHECK(c.zero_dynamics.stability == Stability::kAsymptoticallyStable);
  CHECK(c.zero_dynamics.minimum_phase);
}

TEST_CASE("case 1 undamped: the free vertical vibration at 0.2516 Hz, critical",
          "[analysis][paper]") {
  const Classification c = MassOnCar("90 deg", "0");
  REQUIRE(c.zero_dynamics.modes.size() == 1);
  const double expected_hz = std::sqrt(kK / kM2) / (2 * std::numbers::pi);
  CHECK(c.zero_dynamics.modes[0].frequency_hz == Approx(expected_hz).epsilon(1e-10));
  // The paper rounds sqrt(k / m2) / 2 pi = 0.25165 Hz to 0.25 Hz.
  CHECK(c.zero_dynamics.modes[0].frequency_hz == Approx(0.2516).margin(5e-5));
  CHECK(c.zero_dynamics.modes[0].damping_ratio == Approx(0.0).margin(1e-12));
  CHECK(c.zero_dynamics.stability == Stability::kCritical);
  CHECK_FALSE(c.zero_dynamics.minimum_phase);
}

TEST_CASE("case 2, tilted by 5 deg: non-ideal orthogonal, P from Eq. (30), Eq. (36)",
          "[analysis][paper]") {
  const double alpha = 5.0 * std::numbers::pi / 180.0;
  const Classification c = MassOnCar("5 deg", "1");
  CHECK(c.decoupling.realization == Realization::kNonIdealOrthogonal);
  CHECK(c.decoupling.decoupling_matrix(0, 0) == Approx(PaperP(alpha)).epsilon(1e-12));
  CHECK(c.structure.differentiation_index == 3);
  CHECK(c.structure.internal_dynamics_order == 2);
  const double a2 = kM2 * std::sin(alpha) * std::sin(alpha);
  CheckEigenvalues(c, QuadraticRoots(a2, 1.0, kK));
  // Over-damped (Fig. 6, d = 1 below 9.1 deg): two real eigenvalues, no oscillatory mode.
  CHECK(c.zero_dynamics.eigenvalues[0].imag() == 0.0);
  CHECK(c.zero_dynamics.eigenvalues[1].imag() == 0.0);
  CHECK(c.zero_dynamics.modes.empty());
  CHECK(c.zero_dynamics.stability == Stability::kAsymptoticallyStable);
}

TEST_CASE("case 2 undamped: the internal vibration rises to 2.887 Hz", "[analysis][paper]") {
  const double alpha = 5.0 * std::numbers::pi / 180.0;
  const Classification c = MassOnCar("5 deg", "0");
  REQUIRE(c.zero_dynamics.modes.size() == 1);
  const double expected_hz =
      std::sqrt(kK / (kM2 * std::sin(alpha) * std::sin(alpha))) / (2 * std::numbers::pi);
  CHECK(c.zero_dynamics.modes[0].frequency_hz == Approx(expected_hz).epsilon(1e-9));
  // The paper gives 2.88 Hz; sqrt(k / (m2 sin^2 alpha)) / 2 pi = 2.8873 Hz.
  CHECK(c.zero_dynamics.modes[0].frequency_hz == Approx(2.887).margin(5e-4));
  CHECK(c.zero_dynamics.stability == Stability::kCritical);
  CHECK(c.recommended_solver == SolverMethod::kNormalForm);
}

TEST_CASE("just above the over-damping threshold at d = 1 the zero dynamics oscillates",
          "[analysis][paper]") {
  // Discriminant of m2 sin^2(a) s^2 + d s + k: complex for sin^2(a) > d^2 / (4 m2 k) = 1/40.
  const Classification above = MassOnCar("9.2 deg", "1");
  const Classification below = MassOnCar("9.0 deg", "1");
  CHECK(above.zero_dynamics.modes.size() == 1);
  CHECK(below.zero_dynamics.modes.empty());
}

TEST_CASE("case 3, horizontal and damped: P = 0, tangential, index 4, Eq. (40)",
          "[analysis][paper]") {
  const Classification c = MassOnCar("0", "1");
  CHECK(c.decoupling.realization == Realization::kTangential);
  CHECK(c.decoupling.rank == 0);
  CHECK(c.decoupling.rank_deficiency == 1);
  CHECK(c.decoupling.decoupling_matrix(0, 0) == Approx(0.0).margin(1e-15));
  CHECK(c.structure.relative_degree == std::vector<int>{3});  // y''' needed (Eq. 42)
  CHECK(c.structure.differentiation_index == 4);
  CHECK(c.structure.projected_index == 2);
  CHECK(c.structure.internal_dynamics_order == 1);
  CheckEigenvalues(c, {{-kK / 1.0, 0.0}});  // Eq. (40): k s + d s' = 0
  CHECK_FALSE(c.flat);
  CHECK(c.recommended_solver == SolverMethod::kNormalForm);
}

TEST_CASE("case 4, horizontal and undamped: tangential, index 5, flat", "[analysis][paper]") {
  const Classification c = MassOnCar("0", "0");
  CHECK(c.decoupling.realization == Realization::kTangential);
  CHECK(c.structure.relative_degree == std::vector<int>{4});  // y'''' needed (Eq. 47)
  CHECK(c.structure.differentiation_index == 5);
  CHECK(c.structure.projected_index == 3);
  CHECK(c.structure.internal_dynamics_order == 0);
  CHECK(c.flat);
  CHECK(c.zero_dynamics.eigenvalues.empty());
  CHECK(c.zero_dynamics.stability == Stability::kNone);
  CHECK(c.recommended_solver == SolverMethod::kAlgebraic);
  REQUIRE(c.cross_check.has_value());
  CHECK(c.cross_check->invariant_zeros.empty());  // QZ finds only infinite eigenvalues
}

TEST_CASE("the realization does not depend on the unit of length", "[analysis]") {
  // Scaling k and d by 1e6 (e.g. grams and millimetres) must not move a rank decision.
  const Classification c =
      ClassifyFile(ModelPath("mass_on_car.yaml"),
                   {{"alpha", "0"}, {"k", "5e6"}, {"d", "1e6"}, {"m1", "1e3"}, {"m2", "2e3"}});
  CHECK(c.decoupling.realization == Realization::kTangential);
  CHECK(c.structure.differentiation_index == 4);
  CheckEigenvalues(c, {{-5.0, 0.0}});
}

}  // namespace
}  // namespace servokit
