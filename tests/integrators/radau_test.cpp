// Radau IIA (3 stages, order 5) and Euler backward (1 stage) on linearly implicit problems
// A(t, x) x' = phi(t, x) with closed-form solutions: stiff ODEs, index-2 and index-3 DAEs and a
// state-dependent mass matrix; plus the bookkeeping (breakpoints, t_end, failures, observer,
// options). Each problem is written out with its solution above its class.
#include "integrators/radau.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "base/errors.h"

namespace servokit {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

VectorXd Vector(std::initializer_list<double> values) {
  VectorXd vector(Eigen::Index(values.size()));
  Eigen::Index i = 0;
  for (const double value : values) vector(i++) = value;
  return vector;
}

// Every step the integrator reports, in order.
struct Recording {
  std::vector<double> times;
  std::vector<VectorXd> states;
};

StepObserver RecordInto(Recording& recording) {
  return [&recording](double t, const VectorXd& x) {
    recording.times.push_back(t);
    recording.states.push_back(x);
    return true;
  };
}

RadauOptions EulerOptions(double fixed_step) {
  RadauOptions options;
  options.stages = 1;
  options.fixed_step = fixed_step;
  return options;
}

// x' = -x, x(0) = x0:  x = x0 e^-t. Identity mass matrix; the default (difference) Jacobian.
class Decay : public LinearlyImplicitDae {
 public:
  Eigen::Index size() const override { return 1; }
  std::vector<int> ComponentIndices() const override { return {1}; }
  bool Evaluate(double, const VectorXd& x, MatrixXd& mass, VectorXd& rhs, std::string&) override {
    mass = MatrixXd::Identity(1, 1);
    rhs = -x;
    return true;
  }
};

// x1' = -x1, x2' = -1000 (x2 - cos t) - sin t, x(0) = (1, 1):  x1 = e^-t, x2 = cos t
// (Prothero-Robinson). The eigenvalues -1 and -1000 make it stiff: an explicit method is
// stable only for h < ~3 / 1000, i.e. thousands of steps on [0, 10].
class StiffPair : public LinearlyImplicitDae {
 public:
  Eigen::Index size() const override { return 2; }
  std::vector<int> ComponentIndices() const override { return {1, 1}; }
  bool Evaluate(double t, const VectorXd& x, MatrixXd& mass, VectorXd& rhs, std::string&) override {
    mass = MatrixXd::Identity(2, 2);
    rhs = Vector({-x(0), -1000.0 * (x(1) - std::cos(t)) - std::sin(t)});
    return true;
  }
  static VectorXd Exact(double t) { return Vector({std::exp(-t), std::cos(t)}); }
};

// Index 3:  x1' = x2, x2' = u, 0 = x1 - sin t, i.e. diag(1, 1, 0) x' = (x2, u, x1 - sin t),
// from the consistent (0, 1, 0):  x1 = sin t, x2 = cos t, u = -sin t. The constraint fixes x1,
// its first derivative x2 and its second u: component indices (1, 2, 3), as for the position,
// velocity and force of a servo constraint.
class IndexThreeSine : public LinearlyImplicitDae {
 public:
  Eigen::Index size() const override { return 3; }
  std::vector<int> ComponentIndices() const override { return {1, 2, 3}; }
  bool Evaluate(double t, const VectorXd& x, MatrixXd& mass, VectorXd& rhs, std::string&) override {
    mass = Eigen::Vector3d(1.0, 1.0, 0.0).asDiagonal();
    rhs = Vector({x(1), x(2), x(0) - std::sin(t)});
    return true;
  }
  static VectorXd Exact(double t) { return Vector({std::sin(t), std::cos(t), -std::sin(t)}); }
};

// Index 2:  x1' = -x1 + x2, 0 = x1 - e^-2t, from the consistent (1, -1):  x1 = e^-2t and, from
// x1' = -2 e^-2t, x2 = -e^-2t. One differentiation of the constraint gives x2: indices (1, 2).
class IndexTwoExponential : public LinearlyImplicitDae {
 public:
  Eigen::Index size() const override { return 2; }
  std::vector<int> ComponentIndices() const override { return {1, 2}; }
  bool Evaluate(double t, const VectorXd& x, MatrixXd& mass, VectorXd& rhs, std::string&) override {
    mass = Eigen::Vector2d(1.0, 0.0).asDiagonal();
    rhs = Vector({-x(0) + x(1), x(0) - std::exp(-2.0 * t)});
    return true;
  }
  static VectorXd Exact(double t) { return Vector({std::exp(-2.0 * t), -std::exp(-2.0 * t)}); }
};

// The harmonic oscillator x1' = x2, x2' = -x1 with its first row multiplied by 1 + x2^2 and
// mixed with x1 times the second:  A(x) = [1 + x2^2, x1; 0, 1] (det 1 + x2^2 > 0),
// phi(x) = ((1 + x2^2) x2 - x1^2, -x1). From (0, 1):  x1 = sin t, x2 = cos t.
class StateDependentMass : public LinearlyImplicitDae {
 public:
  Eigen::Index size() const override { return 2; }
  std::vector<int> ComponentIndices() const override { return {1, 1}; }
  bool Evaluate(double, const VectorXd& x, MatrixXd& mass, VectorXd& rhs, std::string&) override {
    mass.resize(2, 2);
    mass << 1.0 + x(1) * x(1), x(0), 0.0, 1.0;
    rhs = Vector({(1.0 + x(1) * x(1)) * x(1) - x(0) * x(0), -x(0)});
    return true;
  }
  static VectorXd Exact(double t) { return Vector({std::sin(t), std::cos(t)}); }
};

// x' = |t - 1|, x(0) = 0:  x = t - t^2 / 2 for t <= 1, 1/2 + (t - 1)^2 / 2 after. phi has a
// kink at t = 1; on each side x is a quadratic, which Radau IIA (collocation of degree 3)
// reproduces to round-off, provided no step straddles the kink.
class KinkedRamp : public LinearlyImplicitDae {
 public:
  Eigen::Index size() const override { return 1; }
  std::vector<int> ComponentIndices() const override { return {1}; }
  bool Evaluate(double t, const VectorXd&, MatrixXd& mass, VectorXd& rhs, std::string&) override {
    mass = MatrixXd::Identity(1, 1);
    rhs = Vector({std::abs(t - 1.0)});
    return true;
  }
  static double Exact(double t) {
    return t <= 1.0 ? t - t * t / 2.0 : 0.5 + (t - 1.0) * (t - 1.0) / 2.0;
  }
};

// x' = -x, but the model cannot be evaluated beyond t = 2 (as when M(q) turns singular there).
class FailsAfterTwo : public Decay {
 public:
  bool Evaluate(
      double t, const VectorXd& x, MatrixXd& mass, VectorXd& rhs, std::string& why) override {
    if (t > 2.0) {
      why = "M(q) is singular";
      return false;
    }
    return Decay::Evaluate(t, x, mass, rhs, why);
  }
};

// max_k |x_i(t_k) - exact_i(t_k)| over the recorded steps, per component.
template <typename Exact>
VectorXd MaxErrors(const Recording& recording, Exact exact) {
  VectorXd largest = VectorXd::Zero(recording.states.front().size());
  for (std::size_t k = 0; k < recording.times.size(); ++k) {
    largest = largest.cwiseMax((recording.states[k] - exact(recording.times[k])).cwiseAbs());
  }
  return largest;
}

// The same index-3 problem with other component indices declared.
class IndexThreeSineDeclaredAs : public IndexThreeSine {
 public:
  explicit IndexThreeSineDeclaredAs(std::vector<int> indices) : indices_(std::move(indices)) {}
  std::vector<int> ComponentIndices() const override { return indices_; }

 private:
  std::vector<int> indices_;
};

TEST_CASE("Radau IIA follows x' = -x within the tolerance", "[integrators]") {
  Decay decay;
  const RadauOptions options;  // rtol 1e-8, atol 1e-10
  Recording recording;
  const SolveSummary summary =
      IntegrateRadau(decay, 0.0, Vector({1.0}), 10.0, {}, options, RecordInto(recording));
  REQUIRE(summary.IsUsable());
  CHECK(summary.status == SolveStatus::kConverged);
  CHECK(summary.message == "reached t = 10 s in " + std::to_string(summary.steps) + " steps");
  CHECK(summary.stop_time == 10.0);
  CHECK(recording.times.back() == 10.0);
  // The local error is held near rtol |x| (RADAU5's calibration); on a decaying solution the
  // global error stays below rtol (measured 1.6e-10).
  const VectorXd errors = MaxErrors(recording, [](double t) { return Vector({std::exp(-t)}); });
  CHECK(errors(0) < 1e-8);
  CHECK(summary.steps < 150);  // measured 91
  CHECK(summary.rejected_steps == 0);
  CHECK(summary.newton_iterations >= summary.steps);
  CHECK(summary.function_evaluations > summary.newton_iterations);
  CHECK(summary.jacobian_evaluations == 1);  // linear: the first Jacobian serves throughout
}

TEST_CASE("Radau IIA integrates a stiff system in far fewer steps than an explicit method needs",
          "[integrators]") {
  StiffPair stiff;
  RadauOptions options;
  options.rtol = 1e-6;
  options.atol = 1e-9;
  Recording recording;
  const SolveSummary summary =
      IntegrateRadau(stiff, 0.0, Vector({1.0, 1.0}), 10.0, {}, options, RecordInto(recording));
  REQUIRE(summary.IsUsable());
  // Amplitudes are 1: a global error of 10 rtol allows for a few local errors accumulating
  // in the slow mode (measured 2e-8 and 5e-7).
  const VectorXd errors = MaxErrors(recording, StiffPair::Exact);
  CHECK(errors(0) < 1e-5);
  CHECK(errors(1) < 1e-5);
  // An explicit method is stable only for h < ~3e-3 here: over 3000 steps on [0, 10].
  CHECK(summary.steps < 100);  // measured 45
}

TEST_CASE("Radau IIA solves an index-3 DAE thanks to the index scaling of the error test",
          "[integrators]") {
  IndexThreeSine dae;
  const RadauOptions options;  // rtol 1e-8, atol 1e-10
  Recording recording;
  const SolveSummary summary =
      IntegrateRadau(dae, 0.0, Vector({0.0, 1.0, 0.0}), 10.0, {}, options, RecordInto(recording));
  REQUIRE(summary.IsUsable());
  CHECK(summary.stop_time == 10.0);
  // Radau IIA on index 3 (Hairer & Wanner VII.8): the constraint holds at every step, so x1
  // is exact to round-off; x2 (index 2) is accurate to O(h^3), u (index 3) to O(h^2). With
  // steps of ~0.04 that is ~1e-6 and ~1e-4 (measured 3e-6 and 4e-4); the limits leave a
  // factor 3 to 5.
  const VectorXd errors = MaxErrors(recording, IndexThreeSine::Exact);
  CHECK(errors(0) < 1e-12);
  CHECK(errors(1) < 1e-5);
  CHECK(errors(2) < 2e-3);
  CHECK(summary.steps < 350);  // measured 272

  // Declared as an ODE (no h^(k-1) scaling) the error test of u can never pass: u's local
  // error is O(h^2) and does not fall below the tolerance before h reaches round-off.
  IndexThreeSineDeclaredAs unscaled({1, 1, 1});
  const SolveSummary failed =
      IntegrateRadau(unscaled, 0.0, Vector({0.0, 1.0, 0.0}), 10.0, {}, options, {});
  CHECK(failed.status == SolveStatus::kStepSizeTooSmall);
  CHECK_THAT(failed.message, Catch::Contains("local error test failed"));
  CHECK(failed.stop_time < 1.0);
}

TEST_CASE("at a constant step Radau IIA has orders 3 and 2 in the index-2 and index-3 components",
          "[integrators]") {
  // Hairer & Wanner VII.8 (Radau IIA, s = 3, index 3): x2 error O(h^s), u error O(h^(s-1)).
  // A loose tolerance and max_step = initial_step = h keep every step at h.
  IndexThreeSine dae;
  const auto errors_with_step = [&dae](double h) {
    RadauOptions options;
    options.rtol = 0.5;
    options.atol = 1.0;
    options.initial_step = h;
    options.max_step = h;
    Recording recording;
    const SolveSummary summary =
        IntegrateRadau(dae, 0.0, Vector({0.0, 1.0, 0.0}), 4.0, {}, options, RecordInto(recording));
    REQUIRE(summary.IsUsable());
    CHECK(summary.rejected_steps == 0);
    return MaxErrors(recording, IndexThreeSine::Exact);
  };
  const VectorXd coarse = errors_with_step(0.04);
  const VectorXd fine = errors_with_step(0.02);
  // Halving h divides the errors by 2^3 and 2^2, up to higher-order terms (~ h relative).
  CHECK(coarse(1) / fine(1) == Approx(8.0).epsilon(0.1));
  CHECK(coarse(2) / fine(2) == Approx(4.0).epsilon(0.1));
}

TEST_CASE("Radau IIA solves an index-2 DAE", "[integrators]") {
  IndexTwoExponential dae;
  const RadauOptions options;  // rtol 1e-8, atol 1e-10
  Recording recording;
  const SolveSummary summary =
      IntegrateRadau(dae, 0.0, Vector({1.0, -1.0}), 5.0, {}, options, RecordInto(recording));
  REQUIRE(summary.IsUsable());
  // x1 is fixed by the constraint (exact to round-off); x2 (index 2) is accurate to O(h^3):
  // ~1e-5 with steps of ~0.04 (measured 1.4e-5, near t = 0 where x2 changes fastest).
  const VectorXd errors = MaxErrors(recording, IndexTwoExponential::Exact);
  CHECK(errors(0) < 1e-12);
  CHECK(errors(1) < 1e-4);
  CHECK(summary.steps < 200);  // measured 120
}

TEST_CASE("Radau IIA handles a mass matrix that depends on the state", "[integrators]") {
  StateDependentMass dae;
  const RadauOptions options;  // rtol 1e-8, atol 1e-10
  Recording recording;
  const SolveSummary summary =
      IntegrateRadau(dae, 0.0, Vector({0.0, 1.0}), 10.0, {}, options, RecordInto(recording));
  REQUIRE(summary.IsUsable());
  // The oscillator does not damp errors: local errors near rtol accumulate over the ~130
  // steps to about rtol times the amplitude 1 (measured 1.4e-8).
  const VectorXd errors = MaxErrors(recording, StateDependentMass::Exact);
  CHECK(errors(0) < 1e-7);
  CHECK(errors(1) < 1e-7);
  CHECK(summary.steps < 200);  // measured 131
}

TEST_CASE("Euler backward on x' = -x is x_k = (1 + h)^-k exactly", "[integrators]") {
  // The scheme itself in closed form: x_{k+1} (1 + h) = x_k.
  Decay decay;
  const double h = 0.1;
  Recording recording;
  const SolveSummary summary =
      IntegrateRadau(decay, 0.0, Vector({1.0}), 1.0, {}, EulerOptions(h), RecordInto(recording));
  REQUIRE(summary.IsUsable());
  CHECK(summary.steps == 10);
  REQUIRE(recording.times.size() == 11);
  for (std::size_t k = 0; k < recording.times.size(); ++k) {
    CHECK(recording.times[k] == Approx(double(k) * h).margin(1e-15));  // grid t_start + k h
    // Newton on this linear problem leaves only round-off after its second iteration (the
    // difference Jacobian is off by ~1e-8, the residual is exact); 1e-13 is ~100 roundings.
    CHECK(recording.states[k](0) == Approx(std::pow(1.0 + h, -double(k))).epsilon(1e-13));
  }
  CHECK(recording.times.back() == 1.0);
}

TEST_CASE("Euler backward on the index-3 DAE converges with order 1", "[integrators]") {
  // Euler backward keeps the constraint x1 = sin t exactly; x2 and u are difference quotients
  // of it, with errors ~ h sin(t) / 2 and ~ h cos(t) (both O(h), nonzero at t = 2).
  IndexThreeSine dae;
  const auto error_at_end = [&dae](double h) {
    Recording recording;
    const SolveSummary summary = IntegrateRadau(dae, 0.0, Vector({0.0, 1.0, 0.0}), 2.0, {},
                                                EulerOptions(h), RecordInto(recording));
    REQUIRE(summary.IsUsable());
    CHECK(summary.steps == std::lround(2.0 / h));
    CHECK(recording.states.back()(0) == Approx(std::sin(2.0)).margin(1e-12));  // the constraint
    return (recording.states.back() - IndexThreeSine::Exact(2.0)).cwiseAbs().eval();
  };
  const VectorXd coarse = error_at_end(0.01);
  const VectorXd fine = error_at_end(0.005);
  // Order 1: halving h halves the error, up to the O(h^2) remainder (~ h relative).
  CHECK(coarse(1) / fine(1) == Approx(2.0).epsilon(0.02));
  CHECK(coarse(2) / fine(2) == Approx(2.0).epsilon(0.02));
  CHECK(coarse(1) == Approx(0.01 * std::sin(2.0) / 2.0).epsilon(0.05));
  CHECK(coarse(2) == Approx(0.01 * std::abs(std::cos(2.0))).epsilon(0.05));
}

TEST_CASE("Euler backward handles the state-dependent mass matrix and the index-2 DAE",
          "[integrators]") {
  // Order 1: the global error is ~ h times the solution's second derivative (<= 1 for the
  // oscillator over [0, 1], <= 4 for e^-2t), so h = 1e-3 gives errors below 1e-3 and 4e-3.
  StateDependentMass oscillator;
  Recording oscillator_steps;
  REQUIRE(IntegrateRadau(oscillator, 0.0, Vector({0.0, 1.0}), 1.0, {}, EulerOptions(1e-3),
                         RecordInto(oscillator_steps))
              .IsUsable());
  CHECK((oscillator_steps.states.back() - StateDependentMass::Exact(1.0)).cwiseAbs().maxCoeff() <
        1e-3);

  IndexTwoExponential index_two;
  Recording index_two_steps;
  REQUIRE(IntegrateRadau(index_two, 0.0, Vector({1.0, -1.0}), 1.0, {}, EulerOptions(1e-3),
                         RecordInto(index_two_steps))
              .IsUsable());
  CHECK((index_two_steps.states.back() - IndexTwoExponential::Exact(1.0)).cwiseAbs().maxCoeff() <
        4e-3);
}

TEST_CASE("Radau IIA steps exactly onto breakpoints and t_end", "[integrators]") {
  KinkedRamp ramp;
  RadauOptions options;
  Recording recording;
  // 2.5 lies beyond t_end and 0 at t_start: both are ignored; the duplicate 1 counts once.
  const std::vector<double> breakpoints = {2.5, 1.0, 0.3, 1.0, 0.0};
  const SolveSummary summary =
      IntegrateRadau(ramp, 0.0, Vector({0.0}), 2.2, breakpoints, options, RecordInto(recording));
  REQUIRE(summary.IsUsable());
  const auto observed = [&recording](double t) {
    return std::count(recording.times.begin(), recording.times.end(), t);
  };
  CHECK(observed(0.3) == 1);
  CHECK(observed(1.0) == 1);
  CHECK(recording.times.back() == 2.2);
  CHECK(summary.stop_time == 2.2);
  CHECK(std::is_sorted(recording.times.begin(), recording.times.end()));
  // No step straddles the kink, so each is exact for the quadratic pieces: round-off only.
  for (std::size_t k = 0; k < recording.times.size(); ++k) {
    CHECK(recording.states[k](0) == Approx(KinkedRamp::Exact(recording.times[k])).margin(1e-13));
  }
}

TEST_CASE("Euler backward keeps its grid and adds the breakpoints to it", "[integrators]") {
  Decay decay;
  Recording recording;
  const SolveSummary summary = IntegrateRadau(decay, 0.0, Vector({1.0}), 0.5, {0.25},
                                              EulerOptions(0.1), RecordInto(recording));
  REQUIRE(summary.IsUsable());
  const std::vector<double> expected = {0.0, 0.1, 0.2, 0.25, 0.3, 0.4, 0.5};
  REQUIRE(recording.times.size() == expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) {
    CHECK(recording.times[k] == Approx(expected[k]).margin(1e-15));  // t_start + k h, rounded
  }
  CHECK(recording.times[3] == 0.25);  // breakpoints and t_end exactly
  CHECK(recording.times.back() == 0.5);
}

TEST_CASE("the default options are valid", "[integrators]") {
  CHECK_NOTHROW(RadauOptions{}.Validate());
  CHECK_NOTHROW(EulerOptions(0.01).Validate());
}

TEST_CASE("each invalid option gives a UsageError naming the field", "[integrators]") {
  const auto invalid = [](auto change) {
    RadauOptions options;
    change(options);
    return options;
  };
  using Catch::Contains;
  CHECK_THROWS_AS(invalid([](RadauOptions& o) { o.rtol = -1.0; }).Validate(), UsageError);
  CHECK_THROWS_WITH(invalid([](RadauOptions& o) { o.rtol = -1.0; }).Validate(),
                    Contains("RadauOptions::rtol = -1: must be"));
  CHECK_THROWS_WITH(invalid([](RadauOptions& o) { o.rtol = 0.0; }).Validate(),
                    Contains("RadauOptions::rtol = 0"));
  CHECK_THROWS_WITH(invalid([](RadauOptions& o) { o.stages = 2; }).Validate(),
                    Contains("RadauOptions::stages = 2: must be 1"));
  CHECK_THROWS_WITH(invalid([](RadauOptions& o) { o.atol = -1e-3; }).Validate(),
                    Contains("RadauOptions::atol = -0.001"));
  CHECK_THROWS_WITH(invalid([](RadauOptions& o) { o.initial_step = -1.0; }).Validate(),
                    Contains("RadauOptions::initial_step = -1"));
  CHECK_THROWS_WITH(invalid([](RadauOptions& o) { o.stages = 1; }).Validate(),
                    Contains("RadauOptions::fixed_step = 0: must be > 0 when stages = 1"));
  CHECK_THROWS_WITH(invalid([](RadauOptions& o) { o.fixed_step = -0.1; }).Validate(),
                    Contains("RadauOptions::fixed_step = -0.1"));
  CHECK_THROWS_WITH(invalid([](RadauOptions& o) { o.max_step = 0.0; }).Validate(),
                    Contains("RadauOptions::max_step = 0: must be > 0"));
  CHECK_THROWS_WITH(invalid([](RadauOptions& o) { o.max_step = std::nan(""); }).Validate(),
                    Contains("RadauOptions::max_step = nan"));
  CHECK_THROWS_WITH(invalid([](RadauOptions& o) { o.max_steps = 0; }).Validate(),
                    Contains("RadauOptions::max_steps = 0: must be >= 1"));
  CHECK_THROWS_WITH(invalid([](RadauOptions& o) { o.max_newton_iterations = 0; }).Validate(),
                    Contains("RadauOptions::max_newton_iterations = 0: must be >= 1"));
}

TEST_CASE("IntegrateRadau validates its options and its problem before it starts",
          "[integrators]") {
  Decay decay;
  RadauOptions bad;
  bad.rtol = -1.0;
  using Catch::Contains;
  CHECK_THROWS_WITH(IntegrateRadau(decay, 0.0, Vector({1.0}), 1.0, {}, bad, {}),
                    Contains("RadauOptions::rtol"));
  CHECK_THROWS_WITH(IntegrateRadau(decay, 0.0, Vector({1.0, 2.0}), 1.0, {}, {}, {}),
                    Contains("x_start has size 2"));
  CHECK_THROWS_WITH(IntegrateRadau(decay, 1.0, Vector({1.0}), 0.0, {}, {}, {}),
                    Contains("t_end >= t_start"));
}

TEST_CASE("an integration over an empty interval converges at once", "[integrators]") {
  Decay decay;
  Recording recording;
  const SolveSummary summary =
      IntegrateRadau(decay, 3.0, Vector({1.0}), 3.0, {}, {}, RecordInto(recording));
  CHECK(summary.IsUsable());
  CHECK(summary.steps == 0);
  CHECK(summary.stop_time == 3.0);
  CHECK(recording.times == std::vector<double>{3.0});
}

TEST_CASE("a model that cannot be evaluated stops the integration with its reason",
          "[integrators]") {
  FailsAfterTwo dae;
  for (const RadauOptions& options : {RadauOptions{}, EulerOptions(0.1)}) {
    INFO("stages = " << options.stages);
    SolveSummary summary;
    REQUIRE_NOTHROW(summary = IntegrateRadau(dae, 0.0, Vector({1.0}), 5.0, {}, options, {}));
    CHECK_FALSE(summary.IsUsable());
    CHECK(summary.status == SolveStatus::kNoConvergence);
    CHECK_THAT(summary.message, Catch::Contains("at t = 2") && Catch::Contains("M(q) is singular"));
    // Radau halves its step until it falls below round-off of t (~1e-14) just before t = 2;
    // Euler backward stops at the grid point 2 after halving the step beyond it five times.
    CHECK(summary.stop_time == Approx(2.0).margin(1e-9));
    CHECK(summary.rejected_steps > 0);
  }
}

TEST_CASE("a failure at the start point is reported at once", "[integrators]") {
  FailsAfterTwo dae;
  const SolveSummary summary = IntegrateRadau(dae, 3.0, Vector({1.0}), 4.0, {}, {}, {});
  CHECK(summary.status == SolveStatus::kNoConvergence);
  CHECK(summary.message == "at t = 3 s: M(q) is singular");
  CHECK(summary.stop_time == 3.0);
  CHECK(summary.steps == 0);
}

TEST_CASE("an observer returning false interrupts the integration", "[integrators]") {
  Decay decay;
  int calls = 0;
  double last_time = -1.0;
  const StepObserver stop_at_third_call = [&](double t, const VectorXd&) {
    last_time = t;
    return ++calls < 3;
  };
  for (const RadauOptions& options : {RadauOptions{}, EulerOptions(0.1)}) {
    calls = 0;
    const SolveSummary summary =
        IntegrateRadau(decay, 0.0, Vector({1.0}), 10.0, {}, options, stop_at_third_call);
    CHECK(summary.status == SolveStatus::kInterrupted);
    CHECK_FALSE(summary.IsUsable());
    CHECK(summary.steps == 2);  // the start point and two steps were observed
    CHECK(summary.stop_time == last_time);
    CHECK_THAT(summary.message, Catch::Contains("interrupted"));
  }
}

TEST_CASE("the step limit stops the integration with kTooManySteps", "[integrators]") {
  Decay decay;
  RadauOptions options = EulerOptions(0.1);
  options.max_steps = 5;
  const SolveSummary summary = IntegrateRadau(decay, 0.0, Vector({1.0}), 10.0, {}, options, {});
  CHECK(summary.status == SolveStatus::kTooManySteps);
  CHECK(summary.steps == 5);
  CHECK(summary.stop_time == Approx(0.5));
  CHECK_THAT(summary.message, Catch::Contains("max_steps = 5"));
}

TEST_CASE("max_step bounds every Radau step", "[integrators]") {
  Decay decay;
  RadauOptions options;
  options.max_step = 0.25;
  Recording recording;
  const SolveSummary summary =
      IntegrateRadau(decay, 0.0, Vector({1.0}), 10.0, {}, options, RecordInto(recording));
  REQUIRE(summary.IsUsable());
  CHECK(summary.steps >= 40);
  for (std::size_t k = 1; k < recording.times.size(); ++k) {
    CHECK(recording.times[k] - recording.times[k - 1] <= 0.25);
  }
}

}  // namespace
}  // namespace servokit
