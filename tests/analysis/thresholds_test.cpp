// Thresholds along one parameter (issue #3), against closed forms derived by hand:
//  - Mass on car, d = 1: the zero dynamics m2 sin^2(a) s^2 + d s + k (Eq. 36) is over-damped
//    while d^2 >= 4 m2 k sin^2(a): a* = asin(d / sqrt(4 m2 k)) = asin(1/sqrt(40)) = 9.0974 deg
//    (paper Sect. 4.1: "over-damped below 9.1 deg").
//  - Rotational arm, Eq. (56): a2 = m l^2 (2l - 3s) changes sign at s = 2l/3, where one
//    eigenvalue leaves through infinity and P vanishes (realization event); the discriminant
//    a1^2 - 4 a2 a0 = 0 gives the oscillation threshold
//    s* = (48 m l^3 c - 36 d^2 l) / (36 d^2 + 72 m l^2 c), just below 2l/3.
//  - Isolated points (issue #18): the mass on car is ideal-orthogonal at alpha = 90 deg only
//    (H = [1, cos a], so the part of B = [1, 0] in ker H is [cos^2 a, -cos a] / (1 + cos^2 a),
//    zero at 90 deg only); the two-link arm at q = 0 (H = [1, kappa]) at kappa = 0 only, and
//    P ~ M22 - kappa M21 vanishes at kappa = M22 / M21 = (l2^2/3) / (l2^2/3 + l1 l2/2) = 0.4.
//  - Stability through 0: the mass on car's Eq. (36) m2 sin^2(a) l^2 + d l + k has a pair with
//    Re = -d / (2 m2 sin^2 a), on the axis at d = 0 only, and a root -k/d + O(k^2) through 0 at
//    k = 0; the arm's Eq. (56) a root -a0/a1 = -c/d through 0 at c = 0.
//  - Structure (paper Sect. 3, cases 3 and 4): at alpha = 0 the output is realized
//    tangentially; with d != 0 the third derivative of y carries F (relative degree 3, index
//    4), with d = 0 only the fourth does (relative degree 4, index 5): a change at d = 0 only.
//  - Operating point: the two-link arm at rest has q1 + q2 = 0 (hanging) or pi (inverted) and
//    q1 + kappa q2 = y0, so q2 = -y0 / (1 - kappa) or pi / (1 - kappa); P = H M^-1 B vanishes
//    where M22 = kappa M21(q2), i.e. (l1 = l2) kappa (2 + 3 cos q2) = 2.
#include "analysis/thresholds.h"

#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>

#include "analysis/characteristic_polynomial.h"
#include "analysis/zero_dynamics.h"
#include "base/errors.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

constexpr double kL = 1.0, kMass = 3.438, kC = 50.0, kD = 0.25;

ThresholdSearch Search(const std::string& file,
                       const std::string& parameter,
                       double low,
                       double high,
                       ThresholdEvent event,
                       const std::vector<ParameterOverride>& overrides = {}) {
  const Model model = LoadModel(ModelPath(file), overrides);
  return FindThresholds(model, *model.FindParameter(parameter), low, high, event);
}

TEST_CASE("the over-damping threshold of the mass on car at d = 1 is asin(1/sqrt(40))",
          "[analysis][paper]") {
  const double degree = std::numbers::pi / 180;
  const ThresholdSearch search = Search("mass_on_car.yaml", "alpha", 0.5 * degree, 90 * degree,
                                        ThresholdEvent::kOscillation, {{"d", "1"}});
  REQUIRE(search.events.size() == 1);
  const double expected = std::asin(1.0 / std::sqrt(4.0 * 2.0 * 5.0));
  CHECK(search.events[0].value == Approx(expected).epsilon(1e-8));
  // asin(1 / sqrt(40)) = 9.0974 deg, which the paper rounds to 9.1 deg (Sect. 4.1).
  CHECK(search.events[0].value / degree == Approx(9.0974).epsilon(1e-5));
  CHECK(search.events[0].from == "non-oscillatory");
  CHECK(search.events[0].to == "oscillatory (1 mode)");
}

TEST_CASE("the arm turns unstable at s/l = 2/3, through infinity", "[analysis][paper]") {
  const ThresholdSearch search =
      Search("rotational_arm.yaml", "s", 0.0, kL, ThresholdEvent::kStability);
  REQUIRE(search.events.size() == 1);
  CHECK(search.events[0].value == Approx(2.0 * kL / 3.0).epsilon(1e-9));
  CHECK(search.events[0].from == "asymptotically-stable");
  CHECK(search.events[0].to == "unstable");
}

TEST_CASE("the arm stops oscillating where the discriminant of Eq. (56) vanishes",
          "[analysis][paper]") {
  const double expected = (48 * kMass * kL * kL * kL * kC - 36 * kD * kD * kL) /
                          (36 * kD * kD + 72 * kMass * kL * kL * kC);
  REQUIRE(expected < 2.0 / 3.0);
  const ThresholdSearch search =
      Search("rotational_arm.yaml", "s", 0.5, 0.6666, ThresholdEvent::kOscillation);
  REQUIRE(search.events.size() == 1);
  CHECK(search.events[0].value == Approx(expected).epsilon(1e-10));
  CHECK(search.events[0].from == "oscillatory (1 mode)");
  CHECK(search.events[0].to == "non-oscillatory");
}

TEST_CASE("P of the arm passes through zero at s = 2l/3: a realization event", "[analysis]") {
  const ThresholdSearch search =
      Search("rotational_arm.yaml", "s", 0.1, kL, ThresholdEvent::kRealization);
  REQUIRE(search.events.size() == 1);
  CHECK(search.events[0].value == Approx(2.0 * kL / 3.0).epsilon(1e-10));
  CHECK(search.events[0].from == "non-ideal-orthogonal");
  CHECK(search.events[0].to == "non-ideal-orthogonal");
  CHECK(search.events[0].via == "tangential");
}

TEST_CASE("P of the mass on car touches zero at alpha = 0 without changing sign", "[analysis]") {
  // P = sin^2(alpha) / (m1 + m2 sin^2(alpha)) >= 0 (Eq. 30): tangential at alpha = 0 only. The
  // range is chosen so that no scan point lands on 0; the minimizer of sigma_min(P) finds it.
  const double degree = std::numbers::pi / 180;
  const ThresholdSearch search = Search("mass_on_car.yaml", "alpha", -10 * degree, 13 * degree,
                                        ThresholdEvent::kRealization, {{"d", "1"}});
  REQUIRE(search.events.size() == 1);
  CHECK(search.events[0].value == Approx(0.0).margin(1e-7));
  CHECK(search.events[0].from == "non-ideal-orthogonal");
  CHECK(search.events[0].to == "non-ideal-orthogonal");
  CHECK(search.events[0].via == "tangential");
}

TEST_CASE("collocated output only at s = 0: the event is at 0, not at the band's edge",
          "[analysis]") {
  // y = alpha + s/(s+l) beta is collocated at s = 0 only (paper Sect. 4.2): the ideal state
  // holds on [0, 1e-10] by the rank tolerance, and the true place, 0, is what is reported.
  const ThresholdSearch search =
      Search("rotational_arm.yaml", "s", 0.0, 0.5, ThresholdEvent::kRealization);
  REQUIRE(search.events.size() == 1);
  CHECK(search.events[0].value == 0.0);
  CHECK(search.events[0].bracket_width <= 1e-9);
  CHECK(search.events[0].from == "ideal-orthogonal");
}

// Whether `event` holds `expected` within value +- bracket_width / 2.
bool Contains(const ThresholdCrossing& event, double expected) {
  return std::abs(event.value - expected) <= 0.5 * event.bracket_width;
}

TEST_CASE("the ideal-orthogonal alpha = 90 deg is found whatever the scan grid", "[analysis]") {
  const double degree = std::numbers::pi / 180;
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const std::size_t alpha = *model.FindParameter("alpha");
  for (const double high : {100.0, 100.3, 97.77}) {
    for (const int intervals : {1, 7, 400, 401}) {
      INFO("high " << high << " deg, " << intervals << " intervals");
      ThresholdOptions options;
      options.scan_intervals = intervals;
      const ThresholdSearch search = FindThresholds(model, alpha, 80 * degree, high * degree,
                                                    ThresholdEvent::kRealization, options);
      REQUIRE(search.events.size() == 1);
      CHECK(search.events[0].via == "ideal-orthogonal");
      CHECK(search.events[0].from == "non-ideal-orthogonal");
      CHECK(search.events[0].to == "non-ideal-orthogonal");
      CHECK(Contains(search.events[0], std::numbers::pi / 2));
      // The band where |D^T B| / |B| = |cos a| / sqrt(1 + cos^2 a) <= 1e-10 (rank tolerance).
      CHECK(search.events[0].bracket_width <= 3e-10);
    }
  }
}

TEST_CASE("the two-link arm's kappa = 0 and P = 0 at kappa = 0.4 are found on -1:2", "[analysis]") {
  const Model model = LoadModel(TestDataPath("two_link_arm_gravity.yaml"));
  const ThresholdSearch search =
      FindThresholds(model, *model.FindParameter("kappa"), -1.0, 2.0, ThresholdEvent::kRealization);
  REQUIRE(search.events.size() == 2);
  CHECK(search.events[0].value == 0.0);
  CHECK(search.events[0].via == "ideal-orthogonal");
  CHECK(Contains(search.events[1], 0.4));
  CHECK(search.events[1].via == "tangential");
}

TEST_CASE("a touch of P = 0 gives the same one event whether or not a scan value lands on it",
          "[analysis]") {
  // P = sin^2(a) / (m1 + m2 sin^2 a) (Eq. 30) is at most 1e-10 of its scale for |a| < ~1e-5:
  // -10:10 deg puts a scan value at 0, -10:13 deg does not.
  const double degree = std::numbers::pi / 180;
  for (const double high : {10.0, 13.0}) {
    INFO("high " << high);
    const ThresholdSearch search = Search("mass_on_car.yaml", "alpha", -10 * degree, high * degree,
                                          ThresholdEvent::kRealization);
    REQUIRE(search.events.size() == 1);
    CHECK(search.events[0].value == 0.0);
    CHECK(search.events[0].via == "tangential");
    CHECK(search.events[0].bracket_width <= 1e-4);
  }
}

TEST_CASE("no event where P is zero all along (alpha = 0, m1 varies)", "[analysis]") {
  // P = sin^2(0) / ... = 0 for every m1: tangential throughout; before: 73 "tangential ->
  // tangential via P = 0" events from round-off minima of sigma(P).
  const ThresholdSearch search =
      Search("mass_on_car.yaml", "m1", 0.1, 20.0, ThresholdEvent::kRealization, {{"alpha", "0"}});
  CHECK(search.events.empty());
}

TEST_CASE("stability thresholds at exactly 0 are reported as 0, with an honest width",
          "[analysis]") {
  {
    // d: Re = -d / (2 m2 sin^2 a): unstable pair, critical at 0, stable after.
    const ThresholdSearch search =
        Search("mass_on_car.yaml", "d", -1.0, 1.3, ThresholdEvent::kStability);
    REQUIRE(search.events.size() == 1);
    CHECK(search.events[0].value == 0.0);
    CHECK(search.events[0].via == "critical");
    CHECK(search.events[0].bracket_width <= 2e-9);  // damping ratio 1e-9: |d| <= 5.5e-10
  }
  {
    // c: the root -c/d passes through 0 (reported before at -2.2e-10 "to 1.6e-22").
    const ThresholdSearch search =
        Search("rotational_arm.yaml", "c", -1.0, 1.3, ThresholdEvent::kStability);
    REQUIRE(search.events.size() == 1);
    CHECK(search.events[0].value == 0.0);
    CHECK(search.events[0].from == "unstable (2 unstable)");
    CHECK(search.events[0].to == "unstable");
    CHECK(search.events[0].bracket_width <= 1e-10);
  }
}

TEST_CASE("a slow real root through 0 beside a fast one is one event at 0", "[analysis]") {
  // k: roots -k/d (slow) and about -d / (m2 sin^2 a) = -65.8 (fast). A band relative to the
  // fast root (1e-9 * 65.8) split this into two events at +-6.6e-8; per eigenvalue it is one.
  const ThresholdSearch search =
      Search("mass_on_car.yaml", "k", -1.0, 1.3, ThresholdEvent::kStability);
  REQUIRE(search.events.size() == 1);
  CHECK(search.events[0].value == 0.0);
  CHECK(search.events[0].from == "unstable");
  CHECK(search.events[0].to == "asymptotically-stable");
  CHECK(search.events[0].bracket_width <= 1e-9);
}

TEST_CASE("the index of the tangential mass on car rises from 4 to 5 at d = 0 only",
          "[analysis][paper]") {
  const ThresholdSearch search =
      Search("mass_on_car.yaml", "d", -1.0, 1.3, ThresholdEvent::kStructure, {{"alpha", "0"}});
  REQUIRE(search.events.size() == 1);
  CHECK(search.events[0].value == 0.0);
  CHECK(search.events[0].from == "relative degree 3, index 4");  // paper case 3
  CHECK(search.events[0].to == "relative degree 3, index 4");
  CHECK(search.events[0].via == "relative degree 4, index 5");  // paper case 4
}

// The root of kappa (2 + 3 cos(q2(kappa))) = 2 in [a, b] by bisection (see the file's header).
double ArmTangentialKappa(double (*q2)(double), double a, double b) {
  auto f = [&](double kappa) { return kappa * (2 + 3 * std::cos(q2(kappa))) - 2; };
  for (int i = 0; i < 200; ++i) {
    const double middle = 0.5 * (a + b);
    (f(a) * f(middle) <= 0 ? b : a) = middle;
  }
  return 0.5 * (a + b);
}

TEST_CASE("the two-link arm's P = 0 moves with the operating point (y0 and q guess)",
          "[analysis]") {
  const Model model = LoadModel(TestDataPath("two_link_arm_gravity.yaml"));
  const std::size_t kappa = *model.FindParameter("kappa");
  {
    // Hanging, y0 = 0.2: q2 = -0.2 / (1 - kappa).
    ThresholdOptions options;
    options.classification.operating_point.y0 = Eigen::VectorXd::Constant(1, 0.2);
    const ThresholdSearch search =
        FindThresholds(model, kappa, 0.1, 0.7, ThresholdEvent::kRealization, options);
    const double expected = ArmTangentialKappa([](double k) { return -0.2 / (1 - k); }, 0.3, 0.5);
    REQUIRE(search.events.size() == 1);
    CHECK(Contains(search.events[0], expected));
    CHECK(std::abs(expected - 0.4) > 0.01);  // not the value at y0 = 0
  }
  {
    // Inverted second link (Newton from q = (0, pi)), y0 = 0: q2 = pi / (1 - kappa). Besides
    // kappa = 0 (collocated), two roots: one in (0.4, 0.5) and 4/7 (q2 = 7 pi / 3).
    ThresholdOptions options;
    options.classification.operating_point.q_guess = Eigen::Vector2d(0.0, std::numbers::pi);
    const ThresholdSearch search =
        FindThresholds(model, kappa, -0.5, 0.6, ThresholdEvent::kRealization, options);
    REQUIRE(search.events.size() == 3);
    CHECK(search.events[0].value == 0.0);
    CHECK(Contains(
        search.events[1],
        ArmTangentialKappa([](double k) { return std::numbers::pi / (1 - k); }, 0.4, 0.5)));
    CHECK(Contains(search.events[2], 4.0 / 7.0));
  }
}

TEST_CASE("no event where nothing changes", "[analysis]") {
  const ThresholdSearch search =
      Search("rotational_arm.yaml", "s", 0.0, 0.5, ThresholdEvent::kStability);
  CHECK(search.events.empty());
}

TEST_CASE("the imaginary-axis verdict is per eigenvalue, with a floor for round-off zeros",
          "[analysis]") {
  // -1e-7 is real (damping ratio 1): stable whatever its neighbour; a band of 1e-9 max |lambda|
  // (4e-7 here) called it critical.
  CHECK(ClassifyStability({{-1e-7, 0.0}, {-400.0, 0.0}}, 1e-9) == Stability::kAsymptoticallyStable);
  CHECK(ClassifyStability({{1e-7, 0.0}, {-400.0, 0.0}}, 1e-9) == Stability::kUnstable);
  // Damping ratio 1e-10 <= 1e-9: on the axis.
  CHECK(ClassifyStability({{-1e-10, 1.0}, {-1e-10, -1.0}}, 1e-9) == Stability::kCritical);
  // Below kZeroEigenvalueFloor (1e-12) of the largest magnitude: a zero eigenvalue.
  CHECK(ClassifyStability({{1e-14, 0.0}, {-100.0, 0.0}}, 1e-9) == Stability::kCritical);
  CHECK(CountRightHalfPlane({{1e-14, 0.0}, {2.0, 0.0}}, 1e-9) == 1);
}

TEST_CASE("a reversed range is a usage error", "[analysis]") {
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"));
  CHECK_THROWS_AS(FindThresholds(model, 0, 1.0, 0.0, ThresholdEvent::kStability), UsageError);
}

TEST_CASE("closed form of the arm: Eq. (56) and Stodola's a2 > 0 <=> s < 2l/3",
          "[analysis][paper]") {
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"));
  const auto closed_form = DeriveCharacteristicPolynomial(model, *model.FindParameter("s"), 0, 1);
  REQUIRE(closed_form.has_value());
  CHECK(closed_form->degree == 2);
  // Eq. (56) at s = l = 1 (up to a common factor of 1): a2 = m l^2 (2l - 3s), a1 = 6 d (s+l),
  // a0 = 6 c (s+l).
  REQUIRE(closed_form->nominal_coefficients.size() == 3);
  const double scale = closed_form->nominal_coefficients[0] / (6 * kC * 2);
  CHECK(closed_form->nominal_coefficients[1] == Approx(scale * 6 * kD * 2));
  CHECK(closed_form->nominal_coefficients[2] == Approx(scale * kMass * (2 - 3)));
  REQUIRE(closed_form->hurwitz.size() == 3);
  CHECK(closed_form->hurwitz[0].name == "a2");
  CHECK(closed_form->hurwitz[0].solved == "s < 2/3*l");
  REQUIRE(closed_form->hurwitz[0].sign_changes.size() == 1);
  CHECK(closed_form->hurwitz[0].sign_changes[0] == Approx(2.0 / 3.0).epsilon(1e-10));
  CHECK(closed_form->hurwitz[1].sign_changes.empty());  // a1 = 6 d (s + l) > 0
  CHECK(closed_form->hurwitz[2].sign_changes.empty());  // a0 = 6 c (s + l) > 0
  const double expected = (48 * kMass * kC - 36 * kD * kD) / (36 * kD * kD + 72 * kMass * kC);
  REQUIRE(closed_form->discriminant_sign_changes.size() == 1);
  CHECK(closed_form->discriminant_sign_changes[0] == Approx(expected).epsilon(1e-10));
}

TEST_CASE("closed form of the mass on car: m2 sin^2(alpha) lambda^2 + d lambda + k",
          "[analysis][paper]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"d", "1"}});
  const auto closed_form =
      DeriveCharacteristicPolynomial(model, *model.FindParameter("alpha"), 0.01, 1.5);
  REQUIRE(closed_form.has_value());
  // At the nominal alpha = 5 deg: a0 = k = 5, a1 = d = 1, a2 = m2 sin^2(alpha).
  REQUIRE(closed_form->nominal_coefficients.size() == 3);
  const double sine = std::sin(5 * std::numbers::pi / 180);
  CHECK(closed_form->nominal_coefficients[0] == Approx(5.0));
  CHECK(closed_form->nominal_coefficients[1] == Approx(1.0));
  CHECK(closed_form->nominal_coefficients[2] == Approx(2.0 * sine * sine).epsilon(1e-12));
  REQUIRE(closed_form->discriminant_sign_changes.size() == 1);
  CHECK(closed_form->discriminant_sign_changes[0] ==
        Approx(std::asin(1.0 / std::sqrt(40.0))).epsilon(1e-10));
}

TEST_CASE("a parameter inside cosh and sin: no closed form, bounded; the event where P = 0",
          "[analysis]") {
  // tests/data/flexible_link_modes.yaml: the output point xi enters each mode shape phi_i.
  // The coefficients of the characteristic polynomial (degree 6) then hold dozens of terms, and
  // the discriminant's budget (8000 terms, bounded from their lengths) refuses the closed form;
  // before the bound GiNaC's resultant ran past 14 minutes and 1.1 GB.
  const Model model = LoadModel(TestDataPath("flexible_link_modes.yaml"));
  const std::size_t xi = *model.FindParameter("xi");
  CHECK_FALSE(DeriveCharacteristicPolynomial(model, xi, 0.1, 1.0));
  // The numeric route: the zero dynamics turn unstable through infinity where P vanishes. With
  // M = [[a, c^T], [c, rho L I]] and B = e1, (M^-1)_i0 = -c_i / (rho L) (M^-1)_00, so
  // P(xi) = (M^-1)_00 (1 - sum_i c_i phi_i(xi L) / (xi L rho L)), c_i = rho L^2 2 / b_i^2:
  // its root by bisection, independent of the threshold search.
  const std::array<double, 3> b = {1.8751, 4.6941, 7.8548}, s = {0.7341, 1.0185, 0.9992};
  const auto p_factor = [&](double x) {
    double sum = 0;
    for (std::size_t i = 0; i < 3; ++i) {
      const double shape = std::cosh(b[i] * x) - std::cos(b[i] * x) -
                           s[i] * (std::sinh(b[i] * x) - std::sin(b[i] * x));
      sum += 2 / (b[i] * b[i]) * shape / x;  // rho = L = 1
    }
    return 1 - sum;
  };
  double low = 0.25, high = 0.35;
  REQUIRE(p_factor(low) > 0);
  REQUIRE(p_factor(high) < 0);
  for (int i = 0; i < 100; ++i)
    (p_factor(0.5 * (low + high)) > 0 ? low : high) = 0.5 * (low + high);
  const ThresholdSearch search = FindThresholds(model, xi, 0.1, 0.4, ThresholdEvent::kStability);
  REQUIRE(search.events.size() == 1);
  CHECK(search.events[0].value == Approx(low).epsilon(1e-10));
  CHECK(search.events[0].from == "asymptotically-stable");
  CHECK(search.events[0].to == "unstable");
}

TEST_CASE("the three-link arm keeps its closed form of degree 4 within the budget", "[analysis]") {
  // Its coefficients have at most 2 terms: the discriminant's bound, 18 monomials (isobaric
  // count for degree 4) times 2^7, is 2304 of the 8000 allowed.
  const Model model = LoadModel(ModelPath("three_link_arm.yaml"));
  const auto closed_form = DeriveCharacteristicPolynomial(model, *model.FindParameter("l"), 0.5, 2);
  REQUIRE(closed_form.has_value());
  CHECK(closed_form->degree == 4);
  CHECK_FALSE(closed_form->discriminant.empty());
}

TEST_CASE("no closed form where the operating point moves with the parameter", "[analysis]") {
  // The crane's hoist holds W = -m g at rest: u != 0, so M, K, D at q = 0, u = 0 do not apply.
  const Model model = LoadModel(ModelPath("gantry_crane.yaml"));
  CHECK_FALSE(DeriveCharacteristicPolynomial(model, *model.FindParameter("m"), 1, 10));
}

}  // namespace
}  // namespace servokit

namespace servokit {
namespace {

// Issue #33: oscillation thresholds where the zero pair passes through infinity, against their
// closed forms (derived in the model files' comments), to the stated bracket:
//  - TORA (tests/data/tora.yaml), y = x + a sin(theta): (m e - (M + m) a) theta'' = k a theta,
//    real pair below a* = m e / (M + m), undamped pair above;
//  - inertia-wheel pendulum (tests/data/inertia_wheel_pendulum.yaml), y = q1 + c q2:
//    (d11 - d12 / c) q1'' = mbar q1, undamped pair below c* = d12 / d11, real pair above.
// The classification counts P (which vanishes there with the leading coefficient) as zero in
// a band of 1e-10 relative around it; the event lies at the band's centre, not at its edge.
TEST_CASE("oscillation thresholds through infinity are where the leading coefficient vanishes",
          "[analysis]") {
  struct Case {
    std::string file, parameter;
    double low, high, expected;
    std::string from, to;
  };
  const double tora = 0.096 * 0.0592 / (1.3608 + 0.096);
  const double d11 = 0.2 * 0.1 * 0.1 + 0.3 * 0.2 * 0.2 + 0.001 + 0.002;
  const double wheel = 0.002 / d11;
  for (const Case& tested :
       {Case{"tora.yaml", "a", 0.001, 0.01, tora, "non-oscillatory", "oscillatory (1 mode)"},
        Case{"inertia_wheel_pendulum.yaml", "c", 0.1, 5.0, wheel, "oscillatory (1 mode)",
             "non-oscillatory"}}) {
    INFO(tested.file);
    const Model model = LoadModel(TestDataPath(tested.file));
    for (const ThresholdEvent event : {ThresholdEvent::kOscillation, ThresholdEvent::kStability}) {
      const ThresholdSearch search = FindThresholds(model, *model.FindParameter(tested.parameter),
                                                    tested.low, tested.high, event);
      REQUIRE(search.events.size() == 1);
      const ThresholdCrossing& crossing = search.events[0];
      CHECK(std::abs(crossing.value - tested.expected) <= crossing.bracket_width / 2);
      CHECK(crossing.bracket_width <= 1e-12);
      if (event == ThresholdEvent::kOscillation) {
        CHECK(crossing.from == tested.from);
        CHECK(crossing.to == tested.to);
      }
    }
  }
}

}  // namespace
}  // namespace servokit
