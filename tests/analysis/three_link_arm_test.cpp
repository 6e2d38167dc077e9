// models/three_link_arm.yaml: two internal coordinates, hyperbolic unstable zero dynamics
// (the stable-inversion case of issue #5). The expected zero dynamics are built here from the
// rods, not from the model file: at q = 0 all links lie on the x axis, so the rod centres move
// only in y, y_c = Jy th with th = S q the absolute angles, and
//   M0 = S^T (m Jy^T Jy + m l^2/12 I) S.
// Holding y = alpha + (2 beta1 + beta2)/3 fixed means q = Z eta with the columns of Z spanning
// ker H; rows 2 and 3 of the equations carry no input (B = e1), so the zero dynamics are
//   (W M0 Z) eta'' + d eta' + c eta = 0,  W = [0 I2],  W diag(0,1,1) Z = I2.
#include <algorithm>
#include <catch2/catch.hpp>
#include <complex>
#include <string>
#include <vector>

#include "tests/analysis/classify_helpers.h"

namespace servokit {
namespace {

using testing::ClassifyFile;
using testing::ModelPath;

constexpr double kL = 1.0, kMass = 3.438, kC = 50.0;

std::vector<std::complex<double>> ExpectedZeroDynamics(double d) {
  Eigen::Matrix3d chain;  // absolute angles from q: th = S q
  chain << 1, 0, 0, 1, 1, 0, 1, 1, 1;
  Eigen::Matrix3d centre_y;  // y of the rod centres from the absolute angles, at q = 0
  centre_y << 0.5, 0, 0, 1, 0.5, 0, 1, 1, 0.5;
  centre_y *= kL;
  const Eigen::Matrix3d mass = chain.transpose() *
                               (kMass * centre_y.transpose() * centre_y +
                                kMass * kL * kL / 12.0 * Eigen::Matrix3d::Identity()) *
                               chain;
  Eigen::Matrix<double, 3, 2> kernel;  // H Z = 0 for H = [1, 2/3, 1/3]
  kernel << -2.0 / 3.0, -1.0 / 3.0, 1, 0, 0, 1;
  const Eigen::Matrix2d reduced_mass = mass.bottomRows<2>() * kernel;
  Eigen::Matrix4d state = Eigen::Matrix4d::Zero();
  state.topRightCorner<2, 2>() = Eigen::Matrix2d::Identity();
  state.bottomLeftCorner<2, 2>() = -kC * reduced_mass.inverse();
  state.bottomRightCorner<2, 2>() = -d * reduced_mass.inverse();
  const Eigen::Vector4cd values = state.eigenvalues();
  std::vector<std::complex<double>> eigenvalues(values.data(), values.data() + values.size());
  SortEigenvalues(eigenvalues);
  return eigenvalues;
}

void CheckHyperbolicUnstable(const Classification& c, double d) {
  CHECK(c.linearization.mass_matrix.rows() == 3);
  CHECK(c.structure.relative_degree == std::vector<int>{2});
  CHECK(c.structure.internal_dynamics_order == 4);
  CHECK(c.zero_dynamics.stability == Stability::kUnstable);
  CHECK_FALSE(c.zero_dynamics.minimum_phase);
  CHECK(c.recommended_solver == SolverMethod::kStableInversion);
  REQUIRE(c.cross_check.has_value());
  CHECK(c.cross_check->agrees);

  const std::vector<std::complex<double>> expected = ExpectedZeroDynamics(d);
  REQUIRE(c.zero_dynamics.eigenvalues.size() == 4);
  double largest = 0.0;
  for (const std::complex<double>& value : expected) largest = std::max(largest, std::abs(value));
  for (std::size_t i = 0; i < expected.size(); ++i) {
    INFO("eigenvalue " << i << ": " << c.zero_dynamics.eigenvalues[i] << ", expected "
                       << expected[i]);
    CHECK(std::abs(c.zero_dynamics.eigenvalues[i] - expected[i]) <= 1e-9 * largest);
    // Hyperbolic: every eigenvalue well off the imaginary axis (the smallest |Re| is ~5 1/s).
    CHECK(std::abs(c.zero_dynamics.eigenvalues[i].real()) >= 1.0);
  }
  CHECK(c.zero_dynamics.eigenvalues.front().real() > 0.0);
}

TEST_CASE("three-link arm: order-4 hyperbolic unstable zero dynamics, index 3", "[analysis]") {
  const Classification c = ClassifyFile(ModelPath("three_link_arm.yaml"));
  CHECK(c.decoupling.realization == Realization::kNonIdealOrthogonal);
  CHECK(c.structure.differentiation_index == 3);
  CheckHyperbolicUnstable(c, 0.25);
  // Two real eigenvalues on each side: a saddle, no oscillatory mode.
  CHECK(c.zero_dynamics.modes.empty());
  CHECK(c.zero_dynamics.eigenvalues[1].real() > 0.0);
  CHECK(c.zero_dynamics.eigenvalues[2].real() < 0.0);
}

TEST_CASE("three-link arm without damping: still hyperbolic, eigenvalues in +- pairs",
          "[analysis]") {
  const Classification c = ClassifyFile(ModelPath("three_link_arm.yaml"), {{"d", "0"}});
  CheckHyperbolicUnstable(c, 0.0);
  // d = 0: the zero dynamics are conservative, lambda and -lambda come together.
  const std::vector<std::complex<double>>& values = c.zero_dynamics.eigenvalues;
  CHECK(std::abs(values[0] + values[3]) <= 1e-9 * std::abs(values[0]));
  CHECK(std::abs(values[1] + values[2]) <= 1e-9 * std::abs(values[0]));
}

}  // namespace
}  // namespace servokit
