// The two derived forms of a model file (issue #20): `kind: lagrangian` (T, V, R, Q and B) and
// `kind: planar-bodies` (bodies, gravity, springs, dampers, actuators).
//
// 1. Both forms of the shipped hand-written models (tests/data/energy_forms/) give the same
//    compiled M, f, B and h as models/mass_on_car.yaml, rotational_arm.yaml (paper Eq. 49),
//    three_link_arm.yaml and gantry_crane.yaml, at random states and parameter values, to
//    1e-13 relative to each quantity's size. The energies and bodies there were written from the
//    mechanics (rod kinematics), not from the hand-written M and f.
// 2. The shipped examples, classified and checked against closed forms derived by hand:
//    - models/acrobot.yaml (uniform rods, angles from the upright, q = 0 upright, u = 0): at
//      q = 0, M = [[I1 + m1 l1^2/4 + I2 + m2 (l1 + l2/2)^2, I2 + m2 (l2^2/4 + l1 l2/2)],
//      [., I2 + m2 l2^2/4]] with I = m l^2/12. Output y = theta1 (H = [1, 0]), input on the
//      elbow (B = [0, 1]): P = (M^-1)_12 = -M12 / det M != 0, relative degree 2, non-ideal
//      orthogonal (D = [0, 1], D^T B = 1). The Rosenbrock determinant with B = e2, H = e1 is
//      -(A12) for A = M lambda^2 + K, and K12 = d2V/dtheta1 dtheta2 = -m2 g l2/2, so the zero
//      dynamics is M12 lambda^2 = m2 g l2 / 2: lambda = +-sqrt(g / (l1 + 2 l2 / 3)), unstable.
//    - models/cart_pendulum.yaml (rod of mass m, length l hanging from a cart mc, cart friction
//      b, y = x + s sin(phi)): M = [[mc + m, m l/2], [m l/2, m l^2/3]], K = diag(0, m g l/2),
//      D = diag(b, 0), B = e1, H = [1, s]. P = (M22 - s M12) / det M. The Rosenbrock
//      determinant is -(A21 s - A22) (B = e1): (m l s/2 - m l^2/3) lambda^2 = m g l/2, so
//      lambda^2 = g / (s - 2 l / 3) (b does not enter). s = l: +-sqrt(3 g / l), unstable;
//      s < 2 l / 3: an undamped pair; s = 2 l / 3: P = 0, flat with relative degree 4.
// 3. The new errors name the file, the key and the body or entry.
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <complex>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/classification.h"
#include "base/errors.h"
#include "modeling/model.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

constexpr double kRelativeTolerance = 1e-13;
constexpr int kRandomPoints = 50;

// |a - b| <= tolerance * max(|a|, |b|) in the Frobenius norm: round-off of two different
// arrangements of the same expression stays far below this.
void CheckSame(const Eigen::MatrixXd& derived, const Eigen::MatrixXd& written, const char* what) {
  INFO(what << ": derived\n" << derived << "\nwritten\n" << written);
  REQUIRE(derived.rows() == written.rows());
  REQUIRE(derived.cols() == written.cols());
  const double scale = std::max(derived.norm(), written.norm());
  CHECK((derived - written).norm() <= kRelativeTolerance * scale);
}

void CheckSameModel(const std::string& hand_written, const std::string& derived_file) {
  const Model written = LoadModel(ModelPath(hand_written));
  const Model derived = LoadModel(TestDataPath("energy_forms/" + derived_file));
  REQUIRE(derived.parameter_names() == written.parameter_names());
  REQUIRE(derived.coordinates() == written.coordinates());
  REQUIRE(derived.inputs() == written.inputs());
  Workspace a(written), b(derived);
  std::mt19937 random(20);
  std::uniform_real_distribution<double> angle(-3.0, 3.0), rate(-2.0, 2.0), factor(0.5, 1.5);
  const auto dof = static_cast<Eigen::Index>(written.dof());
  const unsigned quantities =
      Quantity::kMassMatrix | Quantity::kForces | Quantity::kInputMatrix | Quantity::kOutput;
  for (int point = 0; point < kRandomPoints; ++point) {
    Eigen::VectorXd q(dof), q_dot(dof);
    for (Eigen::Index k = 0; k < dof; ++k) {
      q(k) = angle(random);
      q_dot(k) = rate(random);
    }
    for (Eigen::Index k = 0; k < written.parameters().size(); ++k) {
      a.parameters(k) = b.parameters(k) = written.parameters()(k) * factor(random);
    }
    Evaluate(written, a, q, q_dot, quantities);
    Evaluate(derived, b, q, q_dot, quantities);
    INFO(derived_file << " at q = " << q.transpose() << ", q_dot = " << q_dot.transpose());
    CheckSame(b.mass_matrix, a.mass_matrix, "M");
    CheckSame(b.forces, a.forces, "f");
    CheckSame(b.input_matrix, a.input_matrix, "B");
    CheckSame(b.output, a.output, "h");
  }
}

TEST_CASE("energies and bodies give the hand-written M, f, B and h of the shipped models",
          "[models]") {
  for (const std::string name :
       {"mass_on_car", "rotational_arm", "three_link_arm", "gantry_crane"}) {
    DYNAMIC_SECTION(name) {
      CheckSameModel(name + ".yaml", name + "_lagrangian.yaml");
      CheckSameModel(name + ".yaml", name + "_bodies.yaml");
    }
  }
}

// A chain of nine point masses with relative joint angles: the bodies' sines of sums of up to
// nine angles would expand to 2^8 products each, past the angle-expansion budget, so M and f are
// projected from the positions (ProjectedEquations, modeling/lagrangian_model.h) instead of
// derived from T. Checked against the same chain written as energies in absolute angles theta_j =
// q_1 +
// ... + q_j by the closed form of a serial chain, T = m l^2/2 sum_i sum_(j,k <= i) theta_j'
// theta_k' cos(theta_j - theta_k).
TEST_CASE("a chain of nine bodies past the angle-expansion budget: projected M and f", "[models]") {
  constexpr int kLinks = 9;
  std::string coordinates, bodies, kinetic = "0", input_rows;
  const auto angle = [](int j) {  // theta_j, 1-based
    std::string sum = "(q1";
    for (int i = 2; i <= j; ++i) sum += " + q" + std::to_string(i);
    return sum + ")";
  };
  const auto rate = [](int j) {
    std::string sum = "(q1_dot";
    for (int i = 2; i <= j; ++i) sum += " + q" + std::to_string(i) + "_dot";
    return sum + ")";
  };
  for (int i = 1; i <= kLinks; ++i) {
    coordinates += std::string(i > 1 ? ", " : "") + "q" + std::to_string(i);
    std::string x = "0", y = "0";
    for (int j = 1; j <= i; ++j) {
      x += " + l*cos" + angle(j);
      y += " + l*sin" + angle(j);
      for (int k = 1; k <= i; ++k) {
        kinetic +=
            " + m*l^2/2*" + rate(j) + "*" + rate(k) + "*cos(" + angle(j) + " - " + angle(k) + ")";
      }
    }
    bodies += "  p" + std::to_string(i) + ": {mass: m, inertia: 0, position: [" + x + ", " + y +
              "], angle: " + angle(i) + "}\n";
    input_rows += std::string("  - [") + (i == 1 ? "1" : "0") + "]\n";
  }
  const std::string common = "parameters: {m: 1.5, l: 0.4}\ncoordinates: [" + coordinates +
                             "]\ninputs: [tau]\noutputs: [q1]\n";
  const Model from_bodies =
      LoadModelFromString("kind: planar-bodies\nname: chain\n" + common + "bodies:\n" + bodies +
                              "actuators:\n  tau: {on: p1, torque: 1}\n",
                          "bodies");
  const Model from_energies =
      LoadModelFromString("kind: lagrangian\nname: chain\n" + common + "kinetic_energy: \"" +
                              kinetic + "\"\npotential_energy: \"0\"\ninput_matrix:\n" + input_rows,
                          "energies");
  Workspace a(from_energies), b(from_bodies);
  std::mt19937 random(9);
  std::uniform_real_distribution<double> angle_value(-3.0, 3.0), rate_value(-2.0, 2.0);
  const unsigned quantities = Quantity::kMassMatrix | Quantity::kForces | Quantity::kInputMatrix;
  for (int point = 0; point < 5; ++point) {
    Eigen::VectorXd q(kLinks), q_dot(kLinks);
    for (Eigen::Index k = 0; k < kLinks; ++k) {
      q(k) = angle_value(random);
      q_dot(k) = rate_value(random);
    }
    Evaluate(from_energies, a, q, q_dot, quantities);
    Evaluate(from_bodies, b, q, q_dot, quantities);
    // Two arrangements of sums of hundreds of terms: their round-off, not 1e-13.
    const double scale = a.forces.norm() + a.mass_matrix.norm();
    CHECK((b.mass_matrix - a.mass_matrix).norm() <= 1e-11 * scale);
    CHECK((b.forces - a.forces).norm() <= 1e-11 * scale);
    CHECK((b.input_matrix - a.input_matrix).norm() == 0.0);
  }
}

// A five-bar linkage written in its two crank angles (issue #31): ground pivots A = (0, 0) and
// E = (w, 0), crank AB driven, crank ED passive (spring c, damper d), the coupler's point C
// found by the loop closure (intersection of the circles about B and D, elbow up) and its two
// rods' angles through atan2 and sqrt, as a user writes a closed chain in minimal coordinates.
// T, written out, is far past the expansion budget: M and f stay as derived, never multiplied
// out. Checked against the linkage computed afresh, without T: the points B, C, D in complex
// arithmetic, their Jacobians by the complex step (exact to rounding), M = sum m J^T J + I j^T j
// over the centres of mass and rods, f = (dM/dq q') q' - 1/2 d(q'^T M q')/dq + dV/dq + dR/dq'
// with dM/dq by central differences.
struct FiveBar {
  double l1 = 1.0, l2 = 1.5, l3 = 1.5, l4 = 1.0, w = 2.0, m1 = 1.0, m2 = 1.5, m3 = 1.5, m4 = 1.0,
         c = 10.0, d = 0.1;

  std::string ModelText() const {
    const std::string bx = "(-l1*sin(q1))", by = "(l1*cos(q1))", ex = "(w - l4*sin(q2))",
                      ey = "(l4*cos(q2))";
    const std::string dx = "(" + ex + " - " + bx + ")", dy = "(" + ey + " - " + by + ")";
    const std::string dd2 = "(" + dx + "^2 + " + dy + "^2)", dd = "sqrt" + dd2;
    const std::string a = "((l2^2 - l3^2 + " + dd2 + ")/(2*" + dd + "))";
    const std::string h = "sqrt(l2^2 - " + a + "^2)", a3 = "(" + a + " - " + dd + ")";
    const auto angle = [&](const std::string& along) {
      return "atan2(" + along + "*" + dy + " + " + h + "*" + dx + ", " + along + "*" + dx + " - " +
             h + "*" + dy + ")";
    };
    const std::string phi2 = angle(a), phi3 = angle(a3);
    const std::string w2 = "((l1*q1_dot*cos(q1 - " + phi3 + ") - l4*q2_dot*cos(q2 - " + phi3 +
                           "))/(l2*sin(" + phi3 + " - " + phi2 + ")))";
    const std::string w3 = "((l4*q2_dot*cos(q2 - " + phi2 + ") - l1*q1_dot*cos(q1 - " + phi2 +
                           "))/(l3*sin(" + phi2 + " - " + phi3 + ")))";
    const std::string kinetic =
        "m1*l1^2/6*q1_dot^2 + m4*l4^2/6*q2_dot^2 + m2/2*l1^2*q1_dot^2 + m2/2*l2*l1*q1_dot*sin(" +
        phi2 + " - q1)*" + w2 + " + m2*l2^2/6*" + w2 + "^2 + m3/2*l4^2*q2_dot^2 + " +
        "m3/2*l3*l4*q2_dot*sin(" + phi3 + " - q2)*" + w3 + " + m3*l3^2/6*" + w3 + "^2";
    std::ostringstream text;
    text.precision(17);
    text << "kind: lagrangian\nname: five_bar\nparameters: {l1: " << l1 << ", l2: " << l2
         << ", l3: " << l3 << ", l4: " << l4 << ", w: " << w << ", m1: " << m1 << ", m2: " << m2
         << ", m3: " << m3 << ", m4: " << m4 << ", c: " << c << ", d: " << d
         << "}\ncoordinates: [q1, q2]\ninputs: [u]\nkinetic_energy: \"" << kinetic
         << "\"\npotential_energy: \"c/2*q2^2\"\ndissipation: \"d/2*q2_dot^2\"\n"
         << "input_matrix:\n  - [1]\n  - [0]\noutputs:\n  - \"" << bx << "\"\n";
    return text.str();
  }

  // B, C, D as (x, y) pairs.
  template <typename T>
  std::array<std::array<T, 2>, 3> Points(T q1, T q2) const {
    const T bx = -l1 * sin(q1), by = l1 * cos(q1), ex = w - l4 * sin(q2), ey = l4 * cos(q2);
    const T dx = ex - bx, dy = ey - by, dd = sqrt(dx * dx + dy * dy);
    const T a = (l2 * l2 - l3 * l3 + dd * dd) / (2.0 * dd), h = sqrt(l2 * l2 - a * a);
    return {{{bx, by}, {bx + (a * dx - h * dy) / dd, by + (a * dy + h * dx) / dd}, {ex, ey}}};
  }

  Eigen::Matrix2d MassMatrix(const Eigen::Vector2d& q) const {
    constexpr double kStep = 1e-30;  // the complex step: no difference, so no cancellation
    std::array<Eigen::Matrix2d, 3> jacobians;  // of B, C, D
    for (int k = 0; k < 2; ++k) {
      using Complex = std::complex<double>;
      const auto points =
          Points(Complex(q(0), k == 0 ? kStep : 0.0), Complex(q(1), k == 1 ? kStep : 0.0));
      for (int p = 0; p < 3; ++p) {
        for (int r = 0; r < 2; ++r) jacobians[p](r, k) = points[p][r].imag() / kStep;
      }
    }
    const auto points = Points(q(0), q(1));
    const auto vector = [&](int p) { return Eigen::Vector2d(points[p][0], points[p][1]); };
    // A rod from point p to point s: its centre's Jacobian and its angular rate's row.
    Eigen::Matrix2d mass = Eigen::Matrix2d::Zero();
    mass(0, 0) = m1 * l1 * l1 / 3;
    mass(1, 1) = m4 * l4 * l4 / 3;
    const auto add_rod = [&](int p, int s, double m, double l) {
      const Eigen::Matrix2d centre = (jacobians[p] + jacobians[s]) / 2;
      const Eigen::Vector2d along = vector(s) - vector(p);
      const Eigen::Matrix2d relative = jacobians[s] - jacobians[p];
      const Eigen::RowVector2d rate =
          (along(0) * relative.row(1) - along(1) * relative.row(0)) / (l * l);
      mass += m * centre.transpose() * centre + m * l * l / 12 * rate.transpose() * rate;
    };
    add_rod(0, 1, m2, l2);  // BC
    add_rod(2, 1, m3, l3);  // DC
    return mass;
  }

  Eigen::Vector2d Forces(const Eigen::Vector2d& q, const Eigen::Vector2d& q_dot) const {
    constexpr double kStep = 1e-5;
    Eigen::Vector2d forces = Eigen::Vector2d::Zero();
    for (int j = 0; j < 2; ++j) {
      Eigen::Vector2d shift = Eigen::Vector2d::Zero();
      shift(j) = kStep;
      const Eigen::Matrix2d slope = (MassMatrix(q + shift) - MassMatrix(q - shift)) / (2 * kStep);
      forces += slope * q_dot * q_dot(j);           // (dM/dq_j q'_j) q'
      forces(j) -= 0.5 * q_dot.dot(slope * q_dot);  // -1/2 q'^T dM/dq_j q'
    }
    forces(1) += c * q(1) + d * q_dot(1);
    return forces;
  }
};

TEST_CASE("a five-bar in minimal coordinates keeps its M and f past the expansion budget",
          "[models]") {
  const FiveBar linkage;
  const Model model = LoadModelFromString(linkage.ModelText(), "five_bar");
  Workspace workspace(model);
  std::mt19937 random(5);
  std::uniform_real_distribution<double> angle(-0.4, 0.4), rate(-2.0, 2.0);
  for (int point = 0; point < 10; ++point) {
    const Eigen::Vector2d q(angle(random), angle(random)), q_dot(rate(random), rate(random));
    Evaluate(model, workspace, q, q_dot, Quantity::kMassMatrix | Quantity::kForces);
    INFO("q = " << q.transpose() << ", q_dot = " << q_dot.transpose());
    const Eigen::Matrix2d mass = linkage.MassMatrix(q);
    CHECK((workspace.mass_matrix - mass).norm() <= 1e-13 * mass.norm());
    const Eigen::Vector2d forces = linkage.Forces(q, q_dot);
    // The central differences' error, some 1e-10 of the Coriolis terms.
    CHECK((workspace.forces - forces).norm() <= 1e-8 * (forces.norm() + mass.norm()));
  }
}

// Q(q, q') enters f with a minus sign, so viscous friction written as a generalized force
// -b x' is the same as the Rayleigh function b x'^2 / 2.
TEST_CASE("a generalized force -b x_dot is the same as the dissipation b x_dot^2/2", "[models]") {
  const std::string head = R"(kind: lagrangian
name: sled
parameters: {m: 2.0, b: 0.3, k: 4.0}
coordinates: [x]
inputs: [F]
kinetic_energy: m*x_dot^2/2
potential_energy: k*x^2/2
input_matrix: [[1]]
outputs: [x]
)";
  const Model rayleigh = LoadModelFromString(head + "dissipation: b*x_dot^2/2\n", "r.yaml");
  const Model generalized =
      LoadModelFromString(head + "generalized_forces: [-b*x_dot]\n", "q.yaml");
  Workspace a(rayleigh), b(generalized);
  const Eigen::VectorXd q = Eigen::VectorXd::Constant(1, 0.7),
                        q_dot = Eigen::VectorXd::Constant(1, -1.3);
  Evaluate(rayleigh, a, q, q_dot, Quantity::kForces);
  Evaluate(generalized, b, q, q_dot, Quantity::kForces);
  // f = k x + b x' by hand.
  CHECK(a.forces(0) == Approx(4.0 * 0.7 + 0.3 * -1.3).epsilon(1e-15));
  CHECK(b.forces(0) == Approx(4.0 * 0.7 + 0.3 * -1.3).epsilon(1e-15));
}

// A spring and a damper between two points: V = k/2 (|P1 - P2| - rest)^2 and
// R = d/2 (d|P1 - P2|/dt)^2. A body on a rail at (x, 0) tied to the ground point (0, h): the
// stretch is sqrt(x^2 + h^2) - L, so f = k (1 - L/sqrt(x^2 + h^2)) x + d x^2 x'/(x^2 + h^2).
TEST_CASE("springs and dampers between two points act along the line between them", "[models]") {
  const Model model = LoadModelFromString(R"(kind: planar-bodies
name: tied
parameters: {m: 2.0, k: 3.0, d: 0.5, L: 0.4, h: 1.5}
coordinates: [x]
inputs: [F]
bodies:
  slider: {mass: m, position: [x, 0]}
springs:
  - {between: [slider, {body: ground, at: [0, h]}], stiffness: k, rest: L}
dampers:
  - {between: [{body: ground, at: [0, h]}, slider], damping: d}
actuators:
  F: {on: slider, force: [1, 0]}
outputs: [x]
)",
                                          "tied.yaml");
  Workspace workspace(model);
  const double x = 0.8, x_dot = -0.6, k = 3.0, d = 0.5, L = 0.4, h = 1.5;
  const Eigen::VectorXd q = Eigen::VectorXd::Constant(1, x),
                        q_dot = Eigen::VectorXd::Constant(1, x_dot);
  Evaluate(model, workspace, q, q_dot, Quantity::kForces | Quantity::kMassMatrix);
  const double distance = std::sqrt(x * x + h * h);
  CHECK(workspace.forces(0) ==
        Approx(k * (1 - L / distance) * x + d * x * x * x_dot / (distance * distance))
            .epsilon(1e-14));
  CHECK(workspace.mass_matrix(0, 0) == Approx(2.0).epsilon(1e-15));
}

// A force at a point off the centre of a turning body: B = (dP/dq)^T direction. A wheel of
// radius r turning by phi, centre at (x, 0); a horizontal force at its top (0, r) in the body
// frame, P = (x - r sin(phi), r cos(phi)), so B = [1, -r cos(phi)].
TEST_CASE("a force at a point of a body has the virtual work of that point", "[models]") {
  const Model model = LoadModelFromString(R"(kind: planar-bodies
name: wheel
parameters: {m: 1.0, J: 0.1, r: 0.3}
coordinates: [x, phi]
inputs: [F]
bodies:
  wheel: {mass: m, inertia: J, position: [x, 0], angle: phi}
actuators:
  F: {on: wheel, at: [0, r], force: [1, 0]}
outputs: [x]
)",
                                          "wheel.yaml");
  Workspace workspace(model);
  const Eigen::Vector2d q(0.2, 0.9), q_dot(0.0, 0.0);
  Evaluate(model, workspace, q, q_dot, Quantity::kInputMatrix);
  CHECK(workspace.input_matrix(0, 0) == Approx(1.0).epsilon(1e-15));
  CHECK(workspace.input_matrix(1, 0) == Approx(-0.3 * std::cos(0.9)).epsilon(1e-15));
}

Classification ClassifyShipped(const std::string& file,
                               const std::vector<ParameterOverride>& overrides = {}) {
  const Model model = LoadModel(ModelPath(file), overrides);
  Workspace workspace(model);
  return Classify(model, workspace);
}

void CheckRealPair(const Classification& c, double magnitude) {
  REQUIRE(c.zero_dynamics.eigenvalues.size() == 2);
  for (const std::complex<double>& eigenvalue : c.zero_dynamics.eigenvalues) {
    CHECK(std::abs(eigenvalue.imag()) <= 1e-12 * magnitude);
    CHECK(std::abs(eigenvalue.real()) == Approx(magnitude).epsilon(1e-10));
  }
  CHECK(c.zero_dynamics.eigenvalues[0].real() * c.zero_dynamics.eigenvalues[1].real() < 0);
}

TEST_CASE("the acrobot holding its shoulder angle upright: relative degree 2, saddle zeros",
          "[models]") {
  const double m1 = 1, m2 = 1, l1 = 1, l2 = 1, g = 9.81;
  const double i1 = m1 * l1 * l1 / 12, i2 = m2 * l2 * l2 / 12;
  const double m11 = i1 + m1 * l1 * l1 / 4 + i2 + m2 * (l1 + l2 / 2) * (l1 + l2 / 2);
  const double m12 = i2 + m2 * (l2 * l2 / 4 + l1 * l2 / 2), m22 = i2 + m2 * l2 * l2 / 4;
  const Classification c = ClassifyShipped("acrobot.yaml");
  CHECK(c.operating_point.q.norm() <= 1e-12);
  CHECK(std::abs(c.operating_point.u(0)) <= 1e-12);
  CHECK(c.decoupling.decoupling_matrix(0, 0) ==
        Approx(-m12 / (m11 * m22 - m12 * m12)).epsilon(1e-12));
  CHECK(c.decoupling.realization == Realization::kNonIdealOrthogonal);
  CHECK(c.structure.relative_degree == std::vector<int>{2});
  CHECK(c.structure.internal_dynamics_order == 2);
  CHECK_FALSE(c.flat);
  CHECK(c.zero_dynamics.stability == Stability::kUnstable);
  CheckRealPair(c, std::sqrt(g / (l1 + 2 * l2 / 3)));
}

TEST_CASE("the cart pendulum: zeros lambda^2 = g / (s - 2l/3), flat at the centre of percussion",
          "[models]") {
  const double mc = 1, m = 0.5, l = 1, g = 9.81;
  const double m11 = mc + m, m12 = m * l / 2, m22 = m * l * l / 3;
  SECTION("the tip, s = l: relative degree 2, unstable real pair") {
    const Classification c = ClassifyShipped("cart_pendulum.yaml");
    CHECK(c.decoupling.decoupling_matrix(0, 0) ==
          Approx((m22 - l * m12) / (m11 * m22 - m12 * m12)).epsilon(1e-12));
    CHECK(c.decoupling.realization == Realization::kNonIdealOrthogonal);
    CHECK(c.structure.relative_degree == std::vector<int>{2});
    CHECK(c.zero_dynamics.stability == Stability::kUnstable);
    CheckRealPair(c, std::sqrt(g / (l - 2 * l / 3)));
  }
  SECTION("s = l/2: an undamped pair +-i sqrt(g / (2l/3 - s))") {
    const Classification c = ClassifyShipped("cart_pendulum.yaml", {{"s", "0.5"}});
    REQUIRE(c.zero_dynamics.eigenvalues.size() == 2);
    const double omega = std::sqrt(g / (2 * l / 3 - 0.5));
    for (const std::complex<double>& eigenvalue : c.zero_dynamics.eigenvalues) {
      CHECK(std::abs(eigenvalue.real()) <= 1e-10 * omega);
      CHECK(std::abs(eigenvalue.imag()) == Approx(omega).epsilon(1e-10));
    }
    CHECK(c.zero_dynamics.stability == Stability::kCritical);
  }
  SECTION("s = 2l/3: P = 0, relative degree 4, flat") {
    const Classification c = ClassifyShipped("cart_pendulum.yaml", {{"s", "0.6666666666666666"}});
    CHECK(c.decoupling.realization == Realization::kTangential);
    CHECK(c.structure.relative_degree == std::vector<int>{4});
    CHECK(c.flat);
  }
}

std::string LoadError(const std::string& text) {
  try {
    LoadModelFromString(text, "bad.yaml");
  } catch (const ModelError& error) {
    return error.what();
  }
  FAIL("no ModelError for\n" << text);
  return {};
}

const std::string kLagrangianHead = R"(kind: lagrangian
name: sled
parameters: {m: 2.0, k: 4.0}
coordinates: [x, y]
inputs: [F]
input_matrix: [[1], [0]]
outputs: [x]
)";

const std::string kBodiesHead = R"(kind: planar-bodies
name: cart
parameters: {m: 2.0, k: 4.0}
coordinates: [x]
inputs: [F]
outputs: [x]
)";

TEST_CASE("T must be a quadratic form in the velocities", "[models]") {
  CHECK(LoadError(kLagrangianHead + "kinetic_energy: m*(x_dot^2 + y_dot^2)/2 + m*x_dot\n" +
                  "potential_energy: k*(x^2 + y^2)/2\n") ==
        "bad.yaml: kinetic_energy: T is not quadratic in the velocities: T - 1/2 q_dot^T M q_dot "
        "= m*x_dot (terms linear in or free of the velocities; T(q, s q_dot) must be s^2 "
        "T(q, q_dot))");
  CHECK_THAT(LoadError(kLagrangianHead + "kinetic_energy: m*(x_dot^4 + y_dot^2)/2\n" +
                       "potential_energy: k*(x^2 + y^2)/2\n"),
             Catch::StartsWith("bad.yaml: kinetic_energy: T is not quadratic in the velocities: "
                               "d2T/dx_dot dx_dot = ") &&
                 Catch::EndsWith("depends on the velocity 'x_dot'"));
}

TEST_CASE("each form names its own keys when one is unknown or missing", "[models]") {
  CHECK(LoadError(kLagrangianHead + "kinetic_energy: m*(x_dot^2 + y_dot^2)/2\n" +
                  "potential_energy: 0\nmass_matrix: [[m, 0], [0, m]]\n") ==
        "bad.yaml: mass_matrix: unknown key (expected name, parameters, coordinates, inputs, "
        "kinetic_energy, potential_energy, input_matrix, outputs, description, dissipation, "
        "generalized_forces, constraints, q0 or kind)");
  CHECK(LoadError(kLagrangianHead + "kinetic_energy: m*(x_dot^2 + y_dot^2)/2\n") ==
        "bad.yaml: potential_energy: missing required key");
  CHECK(LoadError(kBodiesHead + "bodies:\n  cart: {mass: m, position: [x, 0]}\nforces: [0]\n") ==
        "bad.yaml: forces: unknown key (expected name, parameters, coordinates, inputs, bodies, "
        "actuators, outputs, description, gravity, springs, dampers, joints, constraints, q0 or "
        "kind)");
}

TEST_CASE("M must be positive definite at q = 0", "[models]") {
  CHECK(LoadError(kLagrangianHead + "kinetic_energy: m*x_dot^2/2\n" +
                  "potential_energy: k*(x^2 + y^2)/2\n") ==
        "bad.yaml: kinetic_energy: the mass matrix d2T/dq_dot2 is not positive definite at q = 0 "
        "with the nominal parameters (smallest eigenvalue 0, largest 2); no kinetic energy in "
        "the coordinates y");
}

TEST_CASE("V and B may not depend on velocities", "[models]") {
  CHECK(LoadError(kLagrangianHead + "kinetic_energy: m*(x_dot^2 + y_dot^2)/2\n" +
                  "potential_energy: k*x*x_dot\n") ==
        "bad.yaml: potential_energy: depends on the velocity 'x_dot'; V(q) may depend on "
        "parameters and coordinates only");
  CHECK(LoadError(kLagrangianHead + "kinetic_energy: m*(x_dot^2 + y_dot^2)/2\n" +
                  "potential_energy: k*z\n") == "bad.yaml: potential_energy: unknown symbol 'z'");
}

TEST_CASE("bad bodies, springs and actuators are named", "[models]") {
  const std::string actuator = "actuators:\n  F: {on: cart, force: [1, 0]}\n";
  CHECK(LoadError(kBodiesHead + "bodies:\n  cart: {position: [x, 0]}\n" + actuator) ==
        "bad.yaml: bodies.cart.mass: missing required key (the body's mass)");
  CHECK(LoadError(kBodiesHead + "bodies:\n  cart: {mass: m, position: [x, 0, 0]}\n" + actuator) ==
        "bad.yaml: bodies.cart.position: expected a vector [x, y] of two expressions, found 3 "
        "entries");
  CHECK(LoadError(kBodiesHead + "bodies:\n  cart: {mass: m, position: [x, 0], colour: red}\n" +
                  actuator) ==
        "bad.yaml: bodies.cart.colour: unknown key (expected mass, inertia, position, angle)");
  CHECK(
      LoadError(kBodiesHead + "bodies:\n  cart: {mass: m*x_dot, position: [x, 0]}\n" + actuator) ==
      "bad.yaml: bodies.cart.mass: depends on the velocity 'x_dot'; positions, angles, masses, "
      "forces and directions may depend on parameters and coordinates only");
  const std::string body = "bodies:\n  cart: {mass: m, position: [x, 0]}\n";
  CHECK(LoadError(kBodiesHead + body + "springs:\n  - {between: [cart, wagon], stiffness: k}\n" +
                  actuator) ==
        "bad.yaml: springs[0].between[1]: unknown body 'wagon' (bodies: cart, ground)");
  CHECK(
      LoadError(kBodiesHead + body + "springs:\n  - {coordinate: z, stiffness: k}\n" + actuator) ==
      "bad.yaml: springs[0].coordinate: unknown coordinate 'z' (coordinates: x)");
  CHECK(LoadError(kBodiesHead + body + "actuators:\n  F: {on: wagon, force: [1, 0]}\n") ==
        "bad.yaml: actuators.F.on: unknown body 'wagon' (bodies: cart)");
  CHECK(LoadError(kBodiesHead + body + "actuators:\n  G: {on: cart, force: [1, 0]}\n") ==
        "bad.yaml: actuators.G: not an input (inputs: F)");
  CHECK(LoadError(kBodiesHead + body + "actuators:\n  F: {on: cart, torque: 1, force: [1, 0]}\n") ==
        "bad.yaml: actuators.F: expected exactly one of force: [x, y] or torque: <expression>");
  CHECK(LoadError(kBodiesHead + "bodies:\n  cart: {mass: 0, position: [x, 0]}\n" + actuator) ==
        "bad.yaml: bodies: the mass matrix d2T/dq_dot2 is not positive definite at q = 0 with "
        "the nominal parameters (smallest eigenvalue 0, largest 0); no kinetic energy in the "
        "coordinates x");
  CHECK(LoadError(kBodiesHead + body) == "bad.yaml: actuators: missing required key");
  CHECK(LoadError(kBodiesHead + body + "bodies:\n  wagon: {mass: m, position: [x, 0]}\n" +
                  actuator) == "bad.yaml: bodies: duplicate key");
  // `springs:` with comments only (as in the example of docs/model-files.md "Bodies") is no
  // springs.
  CHECK_NOTHROW(
      LoadModelFromString(kBodiesHead + body + "springs:\n  # none\n" + actuator, "empty.yaml"));
}

}  // namespace
}  // namespace servokit
