// Closed kinematic chains (docs/model-files.md, "Closed kinematic chains"): a mechanism written
// in redundant coordinates with loop-closing constraints must be classified as the same
// mechanism written in minimal coordinates. The reference is the paper's passive-joint arm
// (Sect. 4.2, models/rotational_arm.yaml): cut at the joint between its links, link 2 described
// by its centre (x2, y2) and absolute angle theta2, and the joint closed by two constraints
// (tests/data/loops/rotational_arm_redundant.yaml). P, the realization, the relative degree and
// the zero dynamics must agree to 1e-12 below, at and above s/l = 2/3. Then the same arm in a
// vertical plane, where the loop carries link 2's weight: the multipliers are the joint force,
// (0, m g) by the statics of link 2 alone, and the zeros need the constraint forces' stiffness
// d(C^T lambda)/dq; the minimal model (written here, by hand) is the reference again. And the
// errors of loading and of the operating point name the constraint.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "analysis/thresholds.h"
#include "base/errors.h"
#include "tests/analysis/classify_helpers.h"

namespace servokit {
namespace {

using testing::ClassifyFile;
using testing::ModelPath;
using testing::TestDataPath;

void CheckSameClassification(const Classification& minimal, const Classification& redundant) {
  REQUIRE(redundant.decoupling.decoupling_matrix.rows() == 1);
  // At s/l = 2/3, P is zero but for rounding (1e-16) in both.
  CHECK(redundant.decoupling.decoupling_matrix(0, 0) ==
        Approx(minimal.decoupling.decoupling_matrix(0, 0)).epsilon(1e-12).margin(1e-15));
  CHECK(redundant.decoupling.rank == minimal.decoupling.rank);
  CHECK(redundant.decoupling.realization == minimal.decoupling.realization);
  CHECK(redundant.structure.relative_degree == minimal.structure.relative_degree);
  CHECK(redundant.structure.internal_dynamics_order == minimal.structure.internal_dynamics_order);
  CHECK(redundant.zero_dynamics.stability == minimal.zero_dynamics.stability);
  const auto& expected = minimal.zero_dynamics.eigenvalues;
  const auto& zeros = redundant.zero_dynamics.eigenvalues;
  REQUIRE(zeros.size() == expected.size());
  for (std::size_t i = 0; i < zeros.size(); ++i) {
    CHECK(std::abs(zeros[i] - expected[i]) <= 1e-12 * std::abs(expected[i]));
  }
  REQUIRE(redundant.cross_check);
  // Where P is zero to rounding, QZ of the pencil sees the zero pair that leaves through
  // infinity as P -> 0 at +-1/sqrt(P) (+-2.7e8 here), which the structure at infinity does not
  // count: a regular P only (issue #36 is about that case).
  if (minimal.decoupling.rank == 1) CHECK(redundant.cross_check->agrees);
}

TEST_CASE("the arm in redundant coordinates is classified as in minimal ones", "[analysis]") {
  // s/l below, at and above 2/3 (l = 1).
  for (const std::string s : {"0.5", "0.6666666666666666", "1", "2"}) {
    INFO("s = " << s);
    const Classification minimal = ClassifyFile(ModelPath("rotational_arm.yaml"), {{"s", s}});
    const Classification redundant =
        ClassifyFile(TestDataPath("loops/rotational_arm_redundant.yaml"), {{"s", s}});
    CheckSameClassification(minimal, redundant);
    // On the loop: the joint closed, link 2's centre half a link beyond the arm's end.
    CHECK(redundant.operating_point.q(1) == Approx(1.5).epsilon(1e-12));
    REQUIRE(redundant.operating_point.multipliers.size() == 2);
    CHECK(redundant.operating_point.multipliers.norm() <= 1e-12);  // nothing loads the joint
  }
}

TEST_CASE("threshold finds s/l = 2/3 on the arm in redundant coordinates", "[analysis]") {
  const Model model = LoadModel(TestDataPath("loops/rotational_arm_redundant.yaml"));
  const ThresholdSearch search =
      FindThresholds(model, *model.FindParameter("s"), 0.1, 2.0, ThresholdEvent::kStability);
  REQUIRE(search.events.size() == 1);
  // The paper's s/l = 2/3 (l = 1), where the leading coefficient m l^2 (2 l - 3 s) of the zero
  // dynamics' polynomial changes sign, within the bracket.
  CHECK(std::abs(search.events[0].value - 2.0 / 3.0) <= search.events[0].bracket_width);
  CHECK(search.events[0].from == "asymptotically-stable");
  CHECK(search.events[0].to == "unstable");
}

// The arm in a vertical plane (gravity g along -y), both ways.
constexpr const char* kVerticalMinimal = R"(kind: lagrangian
name: arm_vertical
parameters: {l: 1.0, m: 3.438, c: 50.0, d: 0.25, s: 1.0, g: 9.81}
coordinates: [alpha, beta]
inputs: [T]
kinetic_energy: m*l^2/6*alpha_dot^2 + m/2*(l^2*alpha_dot^2 + l^2/4*(alpha_dot + beta_dot)^2 + l^2*cos(beta)*alpha_dot*(alpha_dot + beta_dot)) + m*l^2/24*(alpha_dot + beta_dot)^2
potential_energy: c/2*beta^2 + m*g*l/2*sin(alpha) + m*g*(l*sin(alpha) + l/2*sin(alpha + beta))
dissipation: d/2*beta_dot^2
input_matrix: [[1], [0]]
outputs: [alpha + s/(s + l)*beta]
)";
constexpr const char* kVerticalRedundant = R"(kind: lagrangian
name: arm_vertical_redundant
parameters: {l: 1.0, m: 3.438, c: 50.0, d: 0.25, s: 1.0, g: 9.81}
coordinates: [alpha, x2, y2, theta2]
inputs: [T]
kinetic_energy: m*l^2/6*alpha_dot^2 + m/2*(x2_dot^2 + y2_dot^2) + m*l^2/24*theta2_dot^2
potential_energy: c/2*(theta2 - alpha)^2 + m*g*l/2*sin(alpha) + m*g*y2
dissipation: d/2*(theta2_dot - alpha_dot)^2
input_matrix: [[1], [0], [0], [0]]
constraints:
  - x2 - l*cos(alpha) - l/2*cos(theta2)
  - y2 - l*sin(alpha) - l/2*sin(theta2)
outputs: [alpha + s/(s + l)*(theta2 - alpha)]
)";

Classification ClassifyText(const char* text, double y0) {
  const Model model = LoadModelFromString(text, "inline.yaml");
  Workspace workspace(model);
  ClassificationOptions options;
  options.operating_point.y0 = Eigen::VectorXd::Constant(1, y0);
  return Classify(model, workspace, options);
}

TEST_CASE("a loop that carries load: the multipliers and their stiffness", "[analysis]") {
  for (const double y0 : {0.0, 0.4, -1.0}) {
    INFO("y0 = " << y0);
    const Classification minimal = ClassifyText(kVerticalMinimal, y0);
    const Classification redundant = ClassifyText(kVerticalRedundant, y0);
    CheckSameClassification(minimal, redundant);
    // The same pose and torque: alpha and the joint angle theta2 - alpha.
    const Eigen::VectorXd& q = redundant.operating_point.q;
    CHECK(q(0) == Approx(minimal.operating_point.q(0)).margin(1e-10));
    CHECK(q(3) - q(0) == Approx(minimal.operating_point.q(1)).margin(1e-10));
    CHECK(redundant.operating_point.u(0) == Approx(minimal.operating_point.u(0)).epsilon(1e-10));
    // Link 2 alone at rest: the joint pushes it up with its weight; lambda is that force
    // (C^T lambda in the x2, y2 rows is lambda itself).
    const Eigen::VectorXd& lambda = redundant.operating_point.multipliers;
    CHECK(lambda(0) == Approx(0.0).margin(1e-9));
    CHECK(lambda(1) == Approx(3.438 * 9.81).epsilon(1e-12));
  }
}

// The same arm as planar bodies (`kind: planar-bodies`), link 2 placed by its centre and the
// joint between the links a loop-closing joint (tests/data/loops/rotational_arm_bodies.yaml).
TEST_CASE("a joint that closes a loop between planar bodies", "[analysis]") {
  for (const std::string s : {"0.5", "1", "2"}) {
    INFO("s = " << s);
    const Classification minimal = ClassifyFile(ModelPath("rotational_arm.yaml"), {{"s", s}});
    const Classification bodies =
        ClassifyFile(TestDataPath("loops/rotational_arm_bodies.yaml"), {{"s", s}});
    CheckSameClassification(minimal, bodies);
  }
  const auto error_of = [](const std::string& joints) -> std::string {
    const std::string text = R"(kind: planar-bodies
name: bad
parameters: {l: 1.0}
coordinates: [a, x, y]
inputs: [T]
bodies:
  rod: {mass: 1, inertia: 0.1, position: [x, y], angle: a}
joints: )" + joints + R"(
actuators:
  T: {on: rod, torque: 1}
outputs: [a]
)";
    try {
      LoadModelFromString(text, "bad.yaml");
    } catch (const std::exception& error) {
      return error.what();
    }
    return "";
  };
  CHECK_THAT(error_of("[{between: [ground, ground]}]"),
             Catch::Contains("joints[0].x: does not depend on the coordinates"));
  CHECK_THAT(error_of("[{between: [rod, wagon]}]"),
             Catch::Contains("joints[0].between[1]: unknown body 'wagon'"));
  CHECK_THAT(error_of("[{between: [rod]}]"),
             Catch::Contains("joints[0].between: expected two points"));
  CHECK_THAT(error_of("[{between: [rod, ground], slide: [1, 0]}]"),
             Catch::Contains("joints[0]") && Catch::Contains("slide"));
  CHECK_THAT(error_of("[{between: [{body: rod, at: [0.5, 0]}, ground]}, {between: [rod, ground]}]"),
             Catch::Contains("joints: 4 constraints for 3 coordinates leave 0 degrees"));
}

// The file's q0 (the load hanging at L0 = 2 m below the trolley) is Newton's start and its output
// the default y0: the operating point is that pose itself, held by the rope and the hoist; at
// q = 0 (the load on the rail, the rope slack) there is none to find. An explicit q_guess still
// holds the file's h(q0).
TEST_CASE("a model file's q0 is the default operating point", "[analysis]") {
  const Model crane = LoadModel(ModelPath("gantry_crane_absolute.yaml"));
  REQUIRE(crane.operating_point_start().size() == 4);
  Workspace workspace(crane);
  const OperatingPoint point = FindOperatingPoint(crane, workspace, {});
  CHECK(point.q.isApprox(Eigen::Vector4d(0.0, 0.0, 0.0, 2.0), 1e-14));
  CHECK(point.y.isApprox(Eigen::Vector2d(0.0, 2.0), 1e-14));
  CHECK(point.multipliers(0) == Approx(-5.0 * 9.81 / 4.0).epsilon(1e-12));
  CHECK(point.u(1) == Approx(-5.0 * 9.81).epsilon(1e-12));  // the hoist holds the load's weight
  OperatingPointOptions nearby;
  nearby.q_guess = Eigen::Vector4d(0.1, 0.0, 0.1, 1.9);
  CHECK(FindOperatingPoint(crane, workspace, nearby).y.isApprox(Eigen::Vector2d(0.0, 2.0), 1e-14));
  const Model without = LoadModelFromString(
      "name: no_start\nparameters: {}\ncoordinates: [a]\ninputs: [T]\nmass_matrix: [[1]]\n"
      "forces: [a]\ninput_matrix: [[1]]\noutputs: [a]\n",
      "no_start.yaml");
  CHECK(without.operating_point_start().size() == 0);
}

// Couplers of 0.4 m cannot join cranks 2 m apart: no equilibrium closes the five-bar's loop, and
// the message names the constraint left open and what to change.
TEST_CASE("a loop that cannot close is named", "[analysis]") {
  std::string message;
  try {
    ClassifyFile(ModelPath("five_bar.yaml"), {{"l2", "0.4"}, {"l3", "0.4"}});
  } catch (const NoSolution& error) {
    message = error.what();
  }
  CHECK_THAT(message, Catch::Contains("no equilibrium found") &&
                          Catch::Contains("its loops stay open: constraints[") &&
                          Catch::Contains("(--q0, or q0: in the model file)"));
}

// The gantry crane in absolute coordinates (trolley x, rope payout r, the load's xL and zL, the
// rope a constraint: models/gantry_crane_absolute.yaml) against models/gantry_crane.yaml
// in minimal ones: mixed realization, vector relative degree [4, 2], index 5, flat. The
// multiplier is the rope's: the load at rest hangs on it, m g = -dc/dzL lambda = -2 zL lambda.
TEST_CASE("the gantry crane in absolute coordinates is classified as in minimal ones",
          "[analysis]") {
  const Model minimal_model = LoadModel(ModelPath("gantry_crane.yaml"));
  const Model absolute_model = LoadModel(ModelPath("gantry_crane_absolute.yaml"));
  Workspace minimal_workspace(minimal_model), absolute_workspace(absolute_model);
  for (const auto& [x, z] : {std::pair{0.0, 2.0}, std::pair{0.3, 1.5}}) {
    INFO("y0 = " << x << ", " << z);
    ClassificationOptions options;
    options.operating_point.y0 = Eigen::Vector2d(x, z);
    const Classification minimal = Classify(minimal_model, minimal_workspace, options);
    options.operating_point.q_guess = Eigen::Vector4d(0.0, 0.0, 0.0, 2.0);
    const Classification absolute = Classify(absolute_model, absolute_workspace, options);
    CHECK(absolute.decoupling.realization == minimal.decoupling.realization);
    CHECK(absolute.decoupling.realization == Realization::kMixed);
    CHECK(absolute.decoupling.rank == 1);
    CHECK(absolute.structure.relative_degree == std::vector<int>{4, 2});
    CHECK(absolute.structure.differentiation_index == 5);
    CHECK(absolute.flat);
    CHECK(absolute.zero_dynamics.eigenvalues.empty());
    CHECK(absolute.operating_point.u(1) ==
          Approx(minimal.operating_point.u(1)).epsilon(1e-12));  // the hoist holds the load
    const double load_weight = 5.0 * 9.81;
    CHECK(absolute.operating_point.multipliers(0) == Approx(-load_weight / (2 * z)).epsilon(1e-12));
  }
}

// A planar five-bar with a passive sprung crank: in its two crank angles with the loop closure
// solved by atan2 and sqrt (tests/data/loops/five_bar_minimal.yaml, bench/size_models.py's
// derivation), and in the crank and coupler angles with the coupler joint closed by two
// constraints (models/five_bar.yaml, written afresh). The upright pose and two with the
// output point to its left, the spring relaxed and preloaded.
TEST_CASE("a five-bar in redundant coordinates is classified as in minimal ones", "[analysis]") {
  for (const std::string rest_angle : {"0", "0.3"}) {
    const Model minimal_model =
        LoadModel(TestDataPath("loops/five_bar_minimal.yaml"), {{"q2r", rest_angle}});
    const Model redundant_model = LoadModel(ModelPath("five_bar.yaml"), {{"q2r", rest_angle}});
    Workspace minimal_workspace(minimal_model), redundant_workspace(redundant_model);
    for (const double y0 : {1.0, 0.8, 0.9}) {
      INFO("q2r = " << rest_angle << ", y0 = " << y0);
      ClassificationOptions options;
      options.operating_point.y0 = Eigen::VectorXd::Constant(1, y0);
      const Classification minimal = Classify(minimal_model, minimal_workspace, options);
      // Elbow up, as the minimal model's closure chooses: the upright pose's coupler angles.
      options.operating_point.q_guess = Eigen::Vector4d(0.0, 0.0, 0.8411, 2.3005);
      const Classification redundant = Classify(redundant_model, redundant_workspace, options);
      CheckSameClassification(minimal, redundant);
      CHECK(redundant.operating_point.q(0) == Approx(minimal.operating_point.q(0)).margin(1e-10));
      CHECK(redundant.operating_point.q(1) == Approx(minimal.operating_point.q(1)).margin(1e-10));
    }
  }
}

// The error of loading and classifying a model of `coordinates` unit masses with springs to
// the origin, the first driven, the output the sum of the first two, and `constraints`; "" for
// none. (A model error at load, NoSolution at the operating point.)
std::string ErrorOf(const std::vector<std::string>& coordinates, const std::string& constraints) {
  const std::size_t dof = coordinates.size();
  std::string mass, forces, inputs;
  for (std::size_t i = 0; i < dof; ++i) {
    std::string row;
    for (std::size_t j = 0; j < dof; ++j) row += std::string(j ? ", " : "") + (i == j ? "1" : "0");
    mass += std::string(i ? ", " : "") + "[" + row + "]";
    forces += std::string(i ? ", " : "") + coordinates[i];
    inputs += std::string(i ? ", " : "") + (i == 0 ? "[1]" : "[0]");
  }
  std::string names;
  for (std::size_t i = 0; i < dof; ++i) names += std::string(i ? ", " : "") + coordinates[i];
  const std::string text = "name: bad\nparameters: {l: 1.0}\ncoordinates: [" + names +
                           "]\ninputs: [T]\nmass_matrix: [" + mass + "]\nforces: [" + forces +
                           "]\ninput_matrix: [" + inputs + "]\nconstraints: " + constraints +
                           "\noutputs: [" + coordinates[0] + " + " + coordinates[1] + "]\n";
  try {
    const Model model = LoadModelFromString(text, "bad.yaml");
    Workspace workspace(model);
    Classify(model, workspace);
  } catch (const std::exception& error) {
    return error.what();
  }
  return "";
}

TEST_CASE("bad constraints are named", "[analysis]") {
  const auto load_error = [](const std::string& constraints) {
    return ErrorOf({"a", "b", "c"}, constraints);
  };
  CHECK_THAT(load_error("[b - c, l + 1]"),
             Catch::Contains("constraints[1]") && Catch::Contains("does not depend"));
  CHECK_THAT(load_error("[b - c_dot]"),
             Catch::Contains("constraints[0]") && Catch::Contains("velocity 'c_dot'"));
  CHECK_THAT(load_error("[a, b, c]"),
             Catch::Contains("constraints: 3 constraints for 3 coordinates leave 0 degrees"));
  CHECK_THAT(load_error("[]"), Catch::Contains("constraints: expected a list"));
}

TEST_CASE("a redundant constraint and an unreachable loop stop the analysis", "[analysis]") {
  const auto error_of = [](const std::string& constraints) {
    return ErrorOf({"a", "b", "c", "e"}, constraints);
  };
  CHECK_THAT(error_of("[b - c, 2*b - 2*c]"),
             Catch::Contains("constraints[1]") && Catch::Contains("rank-deficient"));
  CHECK_THAT(error_of("[c^2 + 1]"), Catch::Contains("no equilibrium found"));
}

}  // namespace
}  // namespace servokit
