// Models beyond the paper's two examples: six coordinates and two inputs.
//
// Chain of six masses m joined by springs k, force on mass 1 (models/mass_spring_chain.yaml):
//  - output x6: the force reaches x_j only through j-1 springs, so y^(2j) is the first
//    derivative of y = x_j that F enters: relative degree 12 = 2n, no internal dynamics (flat,
//    Blajer 1997b), index 13, P = 0 (tangential).
//  - output x1 (collocated): relative degree 2, ideal orthogonal; holding x1 leaves masses 2..6
//    as a chain fixed at one end and free at the other, stiffness (k/m) tridiag(-1, 2, -1) with
//    last diagonal entry 1, whose eigenvalues are 4 (k/m) sin^2((2j-1) pi / (2(2N+1))), N = 5.
//    The zero dynamics is undamped: lambda = +-i 2 sqrt(k/m) sin((2j-1) pi / 22).
//  - output x3: relative degree 6, tangential, index 7; masses 4..6 form the fixed-free chain of
//    N = 3: lambda = +-i 2 sqrt(k/m) sin((2j-1) pi / 14), internal order 6.
//
// Gantry crane (models/gantry_crane.yaml), load position output, at rest (theta = 0):
//  M = [[mt+m, 0, m L0], [0, mw+m, 0], [m L0, 0, m L0^2]], H = [[1, 0, L0], [0, 1, 0]], B = [I; 0].
//  M^-1 e1 = [1/mt, 0, -1/(mt L0)], so H M^-1 e1 = 0, and P = [[0, 0], [0, 1/(mw+m)]]: rank 1,
//  mixed. Linearized: y1'' = -g theta and theta'' = -(F + (mt+m) g theta)/(mt L0), so
//  y1'''' = g F / (mt L0) + ...: relative degrees (4, 2), decoupling matrix
//  [[g/(mt L0), 0], [0, 1/(mw+m)]] regular, 4 + 2 = 6 = 2n: flat, index 5 (the crane of
//  Blajer & Kolodziejczyk has index 5, paper Sect. 2.3). At rest the hoist holds W = -m g.
//
// Two inputs with a singular decoupling matrix (tests/data/two_input_singular_decoupling.yaml):
//  y1 = xa, y2 = xa + xc; u1 drives a, u2 drives b, spring k between b and c, spring-damper
//  (kd, dd) between a and d. y1'' = y2'' - k(xb - xc)/mc = u1/ma + ..., so P = [[1/ma, 0],
//  [1/ma, 0]] (rank 1, mixed), relative degrees (2, 2) with that singular decoupling matrix:
//  no vector relative degree. y2 - y1 = xc has relative degree 4 in u2, so the infinite zeros
//  have orders {2, 4} and the index is 5. Holding y = 0 holds xa, xc and (through mass c) xb;
//  mass d is left: md xd'' + dd xd' + kd xd = 0, the zero dynamics (order 2).
#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>

#include "tests/analysis/classify_helpers.h"

namespace servokit {
namespace {

using testing::ClassifyFile;
using testing::ModelPath;
using testing::QuadraticRoots;
using testing::TestDataPath;

constexpr double kChainMass = 1.0, kChainSpring = 100.0;

// +-i omega_j of a fixed-free chain of `masses` masses, sorted as SortEigenvalues does.
std::vector<std::complex<double>> FixedFreeChainZeros(int masses) {
  std::vector<std::complex<double>> zeros;
  for (int j = 1; j <= masses; ++j) {
    const double omega = 2 * std::sqrt(kChainSpring / kChainMass) *
                         std::sin((2 * j - 1) * std::numbers::pi / (2 * (2 * masses + 1)));
    zeros.push_back({0.0, omega});
    zeros.push_back({0.0, -omega});
  }
  SortEigenvalues(zeros);
  return zeros;
}

void CheckUndampedZeros(const Classification& c,
                        const std::vector<std::complex<double>>& expected) {
  REQUIRE(c.zero_dynamics.eigenvalues.size() == expected.size());
  // Compare imaginary parts sorted (real parts are round-off: |Re| <= 1e-9 |lambda|).
  std::vector<double> computed_imag, expected_imag;
  for (const auto& z : c.zero_dynamics.eigenvalues) {
    CHECK(std::abs(z.real()) <= 1e-9 * std::abs(z));
    computed_imag.push_back(z.imag());
  }
  for (const auto& z : expected) expected_imag.push_back(z.imag());
  std::sort(computed_imag.begin(), computed_imag.end());
  std::sort(expected_imag.begin(), expected_imag.end());
  for (std::size_t i = 0; i < expected_imag.size(); ++i) {
    CHECK(computed_imag[i] == Approx(expected_imag[i]).epsilon(1e-9));
  }
  CHECK(c.zero_dynamics.stability == Stability::kCritical);
  REQUIRE(c.cross_check.has_value());
  CHECK(c.cross_check->agrees);
}

TEST_CASE("six-mass chain with the last mass as output is flat with relative degree 12",
          "[analysis]") {
  const Classification c = ClassifyFile(ModelPath("mass_spring_chain.yaml"));
  CHECK(c.decoupling.realization == Realization::kTangential);
  CHECK(c.structure.relative_degree == std::vector<int>{12});
  CHECK(c.structure.differentiation_index == 13);
  CHECK(c.structure.projected_index == 11);
  CHECK(c.structure.internal_dynamics_order == 0);
  CHECK(c.flat);
  CHECK(c.cross_check->invariant_zeros.empty());
}

TEST_CASE("six-mass chain, collocated output: ideal orthogonal, fixed-free chain of five",
          "[analysis]") {
  const Classification c = ClassifyFile(TestDataPath("chain_output_x1.yaml"));
  CHECK(c.decoupling.realization == Realization::kIdealOrthogonal);
  CHECK(c.structure.differentiation_index == 3);
  CHECK(c.structure.internal_dynamics_order == 10);
  CheckUndampedZeros(c, FixedFreeChainZeros(5));
  CHECK(c.zero_dynamics.modes.size() == 5);
}

TEST_CASE("six-mass chain, third mass as output: tangential, internal order 6", "[analysis]") {
  const Classification c = ClassifyFile(TestDataPath("chain_output_x3.yaml"));
  CHECK(c.decoupling.realization == Realization::kTangential);
  CHECK(c.structure.relative_degree == std::vector<int>{6});
  CHECK(c.structure.differentiation_index == 7);
  CHECK(c.structure.internal_dynamics_order == 6);
  CheckUndampedZeros(c, FixedFreeChainZeros(3));
}

TEST_CASE("gantry crane with load-position output: mixed realization, index 5, flat",
          "[analysis]") {
  const double mt = 10, mw = 2, m = 5, g = 9.81, L0 = 2;
  const Classification c = ClassifyFile(ModelPath("gantry_crane.yaml"));
  CHECK(c.operating_point.u(0) == Approx(0.0).margin(1e-12));
  CHECK(c.operating_point.u(1) == Approx(-m * g).epsilon(1e-12));
  const Eigen::MatrixXd& P = c.decoupling.decoupling_matrix;
  CHECK(P(0, 0) == Approx(0.0).margin(1e-14));
  CHECK(P(0, 1) == Approx(0.0).margin(1e-14));
  CHECK(P(1, 0) == Approx(0.0).margin(1e-14));
  CHECK(P(1, 1) == Approx(1.0 / (mw + m)).epsilon(1e-12));
  CHECK(c.decoupling.rank == 1);
  CHECK(c.decoupling.realization == Realization::kMixed);
  CHECK(c.structure.relative_degree == std::vector<int>{4, 2});
  CHECK(c.structure.decoupling_matrix_regular);
  CHECK(c.structure.decoupling_matrix(0, 0) == Approx(g / (mt * L0)).epsilon(1e-10));
  CHECK(c.structure.decoupling_matrix(1, 1) == Approx(1.0 / (mw + m)).epsilon(1e-10));
  CHECK(c.structure.infinite_zero_orders == std::vector<int>{2, 4});
  CHECK(c.structure.differentiation_index == 5);
  CHECK(c.structure.projected_index == 3);
  CHECK(c.flat);
}

TEST_CASE("gantry crane held at another load position: Newton finds x and r", "[analysis]") {
  ClassificationOptions options;
  options.operating_point.y0 = Eigen::Vector2d(0.5, 2.2);
  const Classification c = ClassifyFile(ModelPath("gantry_crane.yaml"), {}, options);
  CHECK(c.operating_point.q(0) == Approx(0.5).epsilon(1e-12));
  CHECK(c.operating_point.q(1) == Approx(0.2).epsilon(1e-12));
  CHECK(c.operating_point.q(2) == Approx(0.0).margin(1e-12));
  CHECK(c.operating_point.newton_iterations > 0);
  CHECK(c.flat);
}

TEST_CASE("two inputs with a singular decoupling matrix: orders {2, 4}, index 5, stable zeros",
          "[analysis]") {
  const double ma = 1, md = 0.5, kd = 8, dd = 0.6;
  const Classification c = ClassifyFile(TestDataPath("two_input_singular_decoupling.yaml"));
  const Eigen::MatrixXd& P = c.decoupling.decoupling_matrix;
  CHECK(P(0, 0) == Approx(1 / ma));
  CHECK(P(1, 0) == Approx(1 / ma));
  CHECK(P(0, 1) == Approx(0.0).margin(1e-14));
  CHECK(P(1, 1) == Approx(0.0).margin(1e-14));
  CHECK(c.decoupling.realization == Realization::kMixed);
  CHECK(c.structure.relative_degree == std::vector<int>{2, 2});
  CHECK_FALSE(c.structure.decoupling_matrix_regular);
  CHECK(c.structure.infinite_zero_orders == std::vector<int>{2, 4});
  CHECK(c.structure.differentiation_index == 5);
  CHECK(c.structure.internal_dynamics_order == 2);
  const auto expected = QuadraticRoots(md, dd, kd);
  REQUIRE(c.zero_dynamics.eigenvalues.size() == 2);
  for (std::size_t i = 0; i < 2; ++i) {
    CHECK(std::abs(c.zero_dynamics.eigenvalues[i] - expected[i]) <= 1e-9 * std::abs(expected[i]));
  }
  CHECK(c.zero_dynamics.stability == Stability::kAsymptoticallyStable);
  CHECK(c.cross_check->agrees);
}

}  // namespace
}  // namespace servokit
