// Stable inversion (paper Sect. 5.3, Figs. 14-16): the rotational arm with the end-point
// output (s = l, non-minimum phase) moved from 0 to 270 deg between t0 = 1 s and tf = 3 s, and
// checks against the independent linear stable inversion (Devasia et al. 1996).
#include "solvers/stable_inversion.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <string>

#include "base/errors.h"
#include "solvers/internal_dynamics.h"
#include "solvers/linear_stable_inversion.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

constexpr double kT0 = 1.0, kTf = 3.0;

RestToRestTrajectory ArmTrajectory(double angle) {
  return RestToRestTrajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, angle), kT0,
                              kTf);
}

// The equilibrium of the arm with the output at `angle`: alpha = angle, beta = 0 (no spring
// force, no input), exact for Eq. (50).
Eigen::VectorXd ArmAt(double angle) { return Eigen::Vector2d(angle, 0.0); }

// The input of the linear stable inversion at `times` (the independent reference).
std::vector<double> LinearInput(const Model& model,
                                const OutputTrajectory& trajectory,
                                const std::vector<double>& times,
                                double t_a,
                                double t_b) {
  const LinearInternalDynamics linear = LinearizeInternalDynamics(model, ArmAt(0.0));
  const HyperbolicSplit split = SplitHyperbolic(linear.state_matrix);
  auto drive = [&](double t) {
    Eigen::VectorXd outputs(3);
    for (int order = 0; order < 3; ++order) outputs(order) = trajectory.Derivative(t, order)(0);
    return Eigen::VectorXd(outputs - linear.equilibrium_output);
  };
  IntegratorOptions tight;
  tight.rtol = 1e-12;
  tight.atol = 1e-14;
  const LinearStableInversion result = SolveLinearStableInversion(
      split, [&](double t) -> Eigen::VectorXd { return linear.drive_matrix * drive(t); }, t_a, t_b,
      times, {kT0, kTf}, tight);
  REQUIRE(result.summary.IsUsable());
  std::vector<double> inputs;
  for (std::size_t i = 0; i < times.size(); ++i) {
    inputs.push_back((linear.equilibrium_input +
                      linear.input_state * (result.states[i] - linear.equilibrium_state) +
                      linear.input_drive * drive(times[i]))(0));
  }
  return inputs;
}

TEST_CASE("arm end point 0 to 270 deg: bounded, pre-actuated, unchanged when the window grows",
          "[solvers][paper]") {
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"));
  const double angle = 1.5 * M_PI;  // 270 deg
  const RestToRestTrajectory trajectory = ArmTrajectory(angle);
  const StableInversionSolution solution =
      SolveStableInversion(model, trajectory, ArmAt(0.0), ArmAt(angle));
  INFO(solution.summary.message);
  REQUIRE(solution.summary.IsUsable());
  double largest = 0.0, largest_beta = 0.0;
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    largest = std::max(largest, std::abs(solution.u[i](0)));
    largest_beta = std::max(largest_beta, std::abs(solution.q[i](1)));
  }
  WARN("stable inversion 270 deg: window ["
       << solution.window.start << ", " << solution.window.end << "] s, " << solution.times.size()
       << " mesh points, max |T| = " << largest << " N m, max |beta| = " << largest_beta
       << " rad, pre-actuation from " << solution.window.pre_actuation_start << " s, until "
       << solution.window.post_actuation_end << " s");
  CHECK(std::isfinite(largest));
  CHECK(largest_beta < 1.0);  // bounded: the passive joint stays within a radian
  CHECK(solution.window.pre_actuation_start < kT0);  // T nonzero before t0 (Fig. 15)
  CHECK(solution.window.post_actuation_end > kTf);
  CHECK(solution.window.boundary_value_residual <= 1e-8);

  // Widened window: the same answer to the tolerance.
  StableInversionOptions wider;
  wider.pre_actuation = 2.0 * (kT0 - solution.window.start);
  wider.post_actuation = 2.0 * (solution.window.end - kTf);
  const StableInversionSolution widened =
      SolveStableInversion(model, trajectory, ArmAt(0.0), ArmAt(angle), wider);
  REQUIRE(widened.summary.IsUsable());
  // Compare at the first solution's mesh points through the widened one's interpolant.
  double change = 0.0, servo = 0.0;
  Workspace workspace(model);
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    Eigen::VectorXd q, q_dot, u;
    std::string why;
    REQUIRE(widened.extension->Evaluate(solution.times[i], q, q_dot, u, why));
    change = std::max(change, std::abs(u(0) - solution.u[i](0)));
    Evaluate(model, workspace, solution.q[i], solution.q_dot[i], Quantity::kOutput);
    servo = std::max(
        servo, std::abs(workspace.output(0) - trajectory.Derivative(solution.times[i], 0)(0)));
  }
  WARN("window doubled: max |T change| = " << change << " N m");
  // The boundary value tolerance 1e-8 on the residual; the tails left out of the first
  // window are below 1e-8 of the motion's modes by its choice.
  CHECK(change <= 1e-8 * largest);
  CHECK(servo <= 1e-12);  // the servo constraint holds along the solution (Eq. 19)
}

TEST_CASE("a linear model: the boundary value problem equals linear stable inversion to 1e-8",
          "[solvers]") {
  const Model model = LoadModel(TestDataPath("linear_arm.yaml"));
  const double angle = 1.0;
  const RestToRestTrajectory trajectory = ArmTrajectory(angle);
  const StableInversionSolution solution =
      SolveStableInversion(model, trajectory, ArmAt(0.0), ArmAt(angle));
  REQUIRE(solution.summary.IsUsable());
  const std::vector<double> reference =
      LinearInput(model, trajectory, solution.times, solution.window.start, solution.window.end);
  double difference = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    difference = std::max(difference, std::abs(solution.u[i](0) - reference[i]));
    scale = std::max(scale, std::abs(reference[i]));
  }
  WARN("linear model: max |T_bvp - T_linear| / max |T| = " << difference / scale);
  CHECK(difference <= 1e-8 * scale);
}

TEST_CASE(
    "a small motion: nonlinear and linear stable inversion agree to what linearization "
    "explains",
    "[solvers][paper]") {
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"));
  const double angle = 0.5 * M_PI / 180;
  const RestToRestTrajectory trajectory = ArmTrajectory(angle);
  const StableInversionSolution solution =
      SolveStableInversion(model, trajectory, ArmAt(0.0), ArmAt(angle));
  REQUIRE(solution.summary.IsUsable());
  const std::vector<double> reference =
      LinearInput(model, trajectory, solution.times, solution.window.start, solution.window.end);
  double difference = 0.0, scale = 0.0, largest_beta = 0.0;
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    difference = std::max(difference, std::abs(solution.u[i](0) - reference[i]));
    scale = std::max(scale, std::abs(reference[i]));
    largest_beta = std::max(largest_beta, std::abs(solution.q[i](1)));
  }
  WARN("0.5 deg: max |T_nonlinear - T_linear| / max |T| = " << difference / scale
                                                            << ", max |beta| = " << largest_beta);
  // The neglected terms are of second order in the motion (cos beta, beta' alpha' sin beta):
  // relative size ~ the largest angle and rate involved, here ~1e-2 at most.
  CHECK(difference <= 1e-2 * scale);
}

TEST_CASE("undamped zero dynamics are refused, naming the eigenvalues on the axis", "[solvers]") {
  // Arm with d = 0 and the output at s = l/2 (stable side): zero dynamics undamped.
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"), {{"d", "0"}, {"s", "0.5"}});
  const RestToRestTrajectory trajectory = ArmTrajectory(0.1);
  CHECK_THROWS_WITH(SolveStableInversion(model, trajectory, ArmAt(0.0), ArmAt(0.1)),
                    Catch::Contains("imaginary axis"));
}

// A window of 10^6 s at the arm's fastest zero-dynamics rate (some 10 1/s, four time constants
// per mesh interval) would take millions of mesh points: refused before any is allocated, in
// the toolkit's words (it once named BoundaryValueOptions::max_mesh_points, as a usage error).
TEST_CASE("a window too long for its fastest mode is refused before the mesh is built",
          "[solvers]") {
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"));
  StableInversionOptions options;
  options.pre_actuation = 1.0;
  options.post_actuation = 1e6;
  try {
    SolveStableInversion(model, ArmTrajectory(0.5), ArmAt(0.0), ArmAt(0.5), options);
    FAIL("no NoSolution for a window of 10^6 s");
  } catch (const NoSolution& error) {
    const std::string message = error.what();
    INFO(message);
    CHECK(message.find("stable inversion: the window from t = 0 s to 1000003 s") == 0);
    CHECK(message.find("mesh points, more than the 200000 the collocation takes") !=
          std::string::npos);
    CHECK(message.find("max_mesh_points") == std::string::npos);
  }
}

}  // namespace
}  // namespace servokit

namespace servokit {
namespace {

TEST_CASE("a three-link arm with two passive joints (two internal coordinates) is inverted",
          "[solvers]") {
  // models/three_link_arm.yaml: zero dynamics 31.3, 5.27, -5.13, -27.0 /s at rest, so two
  // unstable modes get end conditions and two stable ones start conditions. Output from 0 to
  // 90 deg between t0 = 1 s and tf = 3 s; at rest the passive joints are straight.
  const Model model = LoadModel(testing::ModelPath("three_link_arm.yaml"));
  const double angle = M_PI / 2;
  const RestToRestTrajectory trajectory = ArmTrajectory(angle);
  const StableInversionSolution solution = SolveStableInversion(
      model, trajectory, Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(angle, 0.0, 0.0));
  INFO(solution.summary.message);
  REQUIRE(solution.summary.IsUsable());
  double largest = 0.0, largest_passive = 0.0, servo = 0.0;
  Workspace workspace(model);
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    largest = std::max(largest, std::abs(solution.u[i](0)));
    largest_passive = std::max(largest_passive, solution.q[i].tail(2).cwiseAbs().maxCoeff());
    Evaluate(model, workspace, solution.q[i], solution.q_dot[i], Quantity::kOutput);
    servo = std::max(
        servo, std::abs(workspace.output(0) - trajectory.Derivative(solution.times[i], 0)(0)));
  }
  WARN("three-link arm 90 deg: " << solution.times.size() << " mesh points, max |T| = " << largest
                                 << " N m, max |beta| = " << largest_passive
                                 << " rad, pre-actuation from "
                                 << solution.window.pre_actuation_start << " s");
  CHECK(std::isfinite(largest));
  CHECK(largest_passive < 1.0);
  CHECK(solution.window.pre_actuation_start < kT0);
  CHECK(servo <= 1e-12);  // the servo constraint holds along the solution (Eq. 19)
}

}  // namespace
}  // namespace servokit
