// The linearized internal dynamics with its drive, against closed forms: for the mass on car
// at 5 deg it is Eq. (36) with the input of Eq. (35) (exact, the model is linear); for the
// rotational arm its eigenvalues are the roots of Eq. (56). With it, linear stable inversion of
// the arm's end-point motion is bounded and non-causal (paper Sect. 5.3, Figs. 15-16).
#include "solvers/internal_dynamics.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <complex>

#include "solvers/linear_stable_inversion.h"
#include "tests/test_paths.h"
#include "trajectories/trajectory.h"

namespace servokit {
namespace {

using testing::ModelPath;

TEST_CASE("mass on car at 5 deg: the linear internal dynamics is Eq. (36), the input Eq. (35)",
          "[solvers][paper]") {
  const double m1 = 1.0, m2 = 2.0, k = 5.0, d = 1.0, alpha = 5 * M_PI / 180;
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "5 deg"}});
  const LinearInternalDynamics linear = LinearizeInternalDynamics(model, Eigen::VectorXd::Zero(2));
  const double sin2 = std::pow(std::sin(alpha), 2), cos = std::cos(alpha);
  // x = (s, s'), Y = (y, y', y''): m2 sin^2 s'' + d s' + k s = -y'' m2 cos (Eq. 36).
  Eigen::MatrixXd state_matrix(2, 2);
  state_matrix << 0, 1, -k / (m2 * sin2), -d / (m2 * sin2);
  Eigen::MatrixXd drive_matrix = Eigen::MatrixXd::Zero(2, 3);
  drive_matrix(1, 2) = -cos / sin2;
  // Eq. (35): F = (m1 + m2 sin^2)/sin^2 y'' + m1 cos (k s + d s') / (m2 sin^2).
  Eigen::MatrixXd input_state(1, 2), input_drive = Eigen::MatrixXd::Zero(1, 3);
  input_state << m1 * cos * k / (m2 * sin2), m1 * cos * d / (m2 * sin2);
  input_drive(0, 2) = (m1 + m2 * sin2) / sin2;
  // Central differences of a linear map: round-off only, relative to entries ~ 1e2.
  CHECK((linear.state_matrix - state_matrix).norm() <= 1e-7 * state_matrix.norm());
  CHECK((linear.drive_matrix - drive_matrix).norm() <= 1e-7 * drive_matrix.norm());
  CHECK((linear.input_state - input_state).norm() <= 1e-7 * input_state.norm());
  CHECK((linear.input_drive - input_drive).norm() <= 1e-7 * input_drive.norm());
  CHECK(linear.equilibrium_input.norm() == Approx(0.0).margin(1e-12));
}

TEST_CASE(
    "rotational arm at s = l: the internal dynamics' eigenvalues are the roots of "
    "Eq. (56)",
    "[solvers][paper]") {
  const double l = 1.0, m = 3.438, c = 50.0, d = 0.25, s = 1.0;  // paper Table 2
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"));
  const LinearInternalDynamics linear =
      LinearizeInternalDynamics(model, Eigen::VectorXd::Zero(Eigen::Index(model.dof())));
  // Eq. (56): m l^2 (2l - 3s) lambda^2 + 6 d (s + l) lambda + 6 c (s + l) = 0.
  const double a2 = m * l * l * (2 * l - 3 * s), a1 = 6 * d * (s + l), a0 = 6 * c * (s + l);
  const double root = std::sqrt(a1 * a1 - 4 * a2 * a0);  // a2 < 0: real, opposite signs
  const double expected_low = (-a1 + root) / (2 * a2), expected_high = (-a1 - root) / (2 * a2);
  Eigen::VectorXcd eigenvalues = linear.state_matrix.eigenvalues();
  std::vector<double> found = {eigenvalues(0).real(), eigenvalues(1).real()};
  std::sort(found.begin(), found.end());
  CHECK(found[0] == Approx(std::min(expected_low, expected_high)).epsilon(1e-6));
  CHECK(found[1] == Approx(std::max(expected_low, expected_high)).epsilon(1e-6));
}

TEST_CASE("linear stable inversion of the arm's end-point motion is bounded and starts early",
          "[solvers][paper]") {
  // Paper Sect. 5.3: output from 0 to a small angle between t0 = 1 s and tf = 3 s; the
  // unstable zero dynamics (eigenvalue ~ +13.7/s at s = l) make the bounded input start before
  // t0 (pre-actuation) and the stable one (~ -12.8/s) make it end after tf.
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"));
  const LinearInternalDynamics linear =
      LinearizeInternalDynamics(model, Eigen::VectorXd::Zero(Eigen::Index(model.dof())));
  const HyperbolicSplit split = SplitHyperbolic(linear.state_matrix);
  REQUIRE(split.unstable_basis.cols() == 1);
  const double angle = 0.5 * M_PI / 180, t0 = 1.0, tf = 3.0;
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1),
                                        Eigen::VectorXd::Constant(1, angle), t0, tf);
  auto drive = [&](double t) {
    Eigen::VectorXd outputs(3);
    for (int order = 0; order < 3; ++order) outputs(order) = trajectory.Derivative(t, order)(0);
    return outputs;
  };
  std::vector<double> times;
  for (int n = 0; n <= 400; ++n) times.push_back(0.0 + 4.0 * n / 400.0);
  const LinearStableInversion result = SolveLinearStableInversion(
      split,
      [&](double t) -> Eigen::VectorXd {
        return linear.drive_matrix * (drive(t) - linear.equilibrium_output);
      },
      0.0, 4.0, times, {t0, tf});
  REQUIRE(result.summary.IsUsable());
  double before = 0.0, during = 0.0, largest = 0.0;
  for (std::size_t i = 0; i < times.size(); ++i) {
    const Eigen::VectorXd input =
        linear.equilibrium_input +
        linear.input_state * (result.states[i] - linear.equilibrium_state) +
        linear.input_drive * (drive(times[i]) - linear.equilibrium_output);
    largest = std::max(largest, input.cwiseAbs().maxCoeff());
    if (times[i] < t0 - 0.05) before = std::max(before, std::abs(input(0)));
    if (times[i] > t0 && times[i] < tf) during = std::max(during, std::abs(input(0)));
  }
  CHECK(std::isfinite(largest));
  CHECK(largest == Approx(during));  // the largest torque is during the motion, bounded
  // Pre-actuation: 50 ms before t0 the torque is already e^(-13.7 * 0.05) ~ half-scale of its
  // value at t0, far from zero.
  CHECK(before > 1e-3 * during);
  // At t = 0 (one second early) it has decayed like e^(-13.7 s): below 1e-5 of its scale.
  const Eigen::VectorXd first = linear.input_state * (result.states[0] - linear.equilibrium_state);
  CHECK(std::abs(first(0)) < 1e-5 * during);
}

}  // namespace
}  // namespace servokit
