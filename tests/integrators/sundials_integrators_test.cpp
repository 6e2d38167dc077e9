// The SUNDIALS integrators (ARKODE Dormand-Prince, CVODE BDF, IDA) on problems whose exact
// solution is known in closed form, plus their breakpoints, failures and options.
#include "integrators/sundials_integrators.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/errors.h"

namespace servokit {
namespace {

constexpr double kPi = 3.14159265358979323846;

// What the observer saw, step by step.
struct ObservedTrajectory {
  std::vector<double> times;
  std::vector<Eigen::VectorXd> states;
  std::vector<Eigen::VectorXd> derivatives;

  IntegratorObserver Observer() {
    return [this](double t, const Eigen::VectorXd& y, const Eigen::VectorXd& y_dot) {
      times.push_back(t);
      states.push_back(y);
      derivatives.push_back(y_dot);
      return true;
    };
  }

  bool TimesIncrease() const {
    for (std::size_t i = 1; i < times.size(); ++i) {
      if (!(times[i] > times[i - 1])) return false;
    }
    return true;
  }
};

Eigen::VectorXd Vector(std::initializer_list<double> values) {
  Eigen::VectorXd vector(static_cast<Eigen::Index>(values.size()));
  Eigen::Index i = 0;
  for (const double value : values) vector(i++) = value;
  return vector;
}

// An ODE integrator of this interface, so that one test can run both.
using OdeIntegrator = std::function<SolveSummary(const OdeRightHandSide&,
                                                 double,
                                                 const Eigen::VectorXd&,
                                                 double,
                                                 const std::vector<double>&,
                                                 const IntegratorOptions&,
                                                 const IntegratorObserver&,
                                                 DenseOutput*)>;

// ---------------------------------------------------------------------------------------------
// Harmonic oscillator q'' = -w^2 q with w = 2 pi 2.887 rad/s (the undamped mass on car's zero
// dynamics at 5 deg), q(0) = 1, q'(0) = 0: q = cos(w t), q' = -w sin(w t). Over 10 s that is
// 29 periods.
TEST_CASE("Dormand-Prince follows the harmonic oscillator's cos/sin over 29 periods",
          "[integrators]") {
  const double omega = 2.0 * kPi * 2.887;
  const OdeRightHandSide oscillator = [omega](double, const Eigen::VectorXd& y,
                                              Eigen::VectorXd& y_dot, std::string&) {
    y_dot << y(1), -omega * omega * y(0);
    return true;
  };
  ObservedTrajectory observed;
  const double t_end = 10.0;
  const SolveSummary summary = IntegrateDormandPrince(oscillator, 0.0, Vector({1.0, 0.0}), t_end,
                                                      {}, IntegratorOptions{}, observed.Observer());
  REQUIRE(summary.IsUsable());
  CHECK(summary.stop_time == t_end);
  CHECK(observed.times.front() == 0.0);
  CHECK(observed.times.back() == t_end);  // the stop time is hit exactly, not interpolated near
  CHECK(observed.TimesIncrease());
  CHECK(summary.steps == static_cast<long>(observed.times.size()) - 1);  // every step observed
  double largest_error = 0.0;
  for (std::size_t i = 0; i < observed.times.size(); ++i) {
    const double t = observed.times[i];
    const Eigen::VectorXd& y = observed.states[i];
    largest_error = std::max({largest_error, std::abs(y(0) - std::cos(omega * t)),
                              std::abs(y(1) / omega + std::sin(omega * t))});
    // The observer's derivative is the right-hand side at the step itself.
    CHECK(observed.derivatives[i](0) == y(1));
    CHECK(observed.derivatives[i](1) == -omega * omega * y(0));
  }
  INFO("steps " << summary.steps << ", evaluations " << summary.function_evaluations
                << ", rejected " << summary.rejected_steps);
  // rtol = 1e-10 per step; the global error accumulates over the ~8000 steps of 29 periods
  // (measured 4.7e-10); 1e-8 leaves room for another platform's round-off.
  CHECK(largest_error < 1e-8);
  CHECK(summary.newton_iterations == 0);  // explicit
}

// ---------------------------------------------------------------------------------------------
// y' = A y with A = 1/2 [[a + b, a - b], [a - b, a + b]], a = -1, b = -1e4: eigenvector (1, 1)
// for a, (1, -1) for b. From y(0) = (2, 0) = (1, 1) + (1, -1):
//   y1 = exp(-t) + exp(-1e4 t),  y2 = exp(-t) - exp(-1e4 t).
// Stiff: an explicit method is held to |h b| <~ 3.3 by stability long after the fast mode died.
TEST_CASE("BDF solves a stiff linear system accurately in far fewer steps than Dormand-Prince",
          "[integrators]") {
  const double slow = -1.0;
  const double fast = -1e4;
  Eigen::Matrix2d system_matrix;
  system_matrix << slow + fast, slow - fast, slow - fast, slow + fast;
  system_matrix *= 0.5;
  const OdeRightHandSide linear = [system_matrix](double, const Eigen::VectorXd& y,
                                                  Eigen::VectorXd& y_dot, std::string&) {
    y_dot.noalias() = system_matrix * y;
    return true;
  };
  const auto exact = [&](double t) {
    return Vector(
        {std::exp(slow * t) + std::exp(fast * t), std::exp(slow * t) - std::exp(fast * t)});
  };
  const double t_end = 10.0;
  ObservedTrajectory observed;
  const SolveSummary bdf =
      IntegrateBdf(linear, 0.0, exact(0.0), t_end, {}, IntegratorOptions{}, observed.Observer());
  REQUIRE(bdf.IsUsable());
  CHECK(observed.times.back() == t_end);
  CHECK(observed.TimesIncrease());
  double largest_error = 0.0;
  for (std::size_t i = 0; i < observed.times.size(); ++i) {
    largest_error = std::max(
        largest_error, (observed.states[i] - exact(observed.times[i])).lpNorm<Eigen::Infinity>());
  }
  // Local tolerance 1e-10 relative; BDF's global error is typically 10-100 times that
  // (measured 5.1e-10).
  CHECK(largest_error < 1e-8);
  CHECK(bdf.newton_iterations > 0);
  CHECK(bdf.jacobian_evaluations > 0);

  const SolveSummary dormand_prince =
      IntegrateDormandPrince(linear, 0.0, exact(0.0), t_end, {}, IntegratorOptions{}, {});
  REQUIRE(dormand_prince.IsUsable());
  INFO("BDF " << bdf.steps << " steps, Dormand-Prince " << dormand_prince.steps << " steps");
  // Stability alone needs 10 s * 1e4 / 3.3 = 3e4 explicit steps (measured 30425); BDF, which
  // is stable at any step, follows the slow mode's accuracy (measured 758).
  CHECK(dormand_prince.steps > 30000);
  CHECK(bdf.steps < 2000);
}

// ---------------------------------------------------------------------------------------------
// x' = -x + z, 0 = z - sin t (z algebraic, index 1). Then x' + x = sin t, and with x(0) = 1:
//   x = 3/2 exp(-t) + (sin t - cos t) / 2,  z = sin t.
// Consistent start: x = 1, z = 0, x' = -1 + 0 = -1, z' = cos 0 = 1.
TEST_CASE("IDA solves a linear index-1 DAE with its algebraic variable out of the error test",
          "[integrators]") {
  const DaeResidual dae = [](double t, const Eigen::VectorXd& x, const Eigen::VectorXd& x_dot,
                             Eigen::VectorXd& residual, std::string&) {
    residual << x_dot(0) + x(0) - x(1), x(1) - std::sin(t);
    return true;
  };
  ObservedTrajectory observed;
  const double t_end = 10.0;
  const SolveSummary summary =
      IntegrateIda(dae, 0.0, Vector({1.0, 0.0}), Vector({-1.0, 1.0}), {true, false}, t_end, {},
                   IntegratorOptions{}, observed.Observer());
  REQUIRE(summary.IsUsable());
  CHECK(observed.times.back() == t_end);
  CHECK(observed.TimesIncrease());
  double largest_error = 0.0;
  for (std::size_t i = 0; i < observed.times.size(); ++i) {
    const double t = observed.times[i];
    const double x = 1.5 * std::exp(-t) + 0.5 * (std::sin(t) - std::cos(t));
    const double x_dot = -1.5 * std::exp(-t) + 0.5 * (std::cos(t) + std::sin(t));
    largest_error = std::max({largest_error, std::abs(observed.states[i](0) - x),
                              std::abs(observed.states[i](1) - std::sin(t))});
    // IDA's x' comes from its BDF polynomial: exact only to the local error (measured 3e-8,
    // largest on the first steps at order 1).
    CHECK(observed.derivatives[i](0) == Approx(x_dot).margin(1e-6));
  }
  INFO("steps " << summary.steps << ", Newton " << summary.newton_iterations << ", rejected "
                << summary.rejected_steps);
  // Local tolerance 1e-10; the global error of BDF is 10-100 times larger (measured 7.7e-10).
  CHECK(largest_error < 1e-8);
  CHECK(summary.newton_iterations > 0);
  CHECK(summary.jacobian_evaluations > 0);
}

// q1' = q2, q2' = -z, 0 = z + z^3 - (w^2 q1 + (w^2 q1)^3): since s + s^3 is strictly
// increasing, the algebraic equation has the single root z = w^2 q1, which IDA must find by
// Newton at every step. So q1'' = -w^2 q1 and, from q1(0) = 1, q2(0) = 0:
//   q1 = cos(w t), q2 = -w sin(w t), z = w^2 cos(w t).
TEST_CASE("IDA solves an oscillator whose force is the root of a nonlinear algebraic equation",
          "[integrators]") {
  const double omega = 2.0;
  const DaeResidual dae = [omega](double, const Eigen::VectorXd& x, const Eigen::VectorXd& x_dot,
                                  Eigen::VectorXd& residual, std::string&) {
    const double spring = omega * omega * x(0);
    residual << x_dot(0) - x(1), x_dot(1) + x(2),
        x(2) + std::pow(x(2), 3) - spring - std::pow(spring, 3);
    return true;
  };
  const double force_start = omega * omega;
  ObservedTrajectory observed;
  const double t_end = 5.0;
  const SolveSummary summary =
      IntegrateIda(dae, 0.0, Vector({1.0, 0.0, force_start}), Vector({0.0, -force_start, 0.0}),
                   {true, true, false}, t_end, {}, IntegratorOptions{}, observed.Observer());
  REQUIRE(summary.IsUsable());
  CHECK(observed.times.back() == t_end);
  double differential_error = 0.0;
  double algebraic_error = 0.0;
  for (std::size_t i = 0; i < observed.times.size(); ++i) {
    const double t = observed.times[i];
    const Eigen::VectorXd& x = observed.states[i];
    differential_error = std::max({differential_error, std::abs(x(0) - std::cos(omega * t)),
                                   std::abs(x(1) / omega + std::sin(omega * t))});
    algebraic_error = std::max(algebraic_error, std::abs(x(2) / force_start - std::cos(omega * t)));
  }
  INFO("steps " << summary.steps << ", Newton " << summary.newton_iterations);
  // Local tolerance 1e-10 over 1.6 periods; BDF's global error (measured 5e-9).
  CHECK(differential_error < 2e-8);
  // With the algebraic component out of the error test, IDA leaves it out of the Newton
  // convergence test too, so z is only as converged as the modified Newton iteration leaves
  // it: measured 1.6e-7 relative (2e-9 with z in the tests, at 1.7 times the steps).
  CHECK(algebraic_error < 1e-6);
}

// ---------------------------------------------------------------------------------------------
// y' = 0 before t = 1 and 1 after, y(0) = 0: y = max(t - 1, 0). Each piece is a polynomial that
// every method here integrates exactly, so the result is exact to round-off provided no step
// straddles the kink: the integrator must stop on t = 1 and restart there. The step that lands
// on t = 1 must also see y' = 0 there, although the function gives 1 at t = 1 itself.
TEST_CASE("a breakpoint is hit exactly and the kinked solution comes out exact", "[integrators]") {
  const double kink = 1.0;
  const OdeRightHandSide ramp = [kink](double t, const Eigen::VectorXd&, Eigen::VectorXd& y_dot,
                                       std::string&) {
    y_dot(0) = t < kink ? 0.0 : 1.0;
    return true;
  };
  const DaeResidual ramp_dae = [kink](double t, const Eigen::VectorXd&,
                                      const Eigen::VectorXd& x_dot, Eigen::VectorXd& residual,
                                      std::string&) {
    residual(0) = x_dot(0) - (t < kink ? 0.0 : 1.0);
    return true;
  };
  const double t_end = 3.0;
  // Breakpoints outside (t_start, t_end), or on its ends, are ignored; order does not matter.
  const std::vector<double> breakpoints = {5.0, t_end, kink, 0.0, -1.0};
  const std::vector<double> no_breakpoints;
  const Eigen::VectorXd start = Vector({0.0});
  using Integrate = std::function<SolveSummary(const std::vector<double>&, ObservedTrajectory&)>;

  const auto check = [&](const Integrate& integrate) {
    ObservedTrajectory observed;
    const SolveSummary summary = integrate(breakpoints, observed);
    REQUIRE(summary.IsUsable());
    CHECK(observed.TimesIncrease());
    CHECK(std::count(observed.times.begin(), observed.times.end(), kink) == 1);
    CHECK(observed.times.back() == t_end);
    CHECK(summary.steps == static_cast<long>(observed.times.size()) - 1);
    for (std::size_t i = 0; i < observed.times.size(); ++i) {
      // Round-off only (measured at most 1.3e-15 in 14 to 54 steps).
      CHECK(observed.states[i](0) == Approx(std::max(observed.times[i] - kink, 0.0)).margin(1e-12));
    }
    // Not one step had to be rejected; across the kink, 24 to 35 are (measured).
    CHECK(summary.rejected_steps == 0);
    ObservedTrajectory across;
    CHECK(integrate(no_breakpoints, across).rejected_steps > 10);
  };
  SECTION("Dormand-Prince") {
    check([&](const std::vector<double>& stops, ObservedTrajectory& observed) {
      return IntegrateDormandPrince(ramp, 0.0, start, t_end, stops, IntegratorOptions{},
                                    observed.Observer());
    });
  }
  SECTION("BDF") {
    check([&](const std::vector<double>& stops, ObservedTrajectory& observed) {
      return IntegrateBdf(ramp, 0.0, start, t_end, stops, IntegratorOptions{}, observed.Observer());
    });
  }
  SECTION("IDA") {
    // After the breakpoint IDA needs x' = 1, not the left limit 0 it arrived with.
    check([&](const std::vector<double>& stops, ObservedTrajectory& observed) {
      return IntegrateIda(ramp_dae, 0.0, start, Vector({0.0}), {true}, t_end, stops,
                          IntegratorOptions{}, observed.Observer());
    });
  }
}

// ---------------------------------------------------------------------------------------------
// y' = -y, refused for t > 2 ("P is singular", as the normal form says when the decoupling
// matrix degenerates). The integrator cannot get past t = 2 and must say why and when:
// Dormand-Prince stops at its first refused stage (ERKStep cannot retry), within a step before
// t = 2; CVODE and IDA retry smaller steps and creep up to t = 2 until the step size falls
// below round-off (measured stop_time 1.9925, 2 and 2; refusals at t = 2.0016, 2 and 2).
TEST_CASE("a right-hand side that refuses a point stops the integration with its reason",
          "[integrators]") {
  const double barrier = 2.0;
  const OdeRightHandSide refusing = [barrier](double t, const Eigen::VectorXd& y,
                                              Eigen::VectorXd& y_dot, std::string& why) {
    if (t > barrier) {
      why = "P is singular";
      return false;
    }
    y_dot = -y;
    return true;
  };
  const DaeResidual refusing_dae = [barrier](double t, const Eigen::VectorXd& x,
                                             const Eigen::VectorXd& x_dot,
                                             Eigen::VectorXd& residual, std::string& why) {
    if (t > barrier) {
      why = "P is singular";
      return false;
    }
    residual = x_dot + x;
    return true;
  };
  IntegratorOptions options;
  options.max_step = 0.1;  // so that "within a step of t = 2" means something
  const auto check = [&](const SolveSummary& summary) {
    INFO(summary.message);
    CHECK_FALSE(summary.IsUsable());
    CHECK(summary.status == SolveStatus::kIntegratorFailure);
    CHECK_THAT(summary.message, Catch::Contains("P is singular"));
    CHECK_THAT(summary.message, Catch::StartsWith("at t = 2"));  // when it was refused
    CHECK(summary.stop_time <= barrier);
    CHECK(summary.stop_time > barrier - options.max_step);
  };
  const Eigen::VectorXd start = Vector({1.0});
  SECTION("Dormand-Prince") {
    check(IntegrateDormandPrince(refusing, 0.0, start, 5.0, {}, options, {}));
  }
  SECTION("BDF") { check(IntegrateBdf(refusing, 0.0, start, 5.0, {}, options, {})); }
  SECTION("IDA") {
    check(IntegrateIda(refusing_dae, 0.0, start, -start, {true}, 5.0, {}, options, {}));
  }
}

TEST_CASE("a right-hand side that is not finite is reported as such", "[integrators]") {
  // y' = -y, but NaN for t > 1.
  const OdeRightHandSide not_finite = [](double t, const Eigen::VectorXd& y, Eigen::VectorXd& y_dot,
                                         std::string&) {
    y_dot = t > 1.0 ? Eigen::VectorXd::Constant(1, std::nan("")) : Eigen::VectorXd(-y);
    return true;
  };
  const SolveSummary summary =
      IntegrateBdf(not_finite, 0.0, Vector({1.0}), 5.0, {}, IntegratorOptions{}, {});
  CHECK_FALSE(summary.IsUsable());
  CHECK_THAT(summary.message, Catch::Contains("the right-hand side is not finite"));
  CHECK(summary.stop_time <= 1.0);
}

TEST_CASE("an exception thrown by a callback comes out of the integrator", "[integrators]") {
  // Thrown inside SUNDIALS' C frames, caught there and rethrown once SUNDIALS has returned.
  const OdeRightHandSide throwing = [](double t, const Eigen::VectorXd& y, Eigen::VectorXd& y_dot,
                                       std::string&) {
    if (t > 1.0) throw std::runtime_error("model evaluation failed");
    y_dot = -y;
    return true;
  };
  const DaeResidual throwing_dae = [](double t, const Eigen::VectorXd& x,
                                      const Eigen::VectorXd& x_dot, Eigen::VectorXd& residual,
                                      std::string&) {
    if (t > 1.0) throw std::runtime_error("model evaluation failed");
    residual = x_dot + x;
    return true;
  };
  const Eigen::VectorXd start = Vector({1.0});
  const IntegratorOptions options;
  CHECK_THROWS_WITH(IntegrateDormandPrince(throwing, 0.0, start, 5.0, {}, options, {}),
                    "model evaluation failed");
  CHECK_THROWS_WITH(IntegrateBdf(throwing, 0.0, start, 5.0, {}, options, {}),
                    "model evaluation failed");
  CHECK_THROWS_WITH(IntegrateIda(throwing_dae, 0.0, start, -start, {true}, 5.0, {}, options, {}),
                    "model evaluation failed");
}

TEST_CASE("a right-hand side returning the wrong size is a programming error", "[integrators]") {
  const OdeRightHandSide wrong_size = [](double, const Eigen::VectorXd&, Eigen::VectorXd& y_dot,
                                         std::string&) {
    y_dot = Eigen::VectorXd::Zero(3);
    return true;
  };
  CHECK_THROWS_AS(
      IntegrateDormandPrince(wrong_size, 0.0, Vector({1.0, 2.0}), 1.0, {}, IntegratorOptions{}, {}),
      std::logic_error);
}

// ---------------------------------------------------------------------------------------------
TEST_CASE("an observer returning false interrupts the integration where it said so",
          "[integrators]") {
  // y' = -y from y(0) = 1; stop at the fifth call (the start and four steps).
  const OdeRightHandSide decay = [](double, const Eigen::VectorXd& y, Eigen::VectorXd& y_dot,
                                    std::string&) {
    y_dot = -y;
    return true;
  };
  int calls = 0;
  double last_time = -1.0;
  const IntegratorObserver stop_at_fifth = [&](double t, const Eigen::VectorXd&,
                                               const Eigen::VectorXd&) {
    last_time = t;
    return ++calls < 5;
  };
  for (const OdeIntegrator& integrate :
       {OdeIntegrator(IntegrateDormandPrince), OdeIntegrator(IntegrateBdf)}) {
    calls = 0;
    const SolveSummary summary =
        integrate(decay, 0.0, Vector({1.0}), 10.0, {}, IntegratorOptions{}, stop_at_fifth, nullptr);
    CHECK(summary.status == SolveStatus::kInterrupted);
    CHECK(summary.steps == 4);
    CHECK(summary.stop_time == last_time);
    CHECK(summary.stop_time < 10.0);
  }
}

TEST_CASE("the step limit stops the integration with too-many-steps", "[integrators]") {
  // y' = -y over 10 s with steps of at most 0.01 s: 1000 steps needed, 100 allowed.
  const OdeRightHandSide decay = [](double, const Eigen::VectorXd& y, Eigen::VectorXd& y_dot,
                                    std::string&) {
    y_dot = -y;
    return true;
  };
  IntegratorOptions options;
  options.max_step = 0.01;
  options.max_steps = 100;
  const SolveSummary summary = IntegrateBdf(decay, 0.0, Vector({1.0}), 10.0, {}, options, {});
  CHECK(summary.status == SolveStatus::kTooManySteps);
  CHECK(summary.steps == 100);
  CHECK(summary.stop_time <= 1.0 + 1e-12);  // 100 steps of at most 0.01 s
  CHECK_THAT(summary.message, Catch::Contains("max_steps"));
}

TEST_CASE("counters add up across the restarts at breakpoints", "[integrators]") {
  // y' = -y with nine breakpoints: every restart resets SUNDIALS' counters, ours must not.
  const OdeRightHandSide decay = [](double, const Eigen::VectorXd& y, Eigen::VectorXd& y_dot,
                                    std::string&) {
    y_dot = -y;
    return true;
  };
  const std::vector<double> breakpoints = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  ObservedTrajectory observed;
  const SolveSummary with_restarts = IntegrateBdf(decay, 0.0, Vector({1.0}), 10.0, breakpoints,
                                                  IntegratorOptions{}, observed.Observer());
  const SolveSummary without =
      IntegrateBdf(decay, 0.0, Vector({1.0}), 10.0, {}, IntegratorOptions{}, {});
  REQUIRE(with_restarts.IsUsable());
  CHECK(with_restarts.steps == static_cast<long>(observed.times.size()) - 1);
  // Each restart begins again at order 1 with a small step, so there is more work in all.
  CHECK(with_restarts.steps > without.steps);
  CHECK(with_restarts.newton_iterations > without.newton_iterations);
  CHECK(with_restarts.function_evaluations > without.function_evaluations);
  CHECK(with_restarts.rejected_steps >= without.rejected_steps);
  // exp(-10) to the tolerance: restarts cost work, not accuracy (global error of BDF).
  CHECK(observed.states.back()(0) == Approx(std::exp(-10.0)).margin(1e-9));
}

// ---------------------------------------------------------------------------------------------
TEST_CASE("default integrator options are valid", "[integrators]") {
  CHECK_NOTHROW(IntegratorOptions{}.Validate());
}

TEST_CASE("each invalid integrator option is named with its value and rule", "[integrators]") {
  const double nan = std::nan("");
  const auto invalid = [](void (*spoil)(IntegratorOptions&)) {
    IntegratorOptions options;
    spoil(options);
    return options;
  };
  using Catch::Contains;
  CHECK_THROWS_WITH(invalid([](IntegratorOptions& o) { o.rtol = -1; }).Validate(),
                    "IntegratorOptions::rtol = -1: must be > 0 and finite");
  CHECK_THROWS_WITH(invalid([](IntegratorOptions& o) { o.rtol = 0; }).Validate(),
                    Contains("IntegratorOptions::rtol = 0"));
  CHECK_THROWS_WITH(invalid([](IntegratorOptions& o) { o.atol = -1e-12; }).Validate(),
                    Contains("IntegratorOptions::atol = -1e-12: must be >= 0"));
  CHECK_THROWS_WITH(invalid([](IntegratorOptions& o) { o.max_steps = 0; }).Validate(),
                    Contains("IntegratorOptions::max_steps = 0: must be >= 1"));
  CHECK_THROWS_WITH(invalid([](IntegratorOptions& o) { o.max_step = 0; }).Validate(),
                    Contains("IntegratorOptions::max_step = 0: must be > 0"));
  CHECK_THROWS_WITH(invalid([](IntegratorOptions& o) { o.initial_step = -0.1; }).Validate(),
                    Contains("IntegratorOptions::initial_step = -0.1: must be >= 0"));
  IntegratorOptions not_a_number;
  not_a_number.rtol = nan;
  CHECK_THROWS_WITH(not_a_number.Validate(), Contains("IntegratorOptions::rtol = nan"));
  not_a_number = IntegratorOptions{};
  not_a_number.max_step = nan;
  CHECK_THROWS_WITH(not_a_number.Validate(), Contains("IntegratorOptions::max_step = nan"));
  not_a_number = IntegratorOptions{};
  not_a_number.atol = nan;
  CHECK_THROWS_AS(not_a_number.Validate(), UsageError);
  // An unbounded step is the default and valid.
  IntegratorOptions unbounded;
  unbounded.max_step = std::numeric_limits<double>::infinity();
  CHECK_NOTHROW(unbounded.Validate());
}

TEST_CASE("the integrators validate their options and inputs before anything else",
          "[integrators]") {
  int calls = 0;
  const OdeRightHandSide counting = [&calls](double, const Eigen::VectorXd& y,
                                             Eigen::VectorXd& y_dot, std::string&) {
    ++calls;
    y_dot = -y;
    return true;
  };
  const DaeResidual residual = [](double, const Eigen::VectorXd& x, const Eigen::VectorXd& x_dot,
                                  Eigen::VectorXd& value, std::string&) {
    value = x_dot + x;
    return true;
  };
  IntegratorOptions bad;
  bad.rtol = -1;
  const IntegratorOptions good;
  const Eigen::VectorXd one = Vector({1.0});
  using Catch::Contains;
  CHECK_THROWS_WITH(IntegrateDormandPrince(counting, 0.0, one, 1.0, {}, bad, {}),
                    Contains("IntegratorOptions::rtol"));
  CHECK_THROWS_WITH(IntegrateBdf(counting, 0.0, one, 1.0, {}, bad, {}),
                    Contains("IntegratorOptions::rtol"));
  CHECK_THROWS_WITH(IntegrateIda(residual, 0.0, one, -one, {true}, 1.0, {}, bad, {}),
                    Contains("IntegratorOptions::rtol"));
  CHECK(calls == 0);

  CHECK_THROWS_WITH(IntegrateBdf(counting, 0.0, Eigen::VectorXd(), 1.0, {}, good, {}),
                    Contains("y_start is empty"));
  CHECK_THROWS_WITH(
      IntegrateDormandPrince(counting, 0.0, Vector({std::nan("")}), 1.0, {}, good, {}),
      Contains("y_start: must be finite"));
  CHECK_THROWS_WITH(IntegrateBdf(counting, 1.0, one, 0.0, {}, good, {}),
                    Contains("t_end >= t_start"));
  CHECK_THROWS_AS(IntegrateBdf(counting, 0.0, one, 1.0, {std::nan("")}, good, {}), UsageError);
  CHECK_THROWS_WITH(
      IntegrateIda(residual, 0.0, Eigen::VectorXd(), Eigen::VectorXd(), {}, 1.0, {}, good, {}),
      Contains("x_start is empty"));
  CHECK_THROWS_WITH(IntegrateIda(residual, 0.0, one, -one, {true, false}, 1.0, {}, good, {}),
                    Contains("differential has 2 flags"));
  CHECK_THROWS_WITH(IntegrateIda(residual, 0.0, one, Vector({1.0, 2.0}), {true}, 1.0, {}, good, {}),
                    Contains("x_dot_start has 2 values"));
  CHECK(calls == 0);
}

TEST_CASE("an empty interval returns the start without a step", "[integrators]") {
  const OdeRightHandSide decay = [](double, const Eigen::VectorXd& y, Eigen::VectorXd& y_dot,
                                    std::string&) {
    y_dot = -y;
    return true;
  };
  ObservedTrajectory observed;
  const SolveSummary summary = IntegrateDormandPrince(decay, 2.0, Vector({1.0}), 2.0, {},
                                                      IntegratorOptions{}, observed.Observer());
  CHECK(summary.IsUsable());
  CHECK(summary.steps == 0);
  CHECK(summary.stop_time == 2.0);
  REQUIRE(observed.times.size() == 1);
  CHECK(observed.derivatives.front()(0) == -1.0);
}

}  // namespace
}  // namespace servokit
