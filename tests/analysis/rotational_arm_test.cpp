// Rotational arm with a passive joint, paper Sect. 4.2 (Eqs. 49-56, Fig. 8, Table 2).
// Closed forms, derived again by hand from Eq. (49) and the output y = alpha + s/(s+l) beta:
//  - det M = m^2 l^4 (4/9 - cos^2(b)/4) and, with sigma = s/(s+l),
//    P = (M22 - sigma M12) / det M = (2l - 3 s cos b) / (6 m l^2 (s+l) (4/9 - cos^2(b)/4)).
//    It vanishes at s* = 2l/(3 cos b), as the paper says. The paper's printed Eq. (54),
//    2l(3s cos b - 2l) / (m l^2 (l+s)(9 cos 2b - 23)), has the units 1/(kg m) instead of
//    1/(kg m^2) and is l/6 times the value above; the test below shows the derivation wins.
//  - Zeros: det [[M s^2 + D s + K, -B], [H, 0]] = (M22 - sigma M12) s^2 + d s + c at b = 0, times
//    6(s+l): m l^2 (2l - 3s) s^2 + 6d(s+l) s + 6c(s+l), which is Eq. (56).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>

#include "analysis/decoupling_matrix.h"
#include "tests/analysis/classify_helpers.h"

namespace servokit {
namespace {

using testing::ClassifyFile;
using testing::ModelPath;
using testing::QuadraticRoots;

constexpr double kL = 1.0, kMass = 3.438, kC = 50.0, kD = 0.25;

std::string Exact(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

Classification Arm(double s) {
  return ClassifyFile(ModelPath("rotational_arm.yaml"), {{"s", Exact(s)}});
}

double DerivedP(double s, double beta) {
  const double cos_beta = std::cos(beta);
  return (2 * kL - 3 * s * cos_beta) /
         (6 * kMass * kL * kL * (s + kL) * (4.0 / 9.0 - cos_beta * cos_beta / 4.0));
}

double PaperEq54(double s, double beta) {
  return 2 * kL * (3 * s * std::cos(beta) - 2 * kL) /
         (kMass * kL * kL * (kL + s) * (9 * std::cos(2 * beta) - 23));
}

// P = H M^-1 B evaluated by servokit at q = (0, beta).
double ServokitP(double s, double beta) {
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"), {{"s", Exact(s)}});
  Workspace workspace(model);
  const Eigen::Vector2d q(0.0, beta);
  Evaluate(model, workspace, q, Eigen::Vector2d::Zero(),
           Quantity::kMassMatrix | Quantity::kInputMatrix | Quantity::kOutputJacobian);
  const Eigen::MatrixXd input_accelerations =
      workspace.mass_matrix.llt().solve(workspace.input_matrix);
  return DecouplingMatrix(workspace.output_jacobian, input_accelerations)(0, 0);
}

TEST_CASE("P of the arm follows the derived formula; the printed Eq. (54) is l/6 of it",
          "[analysis][paper]") {
  for (const double beta : {0.0, 0.3, -0.8, 1.2}) {
    for (const double s : {0.0, 0.4, 1.0}) {
      CHECK(ServokitP(s, beta) == Approx(DerivedP(s, beta)).epsilon(1e-12).margin(1e-15));
      if (std::abs(DerivedP(s, beta)) > 1e-3) {
        CHECK(PaperEq54(s, beta) / DerivedP(s, beta) == Approx(kL / 6.0).epsilon(1e-12));
      }
    }
  }
}

TEST_CASE("P vanishes at s* = 2l/(3 cos beta) away from the operating point too",
          "[analysis][paper]") {
  const double beta = 0.3;
  CHECK(ServokitP(2 * kL / (3 * std::cos(beta)), beta) == Approx(0.0).margin(1e-15));
}

TEST_CASE("collocated output s = 0: ideal orthogonal", "[analysis][paper]") {
  const Classification c = Arm(0.0);
  CHECK(c.decoupling.realization == Realization::kIdealOrthogonal);
  CHECK(c.structure.differentiation_index == 3);
  CHECK(c.structure.internal_dynamics_order == 2);
  CHECK(c.zero_dynamics.stability == Stability::kAsymptoticallyStable);
}

TEST_CASE("zero dynamics follows Eq. (56): stable below s/l = 2/3, unstable above",
          "[analysis][paper]") {
  for (const double s : {0.1, 0.3, 0.5, 0.6, 0.66, 0.67, 0.7, 0.8, 0.9, 1.0}) {
    INFO("s = " << s);
    const Classification c = Arm(s);
    CHECK(c.decoupling.realization == Realization::kNonIdealOrthogonal);
    const double a2 = kMass * kL * kL * (2 * kL - 3 * s);
    const auto expected = QuadraticRoots(a2, 6 * kD * (s + kL), 6 * kC * (s + kL));
    REQUIRE(c.zero_dynamics.eigenvalues.size() == 2);
    for (std::size_t i = 0; i < 2; ++i) {
      // 2x2 eigen-solver round-off, amplified near s = 2/3 where a2 -> 0 (|lambda| ~ 1e3).
      CHECK(std::abs(c.zero_dynamics.eigenvalues[i] - expected[i]) <=
            1e-9 * std::max(1.0, std::abs(expected[i])));
    }
    CHECK(c.zero_dynamics.stability ==
          (s < 2.0 * kL / 3.0 ? Stability::kAsymptoticallyStable : Stability::kUnstable));
    CHECK(c.recommended_solver ==
          (s < 2.0 * kL / 3.0 ? SolverMethod::kBdf : SolverMethod::kStableInversion));
    REQUIRE(c.cross_check.has_value());
    CHECK(c.cross_check->agrees);
  }
}

TEST_CASE("at s = 2l/3 the realization is tangential with one real zero -c/d",
          "[analysis][paper]") {
  // a2 = 0 in Eq. (56): d beta' + c beta = 0 after dividing by 6(s+l).
  const Classification c = Arm(2.0 * kL / 3.0);
  CHECK(c.decoupling.realization == Realization::kTangential);
  CHECK(c.structure.relative_degree == std::vector<int>{3});
  CHECK(c.structure.differentiation_index == 4);
  CHECK(c.structure.internal_dynamics_order == 1);
  REQUIRE(c.zero_dynamics.eigenvalues.size() == 1);
  CHECK(c.zero_dynamics.eigenvalues[0].real() == Approx(-kC / kD).epsilon(1e-9));
}

TEST_CASE("the exact tip angle has the same zero dynamics at rest as the auxiliary angle",
          "[analysis][paper]") {
  // Paper after Eq. (51): the exact position of S gives the same results; its Jacobian at
  // beta = 0 is [1, s/(l+s)], the auxiliary angle's.
  const Classification auxiliary = Arm(1.0);
  const Classification tip = ClassifyFile(ModelPath("rotational_arm_tip.yaml"));
  REQUIRE(tip.zero_dynamics.eigenvalues.size() == 2);
  for (std::size_t i = 0; i < 2; ++i) {
    CHECK(std::abs(tip.zero_dynamics.eigenvalues[i] - auxiliary.zero_dynamics.eigenvalues[i]) <=
          1e-9 * std::abs(auxiliary.zero_dynamics.eigenvalues[i]));
  }
  CHECK(tip.zero_dynamics.stability == Stability::kUnstable);
}

TEST_CASE("the tip angle held at 30 deg: Newton finds alpha = 30 deg, same zero dynamics",
          "[analysis]") {
  // The arm moves in a horizontal plane: every angle is an equilibrium with beta = 0, T = 0.
  ClassificationOptions options;
  options.operating_point.y0 = Eigen::VectorXd::Constant(1, 30.0 * std::numbers::pi / 180.0);
  const Classification turned = ClassifyFile(ModelPath("rotational_arm_tip.yaml"), {}, options);
  CHECK(turned.operating_point.q(0) == Approx(30.0 * std::numbers::pi / 180.0).epsilon(1e-12));
  CHECK(turned.operating_point.q(1) == Approx(0.0).margin(1e-12));
  CHECK(turned.operating_point.u(0) == Approx(0.0).margin(1e-10));
  CHECK(turned.operating_point.newton_iterations > 0);
  const Classification rest = ClassifyFile(ModelPath("rotational_arm_tip.yaml"));
  for (std::size_t i = 0; i < 2; ++i) {
    CHECK(std::abs(turned.zero_dynamics.eigenvalues[i] - rest.zero_dynamics.eigenvalues[i]) <=
          1e-8 * std::abs(rest.zero_dynamics.eigenvalues[i]));
  }
}

}  // namespace
}  // namespace servokit
