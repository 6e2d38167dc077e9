// Stable inversion of linear dynamics x' = A x + g(t) (paper Sect. 5.3, Devasia et al. 1996),
// against the closed form in modal coordinates. For a mode w' = a w + p(t) with p a
// polynomial on [t0, tf] and zero outside, w_p(t) = -sum_j p^(j)(t) / a^(j+1) solves the ODE
// on [t0, tf]; the bounded solution adds the homogeneous part that makes a stable mode
// (Re a < 0) start at rest at t0 and an unstable one (Re a > 0) end at rest at tf, and
// continues as a pure exponential outside (decaying after tf, resp. before t0).
#include "solvers/linear_stable_inversion.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <complex>

#include "base/errors.h"
#include "trajectories/trajectory.h"

namespace servokit {
namespace {

using Complex = std::complex<double>;

constexpr double kT0 = 1.0, kTf = 3.0, kStart = -6.0, kEnd = 10.0;

// The drive: the first derivative of the rest-to-rest polynomial (Eq. 65) from 0 to 1 on
// [t0, tf], a smooth bump; its derivatives are exact.
const RestToRestTrajectory kBump(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), kT0, kTf);
double Bump(double t, int order) { return kBump.Derivative(t, order + 1)(0); }

// The bounded solution of w' = a w + c Bump(t) (closed form of the file comment).
Complex ModalSolution(Complex a, Complex c, double t) {
  auto particular = [&](double time) {
    Complex sum = 0.0;
    Complex power = a;
    for (int j = 0; j <= 9; ++j) {  // Bump is a polynomial of degree 8 on [t0, tf]
      sum -= c * Bump(std::clamp(time, kT0, kTf), j) / power;
      power *= a;
    }
    return sum;
  };
  if (a.real() < 0) {
    if (t <= kT0) return 0.0;
    const double inside = std::min(t, kTf);
    const Complex value = particular(inside) - particular(kT0) * std::exp(a * (inside - kT0));
    return t <= kTf ? value : value * std::exp(a * (t - kTf));
  }
  if (t >= kTf) return 0.0;
  const double inside = std::max(t, kT0);
  const Complex value = particular(inside) - particular(kTf) * std::exp(a * (inside - kTf));
  return t >= kT0 ? value : value * std::exp(a * (t - kT0));
}

TEST_CASE("linear stable inversion matches the modal closed form, real and complex modes",
          "[solvers]") {
  // A has an unstable pair 1 +- 2i, an unstable 0.5 and a stable -3, in coordinates mixed by
  // a non-orthogonal T; g = b Bump(t).
  Eigen::MatrixXd modal = Eigen::MatrixXd::Zero(4, 4);
  modal.topLeftCorner(2, 2) << 1.0, 2.0, -2.0, 1.0;
  modal(2, 2) = 0.5;
  modal(3, 3) = -3.0;
  Eigen::MatrixXd mixing(4, 4);
  mixing << 1.0, 0.3, 0.0, 0.2, -0.4, 1.0, 0.5, 0.0, 0.1, 0.0, 1.0, 0.7, 0.0, 0.2, -0.3, 1.0;
  const Eigen::MatrixXd state_matrix = mixing * modal * mixing.inverse();
  const Eigen::Vector4d direction(1.0, -0.5, 0.25, 2.0);

  const HyperbolicSplit split = SplitHyperbolic(state_matrix);
  CHECK(split.stable_basis.cols() == 1);
  CHECK(split.unstable_basis.cols() == 3);
  // The reduced matrices keep the spectrum: -3 alone on the stable side.
  CHECK(split.stable_matrix(0, 0) == Approx(-3.0).epsilon(1e-12));

  std::vector<double> times;
  for (int k = 0; k <= 160; ++k) times.push_back(kStart + (kEnd - kStart) * k / 160.0);
  IntegratorOptions options;  // tight: this is the reference for the nonlinear solver
  options.rtol = 1e-12;
  options.atol = 1e-14;
  const LinearStableInversion result = SolveLinearStableInversion(
      split, [&](double t) -> Eigen::VectorXd { return direction * Bump(t, 0); }, kStart, kEnd,
      times, {kT0, kTf}, options);
  REQUIRE(result.summary.IsUsable());

  // Reference: complex eigen-decomposition of A (a second route), each mode in closed form.
  const Eigen::ComplexEigenSolver<Eigen::MatrixXd> eigen(state_matrix);
  const Eigen::MatrixXcd vectors = eigen.eigenvectors();
  const Eigen::VectorXcd weights = vectors.inverse() * direction.cast<Complex>();
  double max_error = 0.0, max_size = 0.0, before_motion = 0.0;
  for (std::size_t i = 0; i < times.size(); ++i) {
    Eigen::VectorXcd exact = Eigen::VectorXcd::Zero(4);
    for (Eigen::Index mode = 0; mode < 4; ++mode) {
      exact +=
          vectors.col(mode) * ModalSolution(eigen.eigenvalues()(mode), weights(mode), times[i]);
    }
    CHECK(exact.imag().norm() < 1e-9);  // conjugate modes pair up
    max_error = std::max(max_error, (result.states[i] - exact.real()).cwiseAbs().maxCoeff());
    max_size = std::max(max_size, exact.real().cwiseAbs().maxCoeff());
    if (times[i] < kT0) before_motion = std::max(before_motion, result.states[i].norm());
  }
  WARN("linear stable inversion: max error " << max_error << " of max |x| " << max_size);
  // The reference carries the round-off of its series: for a = 0.5 the terms p^(8)/a^9 reach
  // 2.5e7 and cancel to O(1), leaving ~5e-9; the integration itself is at 1e-12.
  CHECK(max_error <= 2e-8 * max_size);
  // Non-causal: the unstable modes move before the drive starts at t0.
  CHECK(before_motion > 1e-3 * max_size);
}

TEST_CASE("stable inversion refuses non-hyperbolic dynamics and names the eigenvalues",
          "[solvers]") {
  // Undamped oscillator at 2.887 Hz (the mass on car, alpha = 5 deg, d = 0): +-18.14i.
  Eigen::MatrixXd oscillator(2, 2);
  const double omega = 2 * M_PI * 2.887;
  oscillator << 0.0, 1.0, -omega * omega, 0.0;
  CHECK_THROWS_AS(SplitHyperbolic(oscillator), NoSolution);
  CHECK_THROWS_WITH(SplitHyperbolic(oscillator),
                    Catch::Contains("imaginary axis") && Catch::Contains("18.1"));
}

TEST_CASE("a defective (Jordan) unstable block is split all the same", "[solvers]") {
  // [[2, 1], [0, 2]] has one eigenvector only; the sign function still gives the subspace.
  Eigen::MatrixXd jordan = Eigen::MatrixXd::Zero(3, 3);
  jordan << 2.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, -1.0;
  const HyperbolicSplit split = SplitHyperbolic(jordan);
  CHECK(split.unstable_basis.cols() == 2);
  CHECK(split.stable_basis.cols() == 1);
  CHECK((split.unstable_matrix.eigenvalues().real().array() - 2.0).abs().maxCoeff() < 1e-6);
}

}  // namespace
}  // namespace servokit
