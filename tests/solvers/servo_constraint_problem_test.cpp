// The servo-constraint equations every solver integrates, against the paper's closed forms for
// the mass on car (Sect. 3): the normal form gives Eqs. (35)-(36) in case 2, the projected DAE
// (15)-(18) vanishes on the flat solution of case 4 (Eqs. 45-47), and D(q) stays a tangent
// basis that varies continuously with q.
#include "solvers/servo_constraint_problem.h"

#include <catch2/catch.hpp>
#include <cmath>

#include "base/errors.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;

// The mass-on-car parameters of models/mass_on_car.yaml.
constexpr double kM1 = 1.0, kM2 = 2.0, kStiffness = 5.0;

// Paper Fig. 9: y from 0.5 m to 2.5 m in 0-6 s (Eq. 65).
RestToRestTrajectory PaperTrajectory() {
  return RestToRestTrajectory(Eigen::VectorXd::Constant(1, 0.5), Eigen::VectorXd::Constant(1, 2.5),
                              0.0, 6.0);
}

Eigen::VectorXd Vector(std::initializer_list<double> values) {
  Eigen::VectorXd vector(Eigen::Index(values.size()));
  Eigen::Index i = 0;
  for (double value : values) vector(i++) = value;
  return vector;
}

TEST_CASE("the normal form of the mass on car at 5 deg is the paper's Eqs. (35) and (36)",
          "[solvers][paper]") {
  const double damping = 1.0, alpha = 5.0 * M_PI / 180.0;
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "5 deg"}, {"d", "1"}});
  const RestToRestTrajectory trajectory = PaperTrajectory();
  // M, B and H are constant here: once with the shortcut that factors them once, once with
  // the general path that evaluates and factors them at every call.
  const bool exploit = GENERATE(true, false);
  ServoProblemOptions options;
  options.exploit_constant_structure = exploit;
  ServoConstraintProblem problem(model, trajectory, Eigen::VectorXd::Zero(2), options);
  // Eq. (19) with q_u = s: the internal coordinate is the unactuated s.
  REQUIRE(problem.internal_are_unactuated());
  CHECK(problem.internal_directions().isApprox(Vector({0.0, 1.0})));

  for (const double t : {0.7, 2.0, 3.3, 5.1}) {
    const double s = 0.03 * t - 0.05, s_dot = 0.2 - 0.1 * t;
    Eigen::VectorXd q = Eigen::VectorXd::Zero(2), q_dot, u, q_ddot;
    std::string why;
    REQUIRE(problem.StateFromInternal(t, Vector({s}), Vector({s_dot}), q, q_dot, why));
    const double y = trajectory.Derivative(t, 0)(0), y_dot = trajectory.Derivative(t, 1)(0);
    const double y_ddot = trajectory.Derivative(t, 2)(0);
    // Eq. (27) solved for x: x = y - s cos(alpha); its derivative likewise.
    CHECK(q(0) == Approx(y - s * std::cos(alpha)).epsilon(1e-14));
    CHECK(q(1) == Approx(s).epsilon(1e-14));
    CHECK(q_dot(0) == Approx(y_dot - s_dot * std::cos(alpha)).epsilon(1e-13));

    REQUIRE(problem.NormalForm(t, q, q_dot, u, q_ddot, why));
    const double sin2 = std::pow(std::sin(alpha), 2);
    const double spring_damper = kStiffness * s + damping * s_dot;
    // Eq. (35); the 1e-12 is round-off of P^-1, with |P| ~ sin^2(alpha) ~ 8e-3.
    const double force =
        (kM1 + kM2 * sin2) / sin2 * y_ddot + kM1 * std::cos(alpha) * spring_damper / (kM2 * sin2);
    CHECK(u(0) == Approx(force).epsilon(1e-12));
    // Eq. (36): m2 sin^2(alpha) s'' + d s' + k s = -y_d'' m2 cos(alpha).
    const double s_ddot = (-spring_damper - y_ddot * kM2 * std::cos(alpha)) / (kM2 * sin2);
    CHECK(q_ddot(1) == Approx(s_ddot).epsilon(1e-11));
  }
}

TEST_CASE("the projected DAE (15)-(18) vanishes on the flat solution of case 4 (Eqs. 45-47)",
          "[solvers][paper]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}});
  const RestToRestTrajectory trajectory = PaperTrajectory();
  ServoConstraintProblem problem(model, trajectory, Eigen::VectorXd::Zero(2));
  for (const double t : {0.5, 1.9, 3.0, 4.4, 5.8}) {
    Eigen::VectorXd y(6);
    for (int order = 0; order <= 5; ++order) y(order) = trajectory.Derivative(t, order)(0);
    // Eq. (45) and its derivatives: s = -(m2/k) y''; x = y - s (Eq. 27 at alpha = 0).
    const double c = kM2 / kStiffness;
    const Eigen::VectorXd s = Vector({-c * y(2), -c * y(3), -c * y(4), -c * y(5)});
    const double force = (kM1 + kM2) * y(2) + kM1 * kM2 / kStiffness * y(4);  // Eq. (47)
    Eigen::VectorXd x(5), x_dot(5);
    x << y(0) - s(0), s(0), y(1) - s(1), s(1), force;
    x_dot << y(1) - s(1), s(1), y(2) - s(2), s(2), 0.0;
    Eigen::MatrixXd mass;
    Eigen::VectorXd rhs;
    std::string why;
    REQUIRE(problem.ProjectedEquations(t, x, mass, rhs, why));
    // A x' - phi: the algebraic rows (17), (18) are phi alone. Round-off of terms ~ 10.
    CHECK((mass * x_dot - rhs).cwiseAbs().maxCoeff() == Approx(0.0).margin(1e-12));
  }
}

TEST_CASE("the index-1 residual vanishes on the normal form's state and derivative (case 2)",
          "[solvers]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "5 deg"}, {"d", "0"}});
  const RestToRestTrajectory trajectory = PaperTrajectory();
  ServoConstraintProblem problem(model, trajectory, Eigen::VectorXd::Zero(2));
  const double t = 2.5;
  Eigen::VectorXd q = Eigen::VectorXd::Zero(2), q_dot, u, q_ddot, residual;
  std::string why;
  REQUIRE(problem.StateFromInternal(t, Vector({0.01}), Vector({-0.2}), q, q_dot, why));
  REQUIRE(problem.NormalForm(t, q, q_dot, u, q_ddot, why));
  Eigen::VectorXd x(5), x_dot(5);
  x << q, q_dot, u;
  x_dot << q_dot, q_ddot, 0.0;
  REQUIRE(problem.IndexOneResidual(t, x, x_dot, residual, why));
  // Round-off: u ~ 1e3 N here (P ~ 4e-3), so the force rows carry ~1e3 * eps.
  CHECK(residual.cwiseAbs().maxCoeff() == Approx(0.0).margin(1e-10));
  // Only the derivatives of the internal coordinate s (C selects it, Eq. 19) enter, so that the
  // leading term C^T x' does not move with q (BDF needs that): a wrong acceleration of the car
  // is not seen here (Eq. 17 and h = y_d fix it), a wrong s'' is seen one to one.
  x_dot(2) += 1e-3;
  REQUIRE(problem.IndexOneResidual(t, x, x_dot, residual, why));
  CHECK(residual.cwiseAbs().maxCoeff() == Approx(0.0).margin(1e-10));
  x_dot(3) += 1e-3;
  REQUIRE(problem.IndexOneResidual(t, x, x_dot, residual, why));
  CHECK(residual(2) == Approx(1e-3).epsilon(1e-6));
}

TEST_CASE("D(q) stays a tangent basis (H D = 0) that varies continuously along the motion",
          "[solvers]") {
  // The rotational arm's output depends nonlinearly on q, so H(q) turns with q.
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"));
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, 1.0),
                                        0.0, 1.0);
  ServoConstraintProblem problem(model, trajectory, Eigen::VectorXd::Zero(model.dof()));
  Workspace workspace(model);
  Eigen::MatrixXd previous;
  for (int k = 0; k <= 20; ++k) {
    const Eigen::VectorXd q = Eigen::VectorXd::Constant(Eigen::Index(model.dof()), 0.05 * k);
    Evaluate(model, workspace, q, Eigen::VectorXd::Zero(Eigen::Index(model.dof())),
             Quantity::kOutputJacobian);
    const Eigen::MatrixXd tangent = problem.TangentBasisAt(workspace.output_jacobian);
    CHECK((workspace.output_jacobian * tangent).norm() == Approx(0.0).margin(1e-14));
    // Steps of 0.05 rad in q move D by O(0.05), never by a sign flip (|change| ~ 2).
    if (k > 0) CHECK((tangent - previous).norm() < 0.2);
    previous = tangent;
  }
}

TEST_CASE("a trajectory with another number of outputs than the model is refused", "[solvers]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(2), Eigen::VectorXd::Ones(2), 0.0,
                                        1.0);
  CHECK_THROWS_AS(ServoConstraintProblem(model, trajectory, Eigen::VectorXd::Zero(2)), UsageError);
}

TEST_CASE("default servo problem options are valid and bad ones are named", "[solvers]") {
  CHECK_NOTHROW(ServoProblemOptions{}.Validate());
  ServoProblemOptions options;
  options.rank_tolerance = -1.0;
  CHECK_THROWS_WITH(options.Validate(), Catch::Contains("rank_tolerance"));
  options = {};
  options.max_coordinate_iterations = 0;
  CHECK_THROWS_WITH(options.Validate(), Catch::Contains("max_coordinate_iterations"));
}

}  // namespace
}  // namespace servokit
