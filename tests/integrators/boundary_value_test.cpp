// The two-point boundary value solver (bvp4c's collocation) on problems with closed-form
// solutions: a smooth linear one, a boundary layer, the stable-inversion shape (an unstable and
// a stable mode driven by a pulse, paper Sect. 5.3) and the nonlinear Bratu problem; plus the
// options, the size checks and the numerical failures. Each problem is written out with its
// solution above its test.
#include "integrators/boundary_value.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "base/errors.h"

namespace servokit {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

std::vector<double> UniformMesh(double a, double b, int intervals) {
  std::vector<double> mesh;
  for (int i = 0; i <= intervals; ++i) mesh.push_back(a + (b - a) * double(i) / intervals);
  return mesh;
}

std::vector<VectorXd> ConstantGuess(std::size_t points, const VectorXd& value) {
  return std::vector<VectorXd>(points, value);
}

// y'' = c y as the system (y, y')' = (y', c y), with its exact Jacobian.
BvpRightHandSide ScaledSecondDerivative(double c) {
  return [c](double, const VectorXd& y, VectorXd& f, std::string&) {
    f.resize(2);
    f << y(1), c * y(0);
    return true;
  };
}
BvpJacobian ScaledSecondDerivativeJacobian(double c) {
  return [c](double, const VectorXd&, MatrixXd& jacobian, std::string&) {
    jacobian.resize(2, 2);
    jacobian << 0.0, 1.0, c, 0.0;
    return true;
  };
}

// y(a) = left, y(b) = right for the first component.
BoundaryConditions Dirichlet(double left, double right) {
  BoundaryConditions conditions;
  conditions.residual = [left, right](const VectorXd& ya, const VectorXd& yb, VectorXd& residual) {
    residual.resize(2);
    residual << ya(0) - left, yb(0) - right;
  };
  conditions.jacobians = [](const VectorXd&, const VectorXd&, MatrixXd& d_ya, MatrixXd& d_yb) {
    d_ya.setZero(2, 2);
    d_yb.setZero(2, 2);
    d_ya(0, 0) = 1.0;
    d_yb(1, 0) = 1.0;
  };
  return conditions;
}

// y'' = y on [0, 1], y(0) = 1, y(1) = e: y = e^t.
TEST_CASE("a smooth linear problem is solved to the tolerance: y'' = y gives e^t",
          "[integrators]") {
  const std::vector<double> mesh = UniformMesh(0.0, 1.0, 5);
  const BoundaryValueSolution solution = SolveBoundaryValueProblem(
      ScaledSecondDerivative(1.0), ScaledSecondDerivativeJacobian(1.0),
      Dirichlet(1.0, std::exp(1.0)), mesh, ConstantGuess(mesh.size(), VectorXd::Zero(2)), {});
  REQUIRE(solution.summary.IsUsable());
  CAPTURE(solution.mesh.size(), solution.summary.message);
  CHECK(solution.max_residual <= 1e-8);
  // The residual of the cubic interpolant is O(h^3) (its error is O(h^4)): ~ h^3 / 100 <= 1e-8
  // needs h ~ 0.01, about 100-200 points (as bvp4c at RelTol = 1e-8).
  CHECK(solution.mesh.size() < 250);
  double max_error = 0.0;
  for (int k = 0; k <= 100; ++k) {
    const double t = k / 100.0;
    const VectorXd y = solution.Evaluate(t);
    max_error = std::max({max_error, std::abs(y(0) - std::exp(t)), std::abs(y(1) - std::exp(t))});
  }
  // Residual 1e-8 relative to |f| ~ e on a problem with conditioning of order one.
  CHECK(max_error < 1e-8);
}

// eps y'' = y on [-1, 1], y(+-1) = 1, eps = 1e-3: y = cosh(t / sqrt(eps)) / cosh(1 / sqrt(eps)),
// with layers of width sqrt(eps) ~ 0.03 at both ends and y ~ 1e-14 in the middle.
TEST_CASE("a boundary layer draws the mesh to both ends and is resolved to the tolerance",
          "[integrators]") {
  const double eps = 1e-3;
  const double root = std::sqrt(eps);
  const std::vector<double> mesh = UniformMesh(-1.0, 1.0, 10);
  const BoundaryValueSolution solution = SolveBoundaryValueProblem(
      ScaledSecondDerivative(1.0 / eps), ScaledSecondDerivativeJacobian(1.0 / eps),
      Dirichlet(1.0, 1.0), mesh, ConstantGuess(mesh.size(), VectorXd::Zero(2)), {});
  REQUIRE(solution.summary.IsUsable());
  CAPTURE(solution.mesh.size(), solution.summary.message);
  CHECK(solution.max_residual <= 1e-8);
  int near_ends = 0;
  int middle = 0;
  for (const double t : solution.mesh) {
    if (std::abs(t) >= 0.9) ++near_ends;
    if (std::abs(t) <= 0.5) ++middle;
  }
  // Points per unit length: within 0.1 of the ends (length 0.2 in all), where y varies on the
  // scale sqrt(eps), the mesh is several times denser than in the flat middle [-0.5, 0.5]
  // (length 1; about 9 times on this problem).
  CHECK(near_ends / 0.2 > 5.0 * middle / 1.0);
  double max_error = 0.0;
  for (int k = 0; k <= 2000; ++k) {
    const double t = -1.0 + k / 1000.0;
    const double exact = std::cosh(t / root) / std::cosh(1.0 / root);
    max_error = std::max(max_error, std::abs(solution.Evaluate(t)(0) - exact));
  }
  // y is of size 1 in the layers; the residual tolerance 1e-8 bounds the error there.
  CHECK(max_error < 1e-8);
}

// The same boundary layer started on a fine uniform mesh of 2001 points: the flat middle,
// where y ~ 1e-14, does not need them, and pairs of quiet intervals are merged there while the
// layers are refined.
TEST_CASE("quiet intervals of a fine initial mesh are merged while the layers are refined",
          "[integrators]") {
  const double eps = 1e-3;
  const std::vector<double> mesh = UniformMesh(-1.0, 1.0, 2000);
  const BoundaryValueSolution solution = SolveBoundaryValueProblem(
      ScaledSecondDerivative(1.0 / eps), ScaledSecondDerivativeJacobian(1.0 / eps),
      Dirichlet(1.0, 1.0), mesh, ConstantGuess(mesh.size(), VectorXd::Zero(2)), {});
  REQUIRE(solution.summary.IsUsable());
  CAPTURE(solution.mesh.size(), solution.summary.message);
  CHECK(solution.max_residual <= 1e-8);
  const auto middle = std::count_if(solution.mesh.begin(), solution.mesh.end(),
                                    [](double t) { return std::abs(t) <= 0.5; });
  CHECK(middle < 1001 / 2);  // the initial mesh had 1001 points in [-0.5, 0.5]
  const double exact_at_end_of_layer =
      std::cosh(0.9 / std::sqrt(eps)) / std::cosh(1.0 / std::sqrt(eps));
  CHECK(solution.Evaluate(0.9)(0) == Approx(exact_at_end_of_layer).epsilon(1e-8));  // tolerance
}

// Stable inversion in its simplest form (paper Sect. 5.3): x' = A x + b(t), A = diag(2, -3),
// b = (g, g), g(t) = 256 (s (1 - s))^4 with s = (t - 1) / 2 on [1, 3], zero outside (a smooth
// rest-to-rest pulse of height 1). The bounded solution on the real line is
//   x1(t) = -int_t^inf e^{2 (t - tau)} g(tau) dtau,   x2(t) = int_-inf^t e^{-3 (t - tau)} g dtau,
// so x1 = 0 for t >= 3 and x2 = 0 for t <= 1: on [-5, 9] the conditions are x1(9) = 0 (unstable
// component at the end) and x2(-5) = 0 (stable component at the start). x1 is non-causal: it
// is nonzero before the pulse starts.
double Pulse(double t) {
  if (t <= 1.0 || t >= 3.0) return 0.0;
  const double s = (t - 1.0) / 2.0;
  return 256.0 * std::pow(s * (1.0 - s), 4);
}

// Composite Simpson's rule with 20000 intervals (error ~ h^4 ~ 1e-16 relative here).
template <typename Integrand>
double Simpson(Integrand integrand, double a, double b) {
  if (b <= a) return 0.0;
  const int intervals = 20000;
  const double h = (b - a) / intervals;
  double sum = integrand(a) + integrand(b);
  for (int k = 1; k < intervals; ++k) sum += (k % 2 == 1 ? 4.0 : 2.0) * integrand(a + k * h);
  return sum * h / 3.0;
}

double UnstableReference(double t) {
  return -Simpson([t](double tau) { return std::exp(2.0 * (t - tau)) * Pulse(tau); },
                  std::max(t, 1.0), 3.0);
}
double StableReference(double t) {
  return Simpson([t](double tau) { return std::exp(-3.0 * (t - tau)) * Pulse(tau); }, 1.0,
                 std::min(t, 3.0));
}

TEST_CASE("stable inversion: the unstable mode gets an end condition and starts before the pulse",
          "[integrators]") {
  const BvpRightHandSide f = [](double t, const VectorXd& x, VectorXd& out, std::string&) {
    out.resize(2);
    out << 2.0 * x(0) + Pulse(t), -3.0 * x(1) + Pulse(t);
    return true;
  };
  const BvpJacobian jacobian = [](double, const VectorXd&, MatrixXd& out, std::string&) {
    out.setZero(2, 2);
    out(0, 0) = 2.0;
    out(1, 1) = -3.0;
    return true;
  };
  BoundaryConditions conditions;
  conditions.residual = [](const VectorXd& xa, const VectorXd& xb, VectorXd& residual) {
    residual.resize(2);
    residual << xb(0), xa(1);
  };  // jacobians left empty: forward differences
  const std::vector<double> mesh = UniformMesh(-5.0, 9.0, 14);
  const BoundaryValueSolution solution = SolveBoundaryValueProblem(
      f, jacobian, conditions, mesh, ConstantGuess(mesh.size(), VectorXd::Zero(2)), {});
  REQUIRE(solution.summary.IsUsable());
  CAPTURE(solution.mesh.size(), solution.summary.message);
  CHECK(solution.max_residual <= 1e-8);
  double max_error = 0.0;
  for (const double t : {-4.0, -1.0, 0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 8.5}) {
    const VectorXd x = solution.Evaluate(t);
    max_error = std::max(
        {max_error, std::abs(x(0) - UnstableReference(t)), std::abs(x(1) - StableReference(t))});
  }
  // x is of size 0.1-0.3; the residual tolerance 1e-8 relative to |f| ~ 1 bounds the error.
  CHECK(max_error < 1e-8);
  // Non-causal: at t = 0, before the pulse, x1 = -int_1^3 e^{-2 tau} g dtau = -0.0178.
  CHECK(solution.Evaluate(0.0)(0) < -1e-2);
  CHECK(std::abs(solution.Evaluate(0.0)(1)) < 1e-10);  // x2 is causal: zero before the pulse
}

// Lobatto IIIA collocation with s points per interval (BoundaryValueOptions::
// collocation_points) on y'' = y, y(0) = 1, y(1) = e (y = e^t) on fixed uniform meshes (a
// tolerance so loose that no interval is refined): the values at the interval ends converge
// as h^(2s-2) and the collocation polynomial between them as h^(s+1) (Ascher, Mattheij &
// Russell, Thm. 5.140). Halving h must divide the errors by about 2^(2s-2) and 2^(s+1).
TEST_CASE("Lobatto collocation converges with order 2s-2 at the interval ends, s+1 between",
          "[integrators]") {
  for (const int points : {4, 5}) {
    CAPTURE(points);
    BoundaryValueOptions options;
    options.collocation_points = points;
    options.tolerance = 0.5;
    double previous_end_error = 0.0, previous_inner_error = 0.0;
    for (const int intervals : {2, 4, 8}) {
      const std::vector<double> mesh = UniformMesh(0.0, 1.0, intervals);
      const BoundaryValueSolution solution = SolveBoundaryValueProblem(
          ScaledSecondDerivative(1.0), ScaledSecondDerivativeJacobian(1.0),
          Dirichlet(1.0, std::exp(1.0)), mesh, ConstantGuess(mesh.size(), VectorXd::Zero(2)),
          options);
      REQUIRE(solution.summary.IsUsable());
      REQUIRE(solution.summary.steps == intervals);  // not refined
      REQUIRE(solution.nodes_per_interval == points);
      double end_error = 0.0, inner_error = 0.0;
      for (const double t : mesh) {
        end_error = std::max(end_error, std::abs(solution.Evaluate(t)(1) - std::exp(t)));
      }
      for (int k = 0; k < 1000; ++k) {
        const double t = (k + 0.5) / 1000.0;
        inner_error = std::max(inner_error, std::abs(solution.Evaluate(t)(1) - std::exp(t)));
      }
      CAPTURE(intervals, end_error, inner_error);
      if (previous_end_error > 0.0) {
        const double end_ratio = previous_end_error / end_error;
        const double inner_ratio = previous_inner_error / inner_error;
        CAPTURE(end_ratio, inner_ratio);
        // Round-off floor: s = 5 at h = 1/8 reaches ~1e-15 at the ends; skip the ratio there.
        if (end_error > 1e-13)
          CHECK(end_ratio == Approx(std::pow(2.0, 2 * points - 2)).epsilon(0.2));
        CHECK(inner_ratio == Approx(std::pow(2.0, points + 1)).epsilon(0.35));
      }
      previous_end_error = end_error;
      previous_inner_error = inner_error;
    }
  }
}

// The closed-form problems above, solved with 7 Lobatto points per interval to 1e-10: the
// error test holds, with far fewer points than Hermite-Simpson needs at the same tolerance.
TEST_CASE("7-point Lobatto collocation meets a tight tolerance with few points", "[integrators]") {
  BoundaryValueOptions options;
  options.collocation_points = 7;
  options.tolerance = 1e-10;
  options.absolute_tolerance = 1e-12;
  SECTION("e^t") {
    const std::vector<double> mesh = UniformMesh(0.0, 1.0, 2);
    const BoundaryValueSolution solution = SolveBoundaryValueProblem(
        ScaledSecondDerivative(1.0), nullptr, Dirichlet(1.0, std::exp(1.0)), mesh,
        ConstantGuess(mesh.size(), VectorXd::Zero(2)), options);
    REQUIRE(solution.summary.IsUsable());
    CAPTURE(solution.mesh.size(), solution.summary.message);
    CHECK(solution.mesh.size() < 40);
    double max_error = 0.0;
    for (int k = 0; k <= 1000; ++k) {
      const double t = k / 1000.0;
      max_error = std::max(max_error, std::abs(solution.Evaluate(t)(0) - std::exp(t)));
    }
    CHECK(max_error < 1e-10 * std::exp(1.0));
  }
  SECTION("the boundary layer, eps = 1e-3") {
    const double eps = 1e-3;
    const double root = std::sqrt(eps);
    const std::vector<double> mesh = UniformMesh(-1.0, 1.0, 10);
    const BoundaryValueSolution solution = SolveBoundaryValueProblem(
        ScaledSecondDerivative(1.0 / eps), ScaledSecondDerivativeJacobian(1.0 / eps),
        Dirichlet(1.0, 1.0), mesh, ConstantGuess(mesh.size(), VectorXd::Zero(2)), options);
    REQUIRE(solution.summary.IsUsable());
    BoundaryValueOptions hermite_simpson = options;
    hermite_simpson.collocation_points = 3;
    const BoundaryValueSolution fourth_order = SolveBoundaryValueProblem(
        ScaledSecondDerivative(1.0 / eps), ScaledSecondDerivativeJacobian(1.0 / eps),
        Dirichlet(1.0, 1.0), mesh, ConstantGuess(mesh.size(), VectorXd::Zero(2)), hermite_simpson);
    CAPTURE(solution.mesh.size(), fourth_order.mesh.size(), solution.summary.message);
    CHECK(3 * solution.mesh.size() < fourth_order.mesh.size());
    double max_error = 0.0;
    for (int k = 0; k <= 2000; ++k) {
      const double t = -1.0 + k / 1000.0;
      const double exact = std::cosh(t / root) / std::cosh(1.0 / root);
      max_error = std::max(max_error, std::abs(solution.Evaluate(t)(0) - exact));
    }
    CHECK(max_error < 1e-10);
  }
  SECTION("stable inversion of the pulse") {
    const BvpRightHandSide f = [](double t, const VectorXd& x, VectorXd& out, std::string&) {
      out.resize(2);
      out << 2.0 * x(0) + Pulse(t), -3.0 * x(1) + Pulse(t);
      return true;
    };
    BoundaryConditions conditions;
    conditions.residual = [](const VectorXd& xa, const VectorXd& xb, VectorXd& residual) {
      residual.resize(2);
      residual << xb(0), xa(1);
    };
    // The pulse's ends are breakpoints of f (g is C^3 there): mesh points at 1 and 3.
    const std::vector<double> mesh = {-5.0, -3.0, -1.0, 1.0, 2.0, 3.0, 5.0, 7.0, 9.0};
    const BoundaryValueSolution solution = SolveBoundaryValueProblem(
        f, nullptr, conditions, mesh, ConstantGuess(mesh.size(), VectorXd::Zero(2)), options);
    REQUIRE(solution.summary.IsUsable());
    CAPTURE(solution.mesh.size(), solution.summary.message);
    double max_error = 0.0;
    for (const double t : {-4.0, -1.0, 0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 8.5}) {
      const VectorXd x = solution.Evaluate(t);
      max_error = std::max(
          {max_error, std::abs(x(0) - UnstableReference(t)), std::abs(x(1) - StableReference(t))});
    }
    CHECK(max_error < 1e-10);
  }
}

// Bratu: y'' + lambda e^y = 0 on [0, 1], y(0) = y(1) = 0, lambda = 1. The lower solution is
// y = -2 ln(cosh((t - 1/2) theta / 2) / cosh(theta / 4)) with theta = sqrt(2 lambda)
// cosh(theta / 4) (the smaller root, theta ~ 1.5172); Newton from y = 0 finds it.
TEST_CASE("the nonlinear Bratu problem converges to its lower solution from a zero guess",
          "[integrators]") {
  double theta = 1.0;
  for (int k = 0; k < 50; ++k) {  // Newton on theta - sqrt(2) cosh(theta / 4) = 0
    const double residual = theta - std::sqrt(2.0) * std::cosh(theta / 4.0);
    theta -= residual / (1.0 - std::sqrt(2.0) / 4.0 * std::sinh(theta / 4.0));
  }
  REQUIRE(theta == Approx(1.517).margin(1e-3));  // the lower root
  const BvpRightHandSide f = [](double, const VectorXd& y, VectorXd& out, std::string&) {
    out.resize(2);
    out << y(1), -std::exp(y(0));
    return true;
  };
  const std::vector<double> mesh = UniformMesh(0.0, 1.0, 4);
  // No Jacobian: forward differences for both f and the boundary conditions.
  BoundaryConditions conditions = Dirichlet(0.0, 0.0);
  conditions.jacobians = nullptr;
  const BoundaryValueSolution solution = SolveBoundaryValueProblem(
      f, nullptr, conditions, mesh, ConstantGuess(mesh.size(), VectorXd::Zero(2)), {});
  REQUIRE(solution.summary.IsUsable());
  CAPTURE(solution.mesh.size(), solution.summary.message);
  CHECK(solution.summary.newton_iterations > 1);  // nonlinear: several iterations
  double max_error = 0.0;
  for (int k = 0; k <= 100; ++k) {
    const double t = k / 100.0;
    const double exact =
        -2.0 * std::log(std::cosh((t - 0.5) * theta / 2.0) / std::cosh(theta / 4.0));
    max_error = std::max(max_error, std::abs(solution.Evaluate(t)(0) - exact));
  }
  // Residual 1e-8 relative to |f| ~ 1; difference Jacobians only slow Newton down.
  CHECK(max_error < 1e-8);
}

TEST_CASE("default boundary value options are valid and bad fields are named", "[integrators]") {
  CHECK_NOTHROW(BoundaryValueOptions{}.Validate());
  {
    BoundaryValueOptions options;
    options.collocation_points = 2;
    CHECK_THROWS_WITH(
        options.Validate(),
        Catch::Contains("BoundaryValueOptions::collocation_points = 2: must be in 3 .. 10"));
  }
  BoundaryValueOptions options;
  options.tolerance = 1e-15;
  CHECK_THROWS_WITH(options.Validate(),
                    Catch::Contains("BoundaryValueOptions::tolerance = 1e-15: must be >="));
  options = {};
  options.absolute_tolerance = 0.0;
  CHECK_THROWS_WITH(options.Validate(),
                    Catch::Contains("absolute_tolerance = 0: must be finite and > 0"));
  options = {};
  options.max_mesh_points = 1;
  CHECK_THROWS_WITH(options.Validate(), Catch::Contains("max_mesh_points = 1: must be >= 2"));
  options = {};
  options.max_newton_iterations = 0;
  CHECK_THROWS_WITH(options.Validate(), Catch::Contains("max_newton_iterations = 0: must be >= 1"));
}

TEST_CASE("an inconsistent mesh or guess is a usage error", "[integrators]") {
  const BvpRightHandSide f = ScaledSecondDerivative(1.0);
  const BoundaryConditions conditions = Dirichlet(0.0, 1.0);
  const VectorXd zero = VectorXd::Zero(2);
  CHECK_THROWS_AS(SolveBoundaryValueProblem(f, nullptr, conditions, {0.0}, {zero}), UsageError);
  CHECK_THROWS_WITH(
      SolveBoundaryValueProblem(f, nullptr, conditions, {0.0, 0.5, 0.5}, {zero, zero, zero}),
      Catch::Contains("initial_mesh[2] = 0.5: the mesh must be finite and strictly increasing"));
  CHECK_THROWS_WITH(SolveBoundaryValueProblem(f, nullptr, conditions, {0.0, 1.0}, {zero}),
                    Catch::Contains("initial_guess has 1 vectors for 2 mesh points"));
  CHECK_THROWS_WITH(
      SolveBoundaryValueProblem(f, nullptr, conditions, {0.0, 1.0}, {zero, VectorXd::Zero(3)}),
      Catch::Contains("initial_guess[1] has size 3"));
  BoundaryConditions too_few;
  too_few.residual = [](const VectorXd& ya, const VectorXd&, VectorXd& residual) {
    residual.resize(1);
    residual << ya(0);
  };
  CHECK_THROWS_WITH(SolveBoundaryValueProblem(f, nullptr, too_few, {0.0, 1.0}, {zero, zero}),
                    Catch::Contains("boundary conditions returned 1 residuals, expected 2"));
}

TEST_CASE("numerical failures give an unusable summary with the reason, not an exception",
          "[integrators]") {
  const VectorXd zero = VectorXd::Zero(2);
  SECTION("the right-hand side cannot be evaluated") {
    const BvpRightHandSide f = [](double, const VectorXd&, VectorXd&, std::string& why) {
      why = "the model is singular here";
      return false;
    };
    const BoundaryValueSolution solution =
        SolveBoundaryValueProblem(f, nullptr, Dirichlet(0.0, 1.0), {0.0, 1.0}, {zero, zero});
    CHECK_FALSE(solution.summary.IsUsable());
    CHECK(solution.summary.status == SolveStatus::kNoConvergence);
    CHECK_THAT(solution.summary.message,
               Catch::Contains("right-hand side failed at t = 0: the model is singular here"));
    CHECK_THROWS_AS(solution.Evaluate(0.5), UsageError);
  }
  SECTION("the boundary conditions do not determine the solution") {
    BoundaryConditions twice_at_start;
    twice_at_start.residual = [](const VectorXd& ya, const VectorXd&, VectorXd& residual) {
      residual.resize(2);
      residual << ya(0), 2.0 * ya(0);
    };
    const BoundaryValueSolution solution = SolveBoundaryValueProblem(
        ScaledSecondDerivative(1.0), nullptr, twice_at_start, {0.0, 0.5, 1.0}, {zero, zero, zero});
    CHECK(solution.summary.status == SolveStatus::kNoConvergence);
    CHECK_THAT(solution.summary.message, Catch::Contains("singular Jacobian"));
  }
  SECTION("Newton fails where no solution exists: Bratu above its turning point") {
    // y'' + lambda e^y = 0, y(0) = y(1) = 0 has no solution for lambda > 3.5138.
    const BvpRightHandSide f = [](double, const VectorXd& y, VectorXd& out, std::string&) {
      out.resize(2);
      out << y(1), -4.0 * std::exp(y(0));
      return true;
    };
    const std::vector<double> mesh = UniformMesh(0.0, 1.0, 10);
    const BoundaryValueSolution solution = SolveBoundaryValueProblem(
        f, nullptr, Dirichlet(0.0, 0.0), mesh, ConstantGuess(mesh.size(), zero));
    CHECK(solution.summary.status == SolveStatus::kNoConvergence);
    CHECK_THAT(solution.summary.message, Catch::Contains("Newton"));
  }
  SECTION("the mesh limit stops the refinement of a boundary layer") {
    BoundaryValueOptions options;
    options.max_mesh_points = 20;
    const std::vector<double> mesh = UniformMesh(-1.0, 1.0, 10);
    const BoundaryValueSolution solution =
        SolveBoundaryValueProblem(ScaledSecondDerivative(1e3), nullptr, Dirichlet(1.0, 1.0), mesh,
                                  ConstantGuess(mesh.size(), zero), options);
    CHECK(solution.summary.status == SolveStatus::kTooManySteps);
    CHECK_THAT(solution.summary.message, Catch::Contains("> max_mesh_points = 20"));
  }
}

}  // namespace
}  // namespace servokit
