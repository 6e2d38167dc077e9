// The generated chain and beam (modeling/model_generators.h) against closed forms:
//  - chain: the undamped natural frequencies of a fixed-free chain of N equal masses,
//    omega_i^2 = (4k/m) sin^2((2i - 1) pi / (2 (2N + 1))), i = 1..N;
//  - beam: kinetic and strain energies (and the hub row) for deflections x^2 and x^3, which the
//    Hermite cubics represent exactly and which respect the clamp w(0) = w'(0) = 0, so that the
//    consistent mass and stiffness integrate them without error; the rigid rotation's inertia
//    J + rho_a L^3 / 3; and the clamped cantilever's frequencies converging to the closed form
//    omega_i = (beta_i L)^2 sqrt(EI / (rho_a L^4)), beta_1 L = 1.8751040687,
//    beta_2 L = 4.6940911330.
// The beam goes through WriteLinearModel and LoadLinearModel, so the factors are checked too.
#include "modeling/model_generators.h"

#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "base/errors.h"
#include "modeling/linear_model.h"
#include "tests/test_files.h"

namespace servokit {
namespace {

using testing::TemporaryDirectory;

namespace fs = std::filesystem;

// The generated files, written and read back: what a user of `servokit generate` gets.
LinearModel WriteAndLoad(const LinearModelFiles& files) {
  TemporaryDirectory directory;
  return LoadLinearModel(WriteLinearModel(files, directory.path()));
}

// The eigenvalues lambda of a x = lambda b x (b positive definite), ascending.
Eigen::VectorXd SortedGeneralizedEigenvalues(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> solver(a, b);
  REQUIRE(solver.info() == Eigen::Success);
  return solver.eigenvalues();  // ascending
}

TEST_CASE("the generators' default options are valid", "[models]") {
  CHECK_NOTHROW(ChainOptions().Validate());
  CHECK_NOTHROW(BeamOptions().Validate());
}

TEST_CASE("the chain's frequencies are those of a fixed-free chain of equal masses", "[models]") {
  for (const long masses : {1L, 2L, 7L, 40L}) {
    ChainOptions options;
    options.masses = masses;
    options.mass = 0.7;
    options.stiffness = 3.2;
    options.damping = 0.05;
    options.input_mass = 1;
    options.output_mass = masses;
    const LinearModel model = WriteAndLoad(GenerateChain(options));
    const LinearMatrices matrices = AssembleLinearMatrices(model, model.parameters());
    REQUIRE(model.dof() == static_cast<std::size_t>(masses));
    CHECK(model.parameter_names() == std::vector<std::string>{"m", "k", "d"});
    CHECK(Eigen::MatrixXd(matrices.mass) == 0.7 * Eigen::MatrixXd::Identity(masses, masses));
    // D = d T and K = k T with the same T.
    CHECK((Eigen::MatrixXd(matrices.damping) / 0.05 - Eigen::MatrixXd(matrices.stiffness) / 3.2)
              .cwiseAbs()
              .maxCoeff() < 1e-13);
    const Eigen::VectorXd squared_frequencies = SortedGeneralizedEigenvalues(
        Eigen::MatrixXd(matrices.stiffness), Eigen::MatrixXd(matrices.mass));
    for (long i = 1; i <= masses; ++i) {
      const double angle = (2.0 * static_cast<double>(i) - 1.0) * std::numbers::pi /
                           (2.0 * (2.0 * static_cast<double>(masses) + 1.0));
      const double expected = 4.0 * 3.2 / 0.7 * std::sin(angle) * std::sin(angle);
      INFO("N = " << masses << ", i = " << i);
      // Symmetric eigensolver: backward error ~ 1e-15 * |K|/m ~ 1e-14 absolute.
      CHECK(squared_frequencies[i - 1] == Approx(expected).epsilon(1e-12).margin(1e-13));
    }
    CHECK(Eigen::MatrixXd(model.input_matrix()) == Eigen::VectorXd::Unit(masses, 0).eval());
    CHECK(Eigen::MatrixXd(model.output_matrix()) ==
          Eigen::RowVectorXd::Unit(masses, masses - 1).eval());
  }
}

struct BeamCase {
  BeamOptions options;
  LinearModel model;
  Eigen::MatrixXd mass, stiffness, damping;
};

BeamCase MakeBeam(long elements) {
  BeamOptions options;
  options.elements = elements;
  options.length = 1.3;
  options.hub_inertia = 0.4;
  options.mass_per_length = 2.1;
  options.bending_stiffness = 7.0;
  options.damping_factor = 3e-3;
  LinearModel model = WriteAndLoad(GenerateBeam(options));
  const LinearMatrices matrices = AssembleLinearMatrices(model, model.parameters());
  return {options, std::move(model), Eigen::MatrixXd(matrices.mass),
          Eigen::MatrixXd(matrices.stiffness), Eigen::MatrixXd(matrices.damping)};
}

// The coordinates of theta and of a deflection w(x) with slope w'(x), at the nodes x_n = n L/N.
template <typename Deflection, typename Slope>
Eigen::VectorXd BeamState(long elements, double length, double theta, Deflection w, Slope slope) {
  Eigen::VectorXd state(2 * elements + 1);
  state[0] = theta;
  for (long n = 1; n <= elements; ++n) {
    const double x = static_cast<double>(n) * length / static_cast<double>(elements);
    state[2 * n - 1] = w(x);
    state[2 * n] = slope(x);
  }
  return state;
}

TEST_CASE("the beam's mass and stiffness integrate cubic deflections exactly", "[models]") {
  for (const long elements : {1L, 3L, 10L}) {
    const BeamCase beam = MakeBeam(elements);
    const double L = beam.options.length, J = beam.options.hub_inertia,
                 rho = beam.options.mass_per_length, EI = beam.options.bending_stiffness;
    INFO("N = " << elements);
    REQUIRE(beam.model.dof() == static_cast<std::size_t>(2 * elements + 1));
    CHECK(beam.model.parameter_names() == std::vector<std::string>{"J", "rho_a", "EI", "beta"});
    // Rigid rotation theta = 1, w = 0: inertia J + int rho x^2 dx.
    CHECK(beam.mass(0, 0) == Approx(J + rho * L * L * L / 3).epsilon(1e-14));
    // theta = 1 with w = x^3: 2T = J + rho int (x + x^3)^2 dx = J + rho (L^3/3 + 2L^5/5 + L^7/7);
    // 2V = EI int (6x)^2 dx = 12 EI L^3.
    const Eigen::VectorXd cubic = BeamState(
        elements, L, 1.0, [](double x) { return x * x * x; }, [](double x) { return 3 * x * x; });
    CHECK(cubic.dot(beam.mass * cubic) ==
          Approx(J + rho * (std::pow(L, 3) / 3 + 2 * std::pow(L, 5) / 5 + std::pow(L, 7) / 7))
              .epsilon(1e-13));
    CHECK(cubic.dot(beam.stiffness * cubic) == Approx(12 * EI * std::pow(L, 3)).epsilon(1e-12));
    // theta = 0.5 with w = x^2 (clamped: w(0) = w'(0) = 0): 2T = 0.25 J + rho int (x/2 + x^2)^2
    // dx = 0.25 J + rho (L^3/12 + L^4/4 + L^5/5); 2V = EI int 2^2 dx = 4 EI L.
    const Eigen::VectorXd quadratic = BeamState(
        elements, L, 0.5, [](double x) { return x * x; }, [](double x) { return 2 * x; });
    CHECK(quadratic.dot(beam.mass * quadratic) ==
          Approx(0.25 * J + rho * (std::pow(L, 3) / 12 + std::pow(L, 4) / 4 + std::pow(L, 5) / 5))
              .epsilon(1e-13));
    CHECK(quadratic.dot(beam.stiffness * quadratic) == Approx(4 * EI * L).epsilon(1e-12));
  }
}

TEST_CASE("the hub row couples the rotation with each deflection; K and B, C as documented",
          "[models]") {
  const long elements = 8;
  const BeamCase beam = MakeBeam(elements);
  const double L = beam.options.length, rho = beam.options.mass_per_length;
  const auto size = static_cast<Eigen::Index>(2 * elements + 1);
  const Eigen::VectorXd rotation = Eigen::VectorXd::Unit(size, 0);
  const Eigen::VectorXd square = BeamState(
      elements, L, 0.0, [](double x) { return x * x; }, [](double x) { return 2 * x; });
  const Eigen::VectorXd cube = BeamState(
      elements, L, 0.0, [](double x) { return x * x * x; }, [](double x) { return 3 * x * x; });
  // The kinetic energy's cross term theta' int rho x w' dx: rho L^4/4 for x^2, rho L^5/5 for x^3.
  CHECK(rotation.dot(beam.mass * square) == Approx(rho * std::pow(L, 4) / 4).epsilon(1e-13));
  CHECK(rotation.dot(beam.mass * cube) == Approx(rho * std::pow(L, 5) / 5).epsilon(1e-13));
  // And between the deflections themselves: rho int x^5 dx.
  CHECK(square.dot(beam.mass * cube) == Approx(rho * std::pow(L, 6) / 6).epsilon(1e-13));
  // A rigid rotation bends nothing: theta has no stiffness (the hub turns freely).
  CHECK((beam.stiffness * rotation).isZero(0.0));
  // The tip's inertial displacement y = L theta + w_N; the torque acts on theta.
  const Eigen::MatrixXd output(beam.model.output_matrix());
  CHECK((output * rotation)(0) == L);
  CHECK((output * cube)(0) == Approx(std::pow(L, 3)).epsilon(1e-15));
  CHECK(Eigen::MatrixXd(beam.model.input_matrix()) == rotation);
  // D = beta K.
  CHECK((beam.damping - beam.options.damping_factor * beam.stiffness).cwiseAbs().maxCoeff() <
        1e-15 * beam.stiffness.cwiseAbs().maxCoeff());
}

TEST_CASE("the clamped beam's first two frequencies converge to Euler-Bernoulli's", "[models]") {
  const double beta_l[2] = {1.8751040687, 4.6940911330};
  // Hermite cubic elements with consistent mass converge as h^4, from above (Rayleigh-Ritz).
  // Measured relative errors (omega_1, omega_2): N = 4: 3.27e-5, 1.17e-3; N = 16: 1.31e-7,
  // 5.11e-6; N = 64: 8.1e-10, 2.01e-8 (omega_1 there nears the 1e-10 of the 11 digits of
  // beta_1 L). The bounds are about twice these.
  const double tolerance[3][2] = {{7e-5, 2.5e-3}, {3e-7, 1e-5}, {2e-9, 5e-8}};
  const long sizes[3] = {4, 16, 64};
  double previous[2] = {1.0, 1.0};
  for (int s = 0; s < 3; ++s) {
    const BeamCase beam = MakeBeam(sizes[s]);
    const double L = beam.options.length;
    const auto n = static_cast<Eigen::Index>(2 * sizes[s]);
    // Hub held: drop theta's row and column. The eigenvalues 1/omega^2 of (M, K) rather than
    // omega^2 of (K, M): a symmetric eigensolver's error is relative to the largest eigenvalue,
    // and K's largest grows as N^4 while the lowest modes are the ones compared here.
    const Eigen::VectorXd inverse_squared = SortedGeneralizedEigenvalues(
        beam.mass.bottomRightCorner(n, n), beam.stiffness.bottomRightCorner(n, n));
    const double squared[2] = {1.0 / inverse_squared[n - 1], 1.0 / inverse_squared[n - 2]};
    for (int i = 0; i < 2; ++i) {
      const double exact = beta_l[i] * beta_l[i] *
                           std::sqrt(beam.options.bending_stiffness /
                                     (beam.options.mass_per_length * std::pow(L, 4)));
      const double error = (std::sqrt(squared[i]) - exact) / exact;
      WARN("N = " << sizes[s] << ": omega_" << i + 1 << " relative error " << error);
      CHECK(error > -1e-10);  // from above, up to the 11 digits of beta_i L
      CHECK(error < tolerance[s][i]);
      if (s < 2) CHECK(error < previous[i] / 100);  // h^4: 256 per factor 4 in N
      previous[i] = error;
    }
  }
}

TEST_CASE("chain output weights: names both ways, and the rows they write", "[models]") {
  for (const auto weights :
       {ChainOutputWeights::kMass, ChainOutputWeights::kLinear, ChainOutputWeights::kUniform}) {
    CHECK(ChainOutputWeightsFromString(ToString(weights)) == weights);
  }
  CHECK_FALSE(ChainOutputWeightsFromString("Linear"));
  ChainOptions chain;
  chain.masses = 4;
  chain.output_weights = ChainOutputWeights::kLinear;
  CHECK(Eigen::MatrixXd(GenerateChain(chain).output_matrix) ==
        Eigen::RowVector4d(0.25, 0.5, 0.75, 1.0));
  chain.output_weights = ChainOutputWeights::kUniform;
  CHECK(Eigen::MatrixXd(GenerateChain(chain).output_matrix) == Eigen::RowVector4d::Constant(0.25));
  chain.output_weights = ChainOutputWeights::kMass;
  chain.output_mass = 3;
  CHECK(Eigen::MatrixXd(GenerateChain(chain).output_matrix) == Eigen::RowVector4d(0, 0, 1, 0));
}

TEST_CASE("bad generator options name the field, the value and the rule", "[models]") {
  ChainOptions chain;
  chain.masses = 0;
  CHECK_THROWS_WITH(chain.Validate(), "ChainOptions::masses = 0: must be from 1 to 10000000");
  chain = ChainOptions();
  chain.masses = 5;
  chain.output_mass = 6;
  CHECK_THROWS_WITH(chain.Validate(),
                    "ChainOptions::output_mass = 6: must be from 1 to masses = 5");
  chain = ChainOptions();
  chain.output_weights = ChainOutputWeights::kLinear;
  chain.output_mass = 2;
  CHECK_THROWS_WITH(chain.Validate(),
                    "ChainOptions::output_mass = 2: applies only to the output weights 'mass' (the "
                    "weights are linear)");
  chain = ChainOptions();
  chain.damping = -1;
  CHECK_THROWS_WITH(GenerateChain(chain),
                    "ChainOptions::damping = -1: must be a finite number >= 0");
  BeamOptions beam;
  beam.mass_per_length = std::nan("");
  CHECK_THROWS_WITH(beam.Validate(),
                    "BeamOptions::mass_per_length = nan: must be a finite number > 0");
  beam = BeamOptions();
  beam.hub_inertia = -0.1;
  CHECK_THROWS_AS(GenerateBeam(beam), UsageError);
}

}  // namespace
}  // namespace servokit
