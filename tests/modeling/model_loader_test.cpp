// Loads the shipped models and checks the compiled quantities against closed forms written out
// by hand (paper Eqs. 26-27 for the mass on a car, Eqs. 49-50 for the rotational arm) and the
// derived Jacobians against central finite differences of the quantities they differentiate.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "modeling/model.h"
#include "modeling/symbolic_lock.h"
#include "modeling/symbolic_model.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;

// Closed forms and compiled programs evaluate the same formulas in a different order.
constexpr double kRoundOff = 1e-12;
// Central differences with step kStep have truncation error ~ kStep^2 |f'''| ~ 1e-12 and
// round-off ~ 1e-16 |f| / kStep ~ 1e-10 for these O(1)-O(100) quantities.
constexpr double kStep = 1e-6;
constexpr double kFiniteDifferenceTolerance = 1e-6;

// A generic state away from every symmetry of the models.
const Eigen::Vector2d kQ(0.3, -0.7);
const Eigen::Vector2d kQDot(0.2, 0.5);

// The j-th column of a Jacobian by central differences of `quantity` (a function of q, q_dot
// returning a matrix flattened column-major) along `direction`.
Eigen::VectorXd CentralDifference(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&, const Eigen::VectorXd&)>& quantity,
    const Eigen::VectorXd& q,
    const Eigen::VectorXd& q_dot,
    const Eigen::VectorXd& q_direction,
    const Eigen::VectorXd& q_dot_direction) {
  return (quantity(q + kStep * q_direction, q_dot + kStep * q_dot_direction) -
          quantity(q - kStep * q_direction, q_dot - kStep * q_dot_direction)) /
         (2 * kStep);
}

Eigen::VectorXd Flat(const Eigen::MatrixXd& matrix) {
  return Eigen::Map<const Eigen::VectorXd>(matrix.data(), matrix.size());
}

void CheckClose(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected, double tolerance) {
  INFO("actual:\n" << actual << "\nexpected:\n" << expected);
  REQUIRE(actual.rows() == expected.rows());
  REQUIRE(actual.cols() == expected.cols());
  CHECK((actual - expected).cwiseAbs().maxCoeff() <=
        tolerance * std::max(1.0, expected.cwiseAbs().maxCoeff()));
}

TEST_CASE("the three shipped models load with their names and sizes", "[models]") {
  for (const std::string file :
       {"mass_on_car.yaml", "rotational_arm.yaml", "rotational_arm_tip.yaml"}) {
    const Model model = LoadModel(ModelPath(file));
    CHECK(file == model.name() + ".yaml");
    CHECK(model.source() == ModelPath(file));
    CHECK(model.dof() == 2);
    CHECK(model.num_inputs() == 1);
    CHECK(model.num_outputs() == 1);
    CHECK(model.output_names() == std::vector<std::string>{"y1"});
    CHECK_FALSE(model.description().empty());
    CHECK(model.content_hash().size() == 16);
    CHECK(model.content_hash().find_first_not_of("0123456789abcdef") == std::string::npos);
    CHECK(Workspace(model).Fits(model));
  }
}

TEST_CASE("mass on car: parameters in file order, alpha in radians", "[models]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  CHECK(model.parameter_names() == std::vector<std::string>{"m1", "m2", "k", "d", "alpha"});
  // alpha: 5 deg is remembered as given in degrees; the others are SI.
  CHECK(model.parameter_display_units() ==
        std::vector<DisplayUnit>{DisplayUnit::kSI, DisplayUnit::kSI, DisplayUnit::kSI,
                                 DisplayUnit::kSI, DisplayUnit::kDegree});
  CHECK(model.coordinates() == std::vector<std::string>{"x", "s"});
  CHECK(model.inputs() == std::vector<std::string>{"F"});
  CHECK(model.FindParameter("alpha") == 4u);
  CHECK_FALSE(model.FindParameter("beta").has_value());
  CHECK(model.parameters()[4] == Approx(5.0 * std::numbers::pi / 180.0).epsilon(kRoundOff));
}

TEST_CASE("mass on car: M, f, B, h, H, h_bar and the Jacobians of f match Eqs. 26-27", "[models]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  Workspace workspace(model);
  Evaluate(model, workspace, kQ, kQDot,
           Quantity::kMassMatrix | Quantity::kForces | Quantity::kInputMatrix | Quantity::kOutput |
               Quantity::kOutputJacobian | Quantity::kOutputBias | Quantity::kForcesJacobians);
  const double m1 = 1.0, m2 = 2.0, k = 5.0, d = 1.0, alpha = 5.0 * std::numbers::pi / 180.0;
  const double x = kQ[0], s = kQ[1], s_dot = kQDot[1];
  CheckClose(
      workspace.mass_matrix,
      (Eigen::Matrix2d() << m1 + m2, m2 * std::cos(alpha), m2 * std::cos(alpha), m2).finished(),
      kRoundOff);
  CheckClose(workspace.forces, Eigen::Vector2d(0.0, k * s + d * s_dot), kRoundOff);
  CheckClose(workspace.input_matrix, Eigen::Vector2d(1.0, 0.0), kRoundOff);
  CheckClose(workspace.output, Eigen::VectorXd::Constant(1, x + s * std::cos(alpha)), kRoundOff);
  CheckClose(workspace.output_jacobian, Eigen::RowVector2d(1.0, std::cos(alpha)), kRoundOff);
  CheckClose(workspace.output_bias, Eigen::VectorXd::Zero(1), kRoundOff);
  CheckClose(workspace.forces_position_jacobian, (Eigen::Matrix2d() << 0, 0, 0, k).finished(),
             kRoundOff);
  CheckClose(workspace.forces_velocity_jacobian, (Eigen::Matrix2d() << 0, 0, 0, d).finished(),
             kRoundOff);
}

TEST_CASE("rotational arm: M matches Eq. 49 and h_bar vanishes for the linear output of Eq. 50",
          "[models]") {
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"));
  Workspace workspace(model);
  Evaluate(model, workspace, kQ, kQDot,
           Quantity::kMassMatrix | Quantity::kOutputJacobian | Quantity::kOutputBias);
  const double l = 1.0, m = 3.438, s = 1.0, beta = kQ[1];
  const double off_diagonal = l * l * m * (1.0 / 3 + std::cos(beta) / 2);
  CheckClose(workspace.mass_matrix,
             (Eigen::Matrix2d() << l * l * m * (5.0 / 3 + std::cos(beta)), off_diagonal,
              off_diagonal, l * l * m / 3)
                 .finished(),
             kRoundOff);
  CheckClose(workspace.output_jacobian, Eigen::RowVector2d(1.0, s / (s + l)), kRoundOff);
  CheckClose(workspace.output_bias, Eigen::VectorXd::Zero(1), kRoundOff);
}

TEST_CASE("rotational arm tip: H(0) = [1, s/(l+s)] and h_bar = H_dot q_dot", "[models]") {
  // With s = l the tip angle is exactly alpha + beta/2 (the sum of two equal vectors bisects
  // them), a linear output with h_bar = 0; s = l/2 makes it nonlinear.
  const Model model = LoadModel(ModelPath("rotational_arm_tip.yaml"), {{"s", "0.5"}});
  Workspace workspace(model);
  Evaluate(model, workspace, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(),
           Quantity::kOutputJacobian);
  const double l = 1.0, s = 0.5;
  CheckClose(workspace.output_jacobian, Eigen::RowVector2d(1.0, s / (l + s)), kRoundOff);

  // h_bar (paper Eq. 5) is the rate of change of H q_dot along the motion.
  const auto output_rate = [&](const Eigen::VectorXd& q, const Eigen::VectorXd&) {
    Evaluate(model, workspace, q, kQDot, Quantity::kOutputJacobian);
    return Eigen::VectorXd(workspace.output_jacobian * kQDot);
  };
  const Eigen::VectorXd expected =
      CentralDifference(output_rate, kQ, kQDot, kQDot, Eigen::Vector2d::Zero());
  Evaluate(model, workspace, kQ, kQDot, Quantity::kOutputBias);
  CheckClose(workspace.output_bias, expected, kFiniteDifferenceTolerance);
  CHECK(std::abs(workspace.output_bias[0]) > kFiniteDifferenceTolerance);  // not trivially zero
}

// Each derived Jacobian equals central differences of the quantity it differentiates.
TEST_CASE("every derived Jacobian matches central finite differences", "[models]") {
  // The tip model with s != l, so that its output is nonlinear (see the test above).
  const std::vector<std::pair<std::string, std::vector<ParameterOverride>>> models = {
      {"mass_on_car.yaml", {}},
      {"rotational_arm.yaml", {}},
      {"rotational_arm_tip.yaml", {{"s", "0.5"}}}};
  for (const auto& [file, overrides] : models) {
    INFO(file);
    const Model model = LoadModel(ModelPath(file), overrides);
    Workspace workspace(model);
    // `result` is the workspace member that Evaluate() fills for `quantity`.
    const auto evaluated = [&model, &workspace](Quantity quantity, const auto& result) {
      return [&model, &workspace, &result, quantity](const Eigen::VectorXd& q,
                                                     const Eigen::VectorXd& q_dot) {
        Evaluate(model, workspace, q, q_dot, quantity);
        return Flat(result);
      };
    };
    const auto forces = evaluated(Quantity::kForces, workspace.forces);
    const auto input = evaluated(Quantity::kInputMatrix, workspace.input_matrix);
    const auto output = evaluated(Quantity::kOutput, workspace.output);

    for (Eigen::Index k = 0; k < 2; ++k) {
      const Eigen::Vector2d unit = Eigen::Vector2d::Unit(k), none = Eigen::Vector2d::Zero();
      const Eigen::VectorXd d_forces_dq = CentralDifference(forces, kQ, kQDot, unit, none);
      const Eigen::VectorXd d_forces_dq_dot = CentralDifference(forces, kQ, kQDot, none, unit);
      const Eigen::VectorXd d_input_dq = CentralDifference(input, kQ, kQDot, unit, none);
      const Eigen::VectorXd d_output_dq = CentralDifference(output, kQ, kQDot, unit, none);

      Evaluate(model, workspace, kQ, kQDot,
               Quantity::kForcesJacobians | Quantity::kInputMatrixDerivatives |
                   Quantity::kOutputJacobian);
      const auto i = static_cast<std::size_t>(k);
      CheckClose(workspace.forces_position_jacobian.col(k), d_forces_dq,
                 kFiniteDifferenceTolerance);
      CheckClose(workspace.forces_velocity_jacobian.col(k), d_forces_dq_dot,
                 kFiniteDifferenceTolerance);
      CheckClose(Flat(workspace.input_matrix_derivatives[i]), d_input_dq,
                 kFiniteDifferenceTolerance);
      CheckClose(workspace.output_jacobian.col(k), d_output_dq, kFiniteDifferenceTolerance);
    }
  }
}

// The forward-mode route (dual numbers through the programs of f and B) against the symbolic
// Jacobians' programs, a second derivation, on every model file that loads.
TEST_CASE("forward-mode Jacobians equal the symbolic ones on every model file", "[models]") {
  int compared = 0;
  for (const std::string& directory :
       {ModelPath(""), testing::TestDataPath(""), testing::TestDataPath("energy_forms")}) {
    for (const auto& entry : std::filesystem::directory_iterator(directory)) {
      if (entry.path().extension() != ".yaml") continue;
      std::optional<Model> model;
      try {
        model = LoadModel(entry.path().string());
      } catch (const Error&) {
        continue;  // the error-case files and linear models
      }
      INFO(entry.path().string());
      REQUIRE(model->symbolic().has_symbolic_jacobians());
      const auto n = Eigen::Index(model->dof());
      Eigen::VectorXd q(n), q_dot(n);
      for (Eigen::Index j = 0; j < n; ++j) {
        q[j] = 0.31 - 0.17 * double(j);
        q_dot[j] = -0.23 + 0.11 * double(j);
      }
      Workspace symbolic(*model), forward(*model);
      const unsigned jacobians = Quantity::kForcesJacobians | Quantity::kInputMatrixDerivatives;
      Evaluate(*model, symbolic, q, q_dot, jacobians);
      EvaluateByForwardMode(*model, forward, q, q_dot, jacobians);
      CheckClose(forward.forces_position_jacobian, symbolic.forces_position_jacobian, 1e-13);
      CheckClose(forward.forces_velocity_jacobian, symbolic.forces_velocity_jacobian, 1e-13);
      for (std::size_t k = 0; k < model->dof(); ++k) {
        CheckClose(forward.input_matrix_derivatives[k], symbolic.input_matrix_derivatives[k],
                   1e-13);
      }
      ++compared;
    }
  }
  CHECK(compared >= 25);
}

// A force with 1200 distinct monomials: past the budget for symbolic Jacobians, so the model has
// no program for them and Evaluate differentiates f in forward mode, checked against central
// differences.
TEST_CASE("a model past the Jacobian budget is differentiated in forward mode", "[models]") {
  std::string force = "k*s";
  for (int a = 0; a < 12; ++a) {
    for (int b = 0; b < 10; ++b) {
      for (int c = 0; c < 10; ++c) {
        force += " + 1e-4*x^" + std::to_string(a) + "*s^" + std::to_string(b) + "*s_dot^" +
                 std::to_string(c);
      }
    }
  }
  const Model model = LoadModelFromString(
      "name: large\nparameters: {m: 1.0, k: 5.0}\ncoordinates: [x, s]\ninputs: [F]\n"
      "mass_matrix: [[2*m, m], [m, m]]\nforces: [0, \"" +
          force + "\"]\ninput_matrix: [[1], [0]]\noutputs: [x + s]\n",
      "large");
  REQUIRE_FALSE(model.symbolic().has_symbolic_jacobians());
  CHECK_FALSE(model.has_program(Quantity::kForcesJacobians));
  CHECK_FALSE(model.has_zero_dynamics_polynomial());
  Workspace workspace(model);
  const Eigen::Vector2d q(0.3, -0.4), q_dot(0.2, 0.5);
  const auto forces = [&](const Eigen::VectorXd& at_q, const Eigen::VectorXd& at_q_dot) {
    Evaluate(model, workspace, at_q, at_q_dot, Quantity::kForces);
    return Flat(workspace.forces);
  };
  for (Eigen::Index k = 0; k < 2; ++k) {
    const Eigen::Vector2d unit = Eigen::Vector2d::Unit(k), none = Eigen::Vector2d::Zero();
    const Eigen::VectorXd by_q = CentralDifference(forces, q, q_dot, unit, none);
    const Eigen::VectorXd by_q_dot = CentralDifference(forces, q, q_dot, none, unit);
    Evaluate(model, workspace, q, q_dot, Quantity::kForcesJacobians);
    CheckClose(workspace.forces_position_jacobian.col(k), by_q, kFiniteDifferenceTolerance);
    CheckClose(workspace.forces_velocity_jacobian.col(k), by_q_dot, kFiniteDifferenceTolerance);
  }
}

TEST_CASE("Evaluate computes only the quantities asked for", "[models]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  Workspace workspace(model);
  Evaluate(model, workspace, kQ, kQDot, Quantity::kOutput);
  CHECK(workspace.output[0] != 0.0);
  CHECK(workspace.mass_matrix.isZero());
}

TEST_CASE("Evaluate uses the workspace parameters, which sweeps change per point", "[models]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  Workspace workspace(model);
  workspace.parameters[*model.FindParameter("m2")] = 7.0;
  Evaluate(model, workspace, kQ, kQDot, Quantity::kMassMatrix);
  CHECK(workspace.mass_matrix(1, 1) == 7.0);
}

TEST_CASE("--set alpha=90 deg overrides the nominal value in radians", "[models]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "90 deg"}, {"d", "0"}});
  CHECK(model.parameters()[4] == Approx(std::numbers::pi / 2).epsilon(kRoundOff));
  CHECK(model.parameters()[3] == 0.0);
  Workspace workspace(model);
  Evaluate(model, workspace, kQ, kQDot, Quantity::kMassMatrix);
  CHECK(workspace.mass_matrix(0, 1) == Approx(0.0).margin(kRoundOff));  // m2 cos(90 deg)
}

TEST_CASE("an override of an unknown parameter lists the known ones", "[models]") {
  REQUIRE_THROWS_MATCHES(
      LoadModel(ModelPath("mass_on_car.yaml"), {{"kk", "1"}}), ParameterOverrideError,
      Catch::Message(
          "parameter override kk=1: unknown parameter 'kk' (known: m1, m2, k, d, alpha)"));
}

TEST_CASE("an override that is not a number says how to write one", "[models]") {
  REQUIRE_THROWS_MATCHES(
      LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "abc"}}), ParameterOverrideError,
      Catch::Message("parameter override alpha=abc: not a number (use e.g. 5 or \"5 deg\")"));
}

// Reference FNV-1a 64 (http://www.isthe.com/chongo/tech/comp/fnv/), written out independently.
std::string ReferenceFnv1a(const std::string& bytes) {
  std::uint64_t hash = 14695981039346656037ull;
  for (const char byte : bytes) {
    hash = (hash ^ static_cast<unsigned char>(byte)) * 1099511628211ull;
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(hash));
  return hex;
}

std::string ReadText(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

TEST_CASE("the content hash is FNV-1a 64 of the file bytes as 16 hex digits", "[models]") {
  REQUIRE(ReferenceFnv1a("a") == "af63dc4c8601ec8c");  // published test vector
  const std::string text = ReadText(ModelPath("mass_on_car.yaml"));
  CHECK(LoadModel(ModelPath("mass_on_car.yaml")).content_hash() == ReferenceFnv1a(text));
  CHECK(LoadModelFromString(text + "# comment\n", "edited").content_hash() ==
        ReferenceFnv1a(text + "# comment\n"));
}

TEST_CASE("the symbolic view holds the expressions the programs were compiled from", "[models]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const SymbolicModel& symbolic = model.symbolic();
  const GiNaC::ex alpha = symbolic.parameters().at(4);
  const GiNaC::ex s = symbolic.coordinates().at(1);
  CHECK((symbolic.output()(0, 0) - (symbolic.coordinates().at(0) + s * GiNaC::cos(alpha)))
            .expand()
            .is_zero());
  CHECK(symbolic.velocities().at(1).get_name() == "s_dot");
  CHECK(symbolic.ProgramInputs().size() == 9);
  const GiNaC::ex nominal =
      symbolic.SubstituteParameters(symbolic.output_jacobian()(0, 1), model.parameters());
  REQUIRE(GiNaC::is_a<GiNaC::numeric>(nominal.evalf()));
  CHECK(GiNaC::ex_to<GiNaC::numeric>(nominal.evalf()).to_double() ==
        Approx(std::cos(model.parameters()[4])).epsilon(kRoundOff));
}

TEST_CASE("an override in degrees marks its parameter as given in degrees", "[models]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"d", "2 deg"}, {"alpha", "0.1"}});
  // d is now shown in degrees; alpha stays in degrees (the file gave it so), and its bare
  // override is read in degrees too (issue #34: degrees stay degrees), held in SI.
  CHECK(model.parameter_display_units()[3] == DisplayUnit::kDegree);
  CHECK(model.parameter_display_units()[4] == DisplayUnit::kDegree);
  CHECK(model.parameters()[4] == DegreesToRadians(0.1));
  CHECK(model.parameter_display_units()[2] == DisplayUnit::kSI);
  // A unit named is kept: radians for an angle declared in degrees.
  const Model radians = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0.1 rad"}});
  CHECK(radians.parameters()[4] == 0.1);
}

// A force of thousands of terms (issue #31): compiled from the canonical form servokit reads it
// into, its GiNaC form built only when asked for. Both must give the value the terms add up to,
// summed here in double precision.
TEST_CASE("a force of thousands of terms is compiled as read and built in GiNaC on demand",
          "[models]") {
  constexpr int kTerms = 4000;
  const double x = 0.3, s = -0.7, k = 5.0;
  std::ostringstream forces;
  double expected = k * s;
  forces << "k*s";
  for (int i = 0; i < kTerms; ++i) {
    const int coefficient = 1 + i % 9, power_of_x = i % 17, power_of_s = i / 17;
    forces << " + 1e-6*" << coefficient << "*x^" << power_of_x << "*s^" << power_of_s;
    expected += 1e-6 * coefficient * std::pow(x, power_of_x) * std::pow(s, power_of_s);
  }
  const Model model = LoadModelFromString(
      "name: big_force\nparameters: {k: 5}\n"
      "coordinates: [x, s]\ninputs: [u]\n"
      "mass_matrix: [[2, 1], [1, 1]]\n"
      "forces: [\"0\", \"" +
          forces.str() +
          "\"]\n"
          "input_matrix: [[1], [0]]\noutputs: [x]\n",
      "big_force.yaml");
  const SymbolicModel& symbolic = model.symbolic();
  REQUIRE(symbolic.canonical_forces() != nullptr);
  CHECK_FALSE(symbolic.has_symbolic_jacobians());

  Workspace workspace(model);
  Evaluate(model, workspace, Eigen::Vector2d(x, s), Eigen::Vector2d(0.0, 0.0), Quantity::kForces);
  CHECK(std::abs(workspace.forces(1) - expected) <= kRoundOff * std::abs(expected));
  CHECK(workspace.forces(0) == 0.0);

  const SymbolicLock lock;
  const GiNaC::ex built = symbolic.forces()(1, 0);
  GiNaC::exmap at;
  at[symbolic.parameters()[0]] = k;
  at[symbolic.coordinates()[0]] = GiNaC::numeric(x);
  at[symbolic.coordinates()[1]] = GiNaC::numeric(s);
  const double value = GiNaC::ex_to<GiNaC::numeric>(built.subs(at).evalf()).to_double();
  CHECK(std::abs(value - expected) <= kRoundOff * std::abs(expected));
}

TEST_CASE("a small force read from the file is built in GiNaC at load, for its Jacobians",
          "[models]") {
  const Model car = LoadModel(ModelPath("mass_on_car.yaml"));
  CHECK(car.symbolic().canonical_forces() != nullptr);
  CHECK(car.symbolic().has_symbolic_jacobians());
}

}  // namespace
}  // namespace servokit
