// Rest-to-rest trajectories (paper Eq. 65), against the paper's printed coefficients and
// against independent numerical checks.
#include "trajectories/trajectory.h"

#include <ginac/ginac.h>

#include <catch2/catch.hpp>
#include <cmath>

#include "base/errors.h"

namespace servokit {
namespace {

TEST_CASE("the order-4 rest-to-rest polynomial is the paper's Eq. (65)", "[solvers][paper]") {
  // 126 tau^5 - 420 tau^6 + 540 tau^7 - 315 tau^8 + 70 tau^9.
  const std::vector<double> expected = {0, 0, 0, 0, 0, 126, -420, 540, -315, 70};
  CHECK(RestToRestCoefficients(4) == expected);
}

TEST_CASE("rest-to-rest polynomials of other orders: the quintic and the cubic", "[solvers]") {
  // k = 1: 3 tau^2 - 2 tau^3; k = 2: 10 tau^3 - 15 tau^4 + 6 tau^5 (the classic smoothsteps).
  CHECK(RestToRestCoefficients(1) == std::vector<double>{0, 0, 3, -2});
  CHECK(RestToRestCoefficients(2) == std::vector<double>{0, 0, 0, 10, -15, 6});
}

TEST_CASE("p_k reaches 1 and its first k derivatives vanish at both ends", "[solvers]") {
  for (const int k : {3, 4, 6, 8}) {
    const RestToRestTrajectory trajectory(Eigen::VectorXd::Constant(1, 0.0),
                                          Eigen::VectorXd::Constant(1, 1.0), 0.0, 1.0, k);
    CHECK(trajectory.Derivative(1.0, 0)(0) == Approx(1.0).epsilon(1e-12));
    for (int order = 1; order <= k; ++order) {
      INFO("k = " << k << ", order " << order);
      CHECK(trajectory.Derivative(0.0, order)(0) == Approx(0.0).margin(1e-9));
      CHECK(trajectory.Derivative(1.0, order)(0) == Approx(0.0).margin(1e-9));
    }
    CHECK(std::abs(trajectory.Derivative(0.0, k + 1)(0)) > 1.0);  // first non-vanishing one
  }
}

TEST_CASE("derivatives of the paper's trajectory match finite differences", "[solvers][paper]") {
  // y from 0.5 m to 2.5 m between 0 and 6 s (paper Sect. 5.1, Fig. 9).
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Constant(1, 0.5),
                                        Eigen::VectorXd::Constant(1, 2.5), 0.0, 6.0);
  for (const double t : {0.7, 2.0, 3.0, 4.4, 5.9}) {
    for (int order = 1; order <= 5; ++order) {
      // Central difference of the derivative one order lower: O(h^2) error, h = 1e-4.
      const double h = 1e-4;
      const double numeric = (trajectory.Derivative(t + h, order - 1)(0) -
                              trajectory.Derivative(t - h, order - 1)(0)) /
                             (2 * h);
      INFO("t = " << t << ", order " << order);
      CHECK(trajectory.Derivative(t, order)(0) == Approx(numeric).epsilon(1e-6).margin(1e-8));
    }
  }
  CHECK(trajectory.Derivative(3.0, 0)(0) == Approx(1.5));  // half way by symmetry
  CHECK(trajectory.Derivative(8.0, 0)(0) == Approx(2.5));  // at rest after tf
  CHECK(trajectory.Derivative(8.0, 2)(0) == 0.0);
}

TEST_CASE("high derivatives of a high-order rest-to-rest polynomial are accurate up to tf",
          "[solvers]") {
  // p_12 (the six-mass chain needs 12 continuous derivatives): its monomial coefficients
  // alternate in sign up to 1e7, and summed near tau = 1 they cancelled to 1e-5 of the result,
  // which made the chain's u_d noisy before tf. Against exact rational arithmetic (GiNaC):
  // p_k(tau) = tau^(k+1) sum_j C(k+j, j) (1 - tau)^j, differentiated exactly.
  const int k = 12;
  const GiNaC::realsymbol tau("tau");
  GiNaC::ex polynomial = 0;
  for (int j = 0; j <= k; ++j) {
    polynomial += GiNaC::binomial(k + j, j) * GiNaC::pow(1 - tau, j);
  }
  polynomial = (GiNaC::pow(tau, k + 1) * polynomial).expand();
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Constant(1, 0.0),
                                        Eigen::VectorXd::Constant(1, 1.0), 0.0, 1.0, k);
  for (const int thousandths : {30, 250, 500, 750, 970, 999}) {
    const GiNaC::numeric point(thousandths, 1000);
    for (int order = 0; order <= k + 1; ++order) {
      const double exact =
          GiNaC::ex_to<GiNaC::numeric>(polynomial.diff(tau, unsigned(order)).subs(tau == point))
              .to_double();
      const double scale =
          GiNaC::ex_to<GiNaC::numeric>(GiNaC::factorial(k + order) / GiNaC::factorial(k))
              .to_double();  // the size of the order-th derivative's terms
      INFO("tau = " << thousandths / 1000.0 << ", order " << order);
      CHECK(trajectory.Derivative(thousandths / 1000.0, order)(0) ==
            Approx(exact).margin(1e-13 * scale));
    }
  }
  CHECK(trajectory.Derivative(1.0, 0)(0) == 1.0);  // y_d(tf) = yf exactly
}

TEST_CASE("the order is raised when the problem needs more derivatives", "[solvers]") {
  CHECK(RestToRestOrderFor(2) == 4);
  CHECK(RestToRestOrderFor(4) == 4);
  CHECK(RestToRestOrderFor(6) == 6);
}

TEST_CASE("several outputs move together, each from its own y0 to yf", "[solvers]") {
  const RestToRestTrajectory trajectory(Eigen::Vector2d(0.0, 2.0), Eigen::Vector2d(1.0, 0.0), 1.0,
                                        3.0);
  const Eigen::VectorXd middle = trajectory.Derivative(2.0, 0);
  CHECK(middle(0) == Approx(0.5));
  CHECK(middle(1) == Approx(1.0));
}

TEST_CASE("a trajectory with tf <= t0 or mismatched ends is a usage error", "[solvers]") {
  CHECK_THROWS_AS(RestToRestTrajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 2, 1),
                  UsageError);
  CHECK_THROWS_WITH(RestToRestTrajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(2), 0, 1),
                    Catch::Contains("y0 has 1 values, yf 2"));
}

TEST_CASE("a motion too short for its distance is refused naming y0, yf, t0 and tf", "[solvers]") {
  // y_d'' = (yf - y0) p''(tau) / (tf - t0)^2: with tf - t0 = 1e-300 the square underflows and
  // the second derivative is infinite (the first, 1e300 p', is still a double).
  CHECK_THROWS_WITH(
      RestToRestTrajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 0, 1e-300),
      "rest-to-rest: y0 to yf (|yf - y0| = 1) from t0 = 0 to tf = 1e-300: the derivative of "
      "order 2 of y_d overflows (the motion is too short for its distance)");
  // yf - y0 = 2e308 is no double at all: already the first derivative overflows.
  CHECK_THROWS_WITH(RestToRestTrajectory(Eigen::VectorXd::Constant(1, -1e308),
                                         Eigen::VectorXd::Constant(1, 1e308), 0, 1),
                    Catch::Contains("|yf - y0| = inf) from t0 = 0 to tf = 1: the derivative of "
                                    "order 1 of y_d overflows"));
}

TEST_CASE("continuous derivatives are limited to 32, where a one-second motion stays finite",
          "[solvers]") {
  CHECK_THROWS_WITH(RestToRestTrajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 0, 1,
                                         kMaxContinuousDerivatives + 1),
                    "rest-to-rest: continuous derivatives = 33: must be from 1 to 32");
  CHECK_THROWS_WITH(
      RestToRestTrajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 0, 1, 1000000),
      "rest-to-rest: continuous derivatives = 1000000: must be from 1 to 32");
  // p_32 of a unit motion: |p^(n)| <= (2k + 1) C(2k, k) sum_j C(n - 1, j) k!/(k - j)! k!/(k - m)!
  // (Leibniz on p' = tau^k (1 - tau)^k / B(k + 1, k + 1)), which stays below 1.6e109 for every
  // n <= 2k + 1 = 65 (summed exactly in integers, Python).
  const int k = kMaxContinuousDerivatives;
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 0, 1,
                                        k);
  for (const double t : {0.0, 0.01, 0.25, 0.5, 0.99, 1.0}) {
    for (const int order : {1, k, 2 * k + 1}) {
      INFO("t = " << t << ", order " << order);
      const double derivative = trajectory.Derivative(t, order)(0);
      CHECK(std::isfinite(derivative));
      CHECK(std::abs(derivative) < 1.6e109);
    }
  }
}

}  // namespace
}  // namespace servokit
