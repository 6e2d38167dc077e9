// models/three_link_arm.yaml checked against the mechanics, independently of its expressions:
// the three uniform rods are built here from their kinematics (rod centres and absolute angles
// as functions of q = [alpha, beta1, beta2]), M is assembled from their Jacobians, and the
// Coriolis/centrifugal forces come from Lagrange's equations by finite differences of that M.
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <complex>
#include <random>
#include <string>
#include <vector>

#include "modeling/model.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;

struct ArmParameters {
  double l, m, c, d;
};

ArmParameters ParametersOf(const Model& model, const Workspace& workspace) {
  const auto value = [&](const char* name) {
    return workspace.parameters(static_cast<Eigen::Index>(*model.FindParameter(name)));
  };
  return {value("l"), value("m"), value("c"), value("d")};
}

// Rod centres (x, y) and absolute link angles of the chain: link k starts at the end of link
// k-1 and turns by q_k relative to it. Templated so that it runs on complex numbers too.
template <typename Scalar>
struct Kinematics {
  std::array<std::array<Scalar, 2>, 3> centre;
  std::array<Scalar, 3> angle;
};

template <typename Scalar>
Kinematics<Scalar> Chain(const std::array<Scalar, 3>& q, double l) {
  Kinematics<Scalar> k;
  Scalar joint_x = 0.0, joint_y = 0.0, angle = 0.0;
  for (std::size_t i = 0; i < 3; ++i) {
    angle += q[i];
    k.angle[i] = angle;
    k.centre[i] = {joint_x + 0.5 * l * cos(angle), joint_y + 0.5 * l * sin(angle)};
    joint_x += l * cos(angle);
    joint_y += l * sin(angle);
  }
  return k;
}

// M = sum over links of m J_c^T J_c + (m l^2/12) J_th^T J_th. The Jacobians are taken by the
// complex step, d g/d q_j = Im g(q + i h e_j) / h, exact to rounding (no subtractive error).
Eigen::Matrix3d IndependentMassMatrix(const Eigen::Vector3d& q, const ArmParameters& p) {
  constexpr double kStep = 1e-30;
  std::array<Eigen::Matrix<double, 2, 3>, 3> centre_jacobian;
  std::array<Eigen::RowVector3d, 3> angle_jacobian;
  for (int j = 0; j < 3; ++j) {
    std::array<std::complex<double>, 3> perturbed{q(0), q(1), q(2)};
    perturbed[static_cast<std::size_t>(j)] += std::complex<double>(0.0, kStep);
    const Kinematics<std::complex<double>> k = Chain(perturbed, p.l);
    for (std::size_t link = 0; link < 3; ++link) {
      centre_jacobian[link](0, j) = k.centre[link][0].imag() / kStep;
      centre_jacobian[link](1, j) = k.centre[link][1].imag() / kStep;
      angle_jacobian[link](j) = k.angle[link].imag() / kStep;
    }
  }
  Eigen::Matrix3d mass = Eigen::Matrix3d::Zero();
  const double rod_inertia = p.m * p.l * p.l / 12.0;
  for (std::size_t link = 0; link < 3; ++link) {
    mass += p.m * centre_jacobian[link].transpose() * centre_jacobian[link] +
            rod_inertia * angle_jacobian[link].transpose() * angle_jacobian[link];
  }
  return mass;
}

// Lagrange: d/dt(M q') - dT/dq = M q'' + (dM/dt q' - 1/2 d(q'^T M q')/dq). The bracket is the
// Coriolis/centrifugal vector; both derivatives by central differences of IndependentMassMatrix.
Eigen::Vector3d IndependentCoriolis(const Eigen::Vector3d& q,
                                    const Eigen::Vector3d& q_dot,
                                    const ArmParameters& p) {
  // Step 1e-5: truncation ~ h^2 |M'''| ~ 1e-9, rounding ~ eps |M| / h ~ 1e-10 (|M| ~ 30).
  constexpr double kStep = 1e-5;
  Eigen::Matrix3d mass_rate = Eigen::Matrix3d::Zero();  // dM/dt = sum_k dM/dq_k q_k'
  Eigen::Vector3d energy_gradient;                      // d(q'^T M q')/dq
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d step = kStep * Eigen::Vector3d::Unit(k);
    const Eigen::Matrix3d dmass =
        (IndependentMassMatrix(q + step, p) - IndependentMassMatrix(q - step, p)) / (2 * kStep);
    mass_rate += dmass * q_dot(k);
    energy_gradient(k) = q_dot.dot(dmass * q_dot);
  }
  return mass_rate * q_dot - 0.5 * energy_gradient;
}

std::vector<Eigen::Vector3d> RandomVectors(int count, double bound, unsigned seed) {
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> uniform(-bound, bound);
  std::vector<Eigen::Vector3d> vectors;
  for (int i = 0; i < count; ++i) {
    vectors.emplace_back(uniform(generator), uniform(generator), uniform(generator));
  }
  return vectors;
}

// Nominal (paper Table 2) and a set where every parameter differs, so that a wrong power of
// l or m, or c and d swapped, cannot pass.
const std::vector<std::vector<ParameterOverride>> kParameterSets = {
    {}, {{"l", "0.7"}, {"m", "2.1"}, {"c", "30"}, {"d", "0.4"}}};

TEST_CASE("three-link arm: nominal parameters are the paper's Table 2", "[models]") {
  const Model model = LoadModel(ModelPath("three_link_arm.yaml"));
  const Workspace workspace(model);
  const ArmParameters p = ParametersOf(model, workspace);
  CHECK(model.dof() == 3);
  CHECK(p.l == 1.0);
  CHECK(p.m == 3.438);
  CHECK(p.c == 50.0);
  CHECK(p.d == 0.25);
}

TEST_CASE("three-link arm: M equals the rods' m J_c^T J_c + m l^2/12 J_th^T J_th", "[models]") {
  for (const auto& overrides : kParameterSets) {
    const Model model = LoadModel(ModelPath("three_link_arm.yaml"), overrides);
    Workspace workspace(model);
    const ArmParameters p = ParametersOf(model, workspace);
    for (const Eigen::Vector3d& q : RandomVectors(20, M_PI, 7u)) {
      Evaluate(model, workspace, q, Eigen::Vector3d::Zero(), Quantity::kMassMatrix);
      const Eigen::Matrix3d expected = IndependentMassMatrix(q, p);
      INFO("q = " << q.transpose());
      // Complex-step M is exact to rounding; 1e-8 leaves room for both evaluation orders.
      CHECK((workspace.mass_matrix - expected).cwiseAbs().maxCoeff() <= 1e-8);
    }
  }
}

TEST_CASE("three-link arm: f is Lagrange's Coriolis/centrifugal vector plus the joint torques",
          "[models]") {
  for (const auto& overrides : kParameterSets) {
    const Model model = LoadModel(ModelPath("three_link_arm.yaml"), overrides);
    Workspace workspace(model);
    const ArmParameters p = ParametersOf(model, workspace);
    const std::vector<Eigen::Vector3d> positions = RandomVectors(20, M_PI, 11u);
    const std::vector<Eigen::Vector3d> velocities = RandomVectors(20, 3.0, 13u);
    for (std::size_t i = 0; i < positions.size(); ++i) {
      const Eigen::Vector3d& q = positions[i];
      const Eigen::Vector3d& q_dot = velocities[i];
      Evaluate(model, workspace, q, q_dot, Quantity::kForces);
      const Eigen::Vector3d joint_torques(0.0, p.c * q(1) + p.d * q_dot(1),
                                          p.c * q(2) + p.d * q_dot(2));
      const Eigen::Vector3d expected = IndependentCoriolis(q, q_dot, p) + joint_torques;
      INFO("q = " << q.transpose() << ", q_dot = " << q_dot.transpose());
      // Finite differences of M with step 1e-5 are good to ~1e-9 relative; |q_dot|^2 |M'| is
      // at most ~1e3 here, so 1e-6 is a few hundred times the error and far below any wrong term.
      CHECK((workspace.forces - expected).cwiseAbs().maxCoeff() <= 1e-6);
    }
    // At rest only the springs act.
    const Eigen::Vector3d q(0.3, -0.5, 0.8);
    Evaluate(model, workspace, q, Eigen::Vector3d::Zero(), Quantity::kForces);
    CHECK((workspace.forces - Eigen::Vector3d(0.0, p.c * q(1), p.c * q(2))).norm() <= 1e-12);
  }
}

TEST_CASE(
    "three-link arm: torque on joint 1 only; the output is the end-point angle to first "
    "order",
    "[models]") {
  const Model model = LoadModel(ModelPath("three_link_arm.yaml"));
  Workspace workspace(model);
  const ArmParameters p = ParametersOf(model, workspace);
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  Evaluate(model, workspace, zero, zero,
           Quantity::kInputMatrix | Quantity::kOutput | Quantity::kOutputJacobian);
  CHECK(workspace.input_matrix.isApprox(Eigen::Vector3d(1.0, 0.0, 0.0)));
  CHECK(workspace.output(0) == 0.0);
  // Gradient of the exact polar angle of the end point at q = 0 by central differences
  // (step 1e-6: error ~1e-12 truncation + 1e-10 rounding).
  const auto end_angle = [&](const Eigen::Vector3d& q) {
    const Kinematics<double> k = Chain<double>({q(0), q(1), q(2)}, p.l);
    double end_x = 0.0, end_y = 0.0;
    for (const double angle : k.angle) {
      end_x += p.l * std::cos(angle);
      end_y += p.l * std::sin(angle);
    }
    return std::atan2(end_y, end_x);
  };
  constexpr double kStep = 1e-6;
  for (int j = 0; j < 3; ++j) {
    const Eigen::Vector3d step = kStep * Eigen::Vector3d::Unit(j);
    const double slope = (end_angle(step) - end_angle(-step)) / (2 * kStep);
    CHECK(workspace.output_jacobian(0, j) == Approx(slope).margin(1e-8));
  }
}

}  // namespace
}  // namespace servokit
