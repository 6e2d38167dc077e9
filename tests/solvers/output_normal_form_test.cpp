// The input-output normal form of any vector relative degree (`normal-form` when P is
// singular): accuracy against references derived without servokit.
//
// - Flat problems (internal order 0): the normal form is the algebraic inverse; paper case 4
//   gives Eq. (47).
// - A linear three-mass chain, force on mass 1, output mass 2 (tests/data/
//   three_mass_chain_middle_output.yaml): relative degree 3, stable internal dynamics of order
//   3, against the exact solution of its internal dynamics (below).
// - A flexible-joint arm (tests/data/flexible_joint_arm.yaml): flat, relative degree 4, through
//   every method that accepts it, against its closed form.
// - The chain observed at x2 - 2 x3: unstable internal dynamics, stable inversion of the
//   input-output normal form against the exact bounded inverse.
#include <Eigen/Eigenvalues>
#include <catch2/catch.hpp>
#include <cmath>
#include <complex>
#include <vector>

#include "analysis/classification.h"
#include "base/errors.h"
#include "solvers/inverse_model.h"
#include "solvers/method_choice.h"
#include "solvers/verification.h"
#include "tests/solvers/solve_support.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

using Problem = testing::ClassifiedModel;

Problem Load(const std::string& path, const std::vector<ParameterOverride>& set = {}) {
  return testing::LoadClassified(path, set);
}

FeedforwardSolution Solve(const Problem& problem,
                          const OutputTrajectory& trajectory,
                          SolverMethod method,
                          double t_end) {
  return testing::SolveUsable(problem, trajectory, method, t_end);
}

double InputAt(const FeedforwardSolution& solution, double t) {
  return testing::InputAt(solution, t)(0);
}

// max over a fine grid of |u - reference(t)| / max |reference|.
template <typename Reference>
double RelativeInputError(const FeedforwardSolution& solution,
                          Reference&& reference,
                          double t_start,
                          double t_end) {
  double error = 0, scale = 0;
  for (int k = 0; k <= 4000; ++k) {
    const double t = t_start + (t_end - t_start) * k / 4000.0;
    const double expected = reference(t);
    error = std::max(error, std::abs(InputAt(solution, t) - expected));
    scale = std::max(scale, std::abs(expected));
  }
  return error / scale;
}

TEST_CASE("flat problems through normal-form equal the algebraic inverse", "[solvers][paper]") {
  SECTION("paper case 4: Eq. (47)") {
    const Problem problem = Load(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}});
    const RestToRestTrajectory trajectory(Eigen::VectorXd::Constant(1, 0.5),
                                          Eigen::VectorXd::Constant(1, 2.5), 0.0, 6.0);
    const FeedforwardSolution solution =
        Solve(problem, trajectory, SolverMethod::kNormalForm, 10.0);
    REQUIRE(solution.summary.IsUsable());
    // Eq. (47): F = (m1 + m2) y'' + m1 m2 / k y''''.
    const double error = RelativeInputError(
        solution,
        [&](double t) {
          return 3.0 * trajectory.Derivative(t, 2)(0) + 2.0 / 5.0 * trajectory.Derivative(t, 4)(0);
        },
        0.0, 10.0);
    CHECK(error <= 1e-10);
  }
  SECTION("six-mass chain: relative degree 12") {
    const Problem problem = Load(ModelPath("mass_spring_chain.yaml"));
    const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 0.0,
                                          3.0, 12);
    const FeedforwardSolution normal_form =
        Solve(problem, trajectory, SolverMethod::kNormalForm, 4.0);
    const FeedforwardSolution algebraic = Solve(problem, trajectory, SolverMethod::kAlgebraic, 4.0);
    REQUIRE(normal_form.summary.IsUsable());
    REQUIRE(algebraic.summary.IsUsable());
    const double error = RelativeInputError(
        normal_form, [&](double t) { return InputAt(algebraic, t); }, 0.0, 4.0);
    CHECK(error <= 1e-10);
  }
}

// The three-mass chain with y = x2 given: the first mass follows from the second mass's
// equation and the third mass from its own,
//   c x1' = m2 y'' + 2 c y' + 2 k y - k x1 - k x3 - c x3',   m3 x3'' = k (y - x3) + c (y' - x3'),
// a linear system xi' = A xi + G w with xi = (x1, x3, x3') and w = (y, y', y''). For a
// polynomial w its exact solution is xi_p + e^(A (t - t0)) (xi(t0) - xi_p(t0)) with the
// polynomial particular solution xi_p = -sum_j A^-(j+1) G w^(j); after tf, w is constant.
// Then F = m1 x1'' + k (x1 - y) + c (x1' - y'). The exponential is taken from A's
// eigendecomposition (Eigen), nothing from servokit.
struct ChainReference {
  double m1 = 1.0, m2 = 2.0, m3 = 1.5, k = 50.0, c = 2.0;
  const RestToRestTrajectory& trajectory;
  double t0, tf;
  Eigen::Matrix3d a;
  Eigen::Matrix3d g;
  Eigen::Vector3d state_at_tf;

  ChainReference(const RestToRestTrajectory& y, double start, double end, double damping = 2.0)
      : c(damping), trajectory(y), t0(start), tf(end) {
    a << -k / c, -k / c, -1.0,  //
        0.0, 0.0, 1.0,          //
        0.0, -k / m3, -c / m3;
    g << 2 * k / c, 2.0, m2 / c,  //
        0.0, 0.0, 0.0,            //
        k / m3, c / m3, 0.0;
    state_at_tf = Moving(tf);
  }
  Eigen::Vector3d W(double t, int order) const {
    return Eigen::Vector3d(trajectory.Derivative(t, order)(0),
                           trajectory.Derivative(t, order + 1)(0),
                           trajectory.Derivative(t, order + 2)(0));
  }
  Eigen::Vector3d Particular(double t) const {
    const Eigen::Matrix3d inverse = a.inverse();
    Eigen::Matrix3d power = inverse;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int j = 0; j <= 12; ++j, power = power * inverse) sum -= power * g * W(t, j);
    return sum;
  }
  Eigen::Matrix3d Exponential(double tau) const {
    const Eigen::EigenSolver<Eigen::Matrix3d> solver(a);
    const Eigen::Matrix3cd v = solver.eigenvectors();
    Eigen::Vector3cd exponentials;
    for (int i = 0; i < 3; ++i) exponentials[i] = std::exp(solver.eigenvalues()[i] * tau);
    return (v * exponentials.asDiagonal() * v.inverse()).real();
  }
  Eigen::Vector3d Moving(double t) const {
    const double y0 = trajectory.Derivative(t0, 0)(0);
    const Eigen::Vector3d rest(y0, y0, 0.0);
    return Particular(t) + Exponential(t - t0) * (rest - Particular(t0));
  }
  Eigen::Vector3d State(double t) const {
    if (t <= tf) return Moving(t);
    const Eigen::Vector3d held = -a.inverse() * g * W(tf, 0);  // w = (yf, 0, 0) after tf
    return held + Exponential(t - tf) * (state_at_tf - held);
  }
  double Force(double t) const {
    const Eigen::Vector3d xi = State(t);
    const Eigen::Vector3d w = W(std::min(t, tf), 0);
    const double y = w[0], y_dot = t < tf ? w[1] : 0.0, y_ddot = t < tf ? w[2] : 0.0;
    const double y_dddot = t < tf ? trajectory.Derivative(t, 3)(0) : 0.0;
    const Eigen::Vector3d xi_dot = a * xi + g * Eigen::Vector3d(y, y_dot, y_ddot);
    const double x1_ddot = (m2 * y_dddot + 2 * c * y_ddot + 2 * k * y_dot - k * xi_dot[0] -
                            k * xi_dot[1] - c * xi_dot[2]) /
                           c;
    return m1 * x1_ddot + k * (xi[0] - y) + c * (xi_dot[0] - y_dot);
  }
};

TEST_CASE("tangential chain, relative degree 3: normal-form within 1e-8 of the exact inverse",
          "[solvers]") {
  const Problem problem = Load(TestDataPath("three_mass_chain_middle_output.yaml"));
  REQUIRE(problem.classification.structure.relative_degree == std::vector<int>{3});
  REQUIRE(problem.classification.structure.internal_dynamics_order == 3);
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 0.0,
                                        2.0);
  const FeedforwardSolution solution = Solve(problem, trajectory, SolverMethod::kAuto, 4.0);
  REQUIRE(solution.summary.IsUsable());
  CHECK(solution.method == SolverMethod::kNormalForm);
  const ChainReference reference(trajectory, 0.0, 2.0);
  const double error = RelativeInputError(
      solution, [&](double t) { return reference.Force(t); }, 0.0, 4.0);
  WARN("three-mass chain, normal form: " << solution.summary.steps
                                         << " steps, max |u - exact| / max |u| = " << error);
  CHECK(error <= 1e-8);
  CHECK(VerifyFeedforward(problem.model, trajectory, solution).passed);
}

// The same chain with dampers of 0.001 N s/m: x1's internal mode decays at k/c = 5e4 /s, so
// Dormand-Prince would need ~6e4 steps for stability alone; the normal form switches to
// CVODE's BDF, and stays within its accuracy.
TEST_CASE("stiff internal dynamics: the normal form integrates them with BDF, to rtol",
          "[solvers]") {
  Problem problem = Load(TestDataPath("three_mass_chain_middle_output.yaml"), {{"c", "0.001"}});
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 0.0,
                                        2.0);
  const FeedforwardSolution solution = Solve(problem, trajectory, SolverMethod::kAuto, 4.0);
  REQUIRE(solution.summary.IsUsable());
  CHECK(solution.method == SolverMethod::kNormalForm);
  CHECK_THAT(solution.method_reason, Catch::Contains("CVODE's BDF"));
  CHECK(solution.summary.steps < 5000);
  const ChainReference reference(trajectory, 0.0, 2.0, 0.001);
  // The internal state to the tolerance (x1, x3 at the rows, against max |x|, ~1 m).
  double state_error = 0.0;
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    const Eigen::Vector3d exact = reference.State(solution.times[i]);
    state_error = std::max({state_error, std::abs(solution.q[i](0) - exact[0]),
                            std::abs(solution.q[i](2) - exact[1])});
  }
  // u reads x1'' = (... - k x1' ...) / c: a state error reaches u amplified by up to
  // (k/c)^2 m1 / max|u| (here ~1e8), the inverse's own conditioning, not the integrator's.
  const double error = RelativeInputError(
      solution, [&](double t) { return reference.Force(t); }, 0.0, 4.0);
  WARN("stiff chain, BDF: " << solution.summary.steps << " steps, max |x - exact| = " << state_error
                            << ", max |u - exact| / max |u| = " << error);
  CHECK(state_error <= 1e-9);
  CHECK(error <= 1e-6);
  CHECK(VerifyFeedforward(problem.model, trajectory, solution).passed);
}

// A nonlinear tangential chain (tests/data/three_mass_chain_cubic_spring.yaml): no closed
// form, so the forward simulation of --verify is the independent check; its error must fall
// with the tolerance (Radau IIA's input stayed at ~2e-3 whatever rtol, being O(h^2)).
TEST_CASE("cubic-spring chain: the normal form converges with rtol", "[solvers]") {
  const Problem problem = Load(TestDataPath("three_mass_chain_cubic_spring.yaml"));
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 0.0,
                                        2.0);
  std::vector<double> errors;
  for (const double rtol : {1e-6, 1e-10}) {
    InverseModelOptions options;
    options.t_end = 4.0;
    options.rtol = rtol;
    const FeedforwardSolution solution =
        SolveInverseModel(problem.model, trajectory, problem.classification, options);
    REQUIRE(solution.summary.IsUsable());
    CHECK(solution.method == SolverMethod::kNormalForm);
    const Verification check = VerifyFeedforward(problem.model, trajectory, solution);
    CHECK(check.passed);
    errors.push_back(check.max_tracking_error);
  }
  WARN("cubic-spring chain: --verify " << errors[0] << " at rtol 1e-6, " << errors[1]
                                       << " at 1e-10");
  CHECK(errors[1] <= 1e-8);
  CHECK(errors[1] <= 1e-3 * errors[0]);
}

// Flexible-joint arm, y = q1: Il y'' + m g lc sin(y) = k (q2 - y) gives
// q2 = y + (Il y'' + m g lc sin y) / k, and the motor's equation gives
// tau = Jm q2'' + Il y'' + m g lc sin y, with
// q2'' = y'' + (Il y'''' + m g lc (cos(y) y'' - sin(y) y'^2)) / k.
TEST_CASE("flexible-joint arm through every method that accepts it", "[solvers]") {
  const Problem problem = Load(TestDataPath("flexible_joint_arm.yaml"));
  const double il = 0.05, jm = 0.02, mgl = 0.5 * 9.81 * 0.2, k = 20.0;
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, 1.0),
                                        0.0, 1.5);
  const auto torque = [&](double t) {
    const double y = trajectory.Derivative(t, 0)(0), y1 = trajectory.Derivative(t, 1)(0),
                 y2 = trajectory.Derivative(t, 2)(0), y4 = trajectory.Derivative(t, 4)(0);
    const double q2_ddot = y2 + (il * y4 + mgl * (std::cos(y) * y2 - std::sin(y) * y1 * y1)) / k;
    return jm * q2_ddot + il * y2 + mgl * std::sin(y);
  };
  MethodChooser chooser(problem.model, problem.classification, false);
  std::vector<SolverMethod> accepted;
  for (const SolverMethod method : MethodsInOrderOfPreference()) {
    if (!chooser.Assess(method).accepts) continue;
    accepted.push_back(method);
    INFO(ToString(method));
    const FeedforwardSolution solution = Solve(problem, trajectory, method, 2.5);
    REQUIRE(solution.summary.IsUsable());
    const double error = RelativeInputError(solution, torque, 0.0, 2.5);
    WARN(ToString(method) << ": max |tau - closed form| / max |tau| = " << error);
    // Exact methods to their tolerance; Radau IIA's index-3 input to O(h^2), Euler backward's
    // (1 ms) to O(h).
    const bool exact = method == SolverMethod::kAlgebraic || method == SolverMethod::kNormalForm;
    CHECK(error <= (exact ? 1e-8 : method == SolverMethod::kRadau ? 1e-3 : 2e-2));
    CHECK(VerifyFeedforward(problem.model, trajectory, solution).passed);
  }
  CHECK(accepted == std::vector<SolverMethod>{SolverMethod::kAlgebraic, SolverMethod::kNormalForm,
                                              SolverMethod::kRadau, SolverMethod::kEuler});
}

// The three-mass chain observed at y = x2 + gamma x3 with gamma = -2
// (tests/data/three_mass_chain_unstable_output.yaml): tangential, relative degree 3, internal
// dynamics xi = (x1, x3, x3') with x2 = y - gamma x3:
//   m3 x3'' = k (y - (1 + gamma) x3) + c (y' - (1 + gamma) x3'),
//   c x1'   = m2 (y'' - gamma x3'') - k x1 + 2 k (y - gamma x3) + 2 c (y' - gamma x3') - k x3 - c
//   x3',
// i.e. xi' = A xi + G w, w = (y, y', y''). Its bounded solution, mode by mode in A's
// eigenvectors (eta' = lambda eta + g): on each piece of w (rest before t0, the polynomial, rest
// after tf) the polynomial particular solution p = -sum_j lambda^-(j+1) g^(j), joined by
// e^(lambda (t - a)) to the value at the piece's end from which the mode is bounded: stable
// modes forward from rest at -infinity, unstable ones backward from rest at +infinity. Then
// F = m1 x1'' + k (x1 - x2) + c (x1' - x2'), x1'' = A_0 xi' + G_0 w'. Eigen only.
struct UnstableChainReference {
  double m1 = 1.0, m2 = 2.0, m3 = 1.5, k = 50.0, c = 2.0, gamma = -2.0;
  const RestToRestTrajectory& trajectory;
  double t0, tf;
  Eigen::Matrix3d a, g;
  Eigen::Matrix3cd v, v_inverse;
  Eigen::Vector3cd lambda;

  UnstableChainReference(const RestToRestTrajectory& y, double start, double end)
      : trajectory(y), t0(start), tf(end) {
    const Eigen::RowVector3d a2(0.0, -k * (1 + gamma) / m3, -c * (1 + gamma) / m3);
    const Eigen::RowVector3d g2(k / m3, c / m3, 0.0);
    a.row(2) = a2;
    g.row(2) = g2;
    a.row(1) << 0.0, 0.0, 1.0;
    g.row(1).setZero();
    a.row(0) =
        Eigen::RowVector3d(-k, -2 * k * gamma - k, -2 * c * gamma - c) / c - m2 * gamma / c * a2;
    g.row(0) = Eigen::RowVector3d(2 * k, 2 * c, m2) / c - m2 * gamma / c * g2;
    const Eigen::EigenSolver<Eigen::Matrix3d> solver(a);
    v = solver.eigenvectors();
    v_inverse = v.inverse();
    lambda = solver.eigenvalues();
  }
  // w^(order) at t inside the motion (the polynomial), or at rest outside it.
  Eigen::Vector3d W(double t, int order) const {
    Eigen::Vector3d w;
    for (int i = 0; i < 3; ++i) w[i] = trajectory.Derivative(t, order + i)(0);
    return w;
  }
  // The particular solution of mode i on the motion's piece at t.
  std::complex<double> Particular(int i, double t) const {
    std::complex<double> sum = 0, power = 1.0 / lambda[i];
    for (int j = 0; j <= 14; ++j, power /= lambda[i]) {
      sum -= power * (v_inverse.row(i) * (g * W(t, j)).cast<std::complex<double>>())(0);
    }
    return sum;
  }
  std::complex<double> RestParticular(int i, double y) const {
    return -(v_inverse.row(i) * (g * Eigen::Vector3d(y, 0, 0)).cast<std::complex<double>>())(0) /
           lambda[i];
  }
  Eigen::Vector3d State(double t) const {
    const double y0 = trajectory.Derivative(t0 - 1, 0)(0), yf = trajectory.Derivative(tf + 1, 0)(0);
    Eigen::Vector3cd eta;
    for (int i = 0; i < 3; ++i) {
      const std::complex<double> before = RestParticular(i, y0), after = RestParticular(i, yf);
      if (lambda[i].real() < 0) {
        const std::complex<double> at_tf =
            Particular(i, tf) + std::exp(lambda[i] * (tf - t0)) * (before - Particular(i, t0));
        eta[i] = t <= t0   ? before
                 : t <= tf ? Particular(i, t) +
                                 std::exp(lambda[i] * (t - t0)) * (before - Particular(i, t0))
                           : after + std::exp(lambda[i] * (t - tf)) * (at_tf - after);
      } else {
        const std::complex<double> at_t0 =
            Particular(i, t0) + std::exp(lambda[i] * (t0 - tf)) * (after - Particular(i, tf));
        eta[i] = t >= tf   ? after
                 : t >= t0 ? Particular(i, t) +
                                 std::exp(lambda[i] * (t - tf)) * (after - Particular(i, tf))
                           : before + std::exp(lambda[i] * (t - t0)) * (at_t0 - before);
      }
    }
    return (v * eta).real();
  }
  double Force(double t) const {
    const bool moving = t > t0 && t < tf;
    const Eigen::Vector3d xi = State(t);
    const Eigen::Vector3d w =
        moving ? W(t, 0) : Eigen::Vector3d(trajectory.Derivative(t, 0)(0), 0, 0);
    const Eigen::Vector3d w_dot = moving ? W(t, 1) : Eigen::Vector3d::Zero();
    const Eigen::Vector3d xi_dot = a * xi + g * w;
    const double x1_ddot = a.row(0).dot(xi_dot) + g.row(0).dot(w_dot);
    const double x2 = w[0] - gamma * xi[1], x2_dot = w[1] - gamma * xi[2];
    return m1 * x1_ddot + k * (xi[0] - x2) + c * (xi_dot[0] - x2_dot);
  }
};

TEST_CASE(
    "tangential chain with unstable internal dynamics: stable inversion is bounded, "
    "non-causal and within 1e-8 of the exact bounded inverse",
    "[solvers]") {
  const Problem problem = Load(TestDataPath("three_mass_chain_unstable_output.yaml"));
  REQUIRE(problem.classification.decoupling.rank == 0);  // tangential
  REQUIRE(problem.classification.zero_dynamics.stability == Stability::kUnstable);
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 0.0,
                                        2.0);
  InverseModelOptions options;
  options.t_end = 8.0;
  const FeedforwardSolution solution =
      SolveInverseModel(problem.model, trajectory, problem.classification, options);
  REQUIRE(solution.summary.IsUsable());
  CHECK(solution.method == SolverMethod::kStableInversion);
  REQUIRE(solution.window);
  // Non-causal: the force starts before the motion (the unstable mode 6.48/s needs
  // ln(1e8)/6.48 = 2.8 s of pre-actuation to start from rest at the tolerance).
  CHECK(solution.window->pre_actuation_start < -1.0);
  const UnstableChainReference reference(trajectory, 0.0, 2.0);
  const double error = RelativeInputError(
      solution, [&](double t) { return reference.Force(t); }, solution.t_start, 8.0);
  double largest = 0;
  for (const Eigen::VectorXd& u : solution.u) largest = std::max(largest, u.cwiseAbs().maxCoeff());
  WARN("unstable chain, stable inversion: "
       << solution.summary.steps << " mesh points, window [" << solution.window->start << ", "
       << solution.window->end << "], max |u - exact| / max |u| = " << error
       << ", max |u| = " << largest);
  CHECK(error <= 1e-8);
  CHECK(std::abs(reference.Force(solution.t_start)) <= 1e-6 * largest);  // bounded, at rest
  CHECK(VerifyFeedforward(problem.model, trajectory, solution).passed);
}

}  // namespace
}  // namespace servokit
