// Thresholds along one parameter (issue #3), against closed forms derived by hand:
//  - Mass on car, d = 1: the zero dynamics m2 sin^2(a) s^2 + d s + k (Eq. 36) is over-damped
//    while d^2 >= 4 m2 k sin^2(a): a* = asin(d / sqrt(4 m2 k)) = asin(1/sqrt(40)) = 9.0974 deg
//    (paper Sect. 4.1: "over-damped below 9.1 deg").
//  - Rotational arm, Eq. (56): a2 = m l^2 (2l - 3s) changes sign at s = 2l/3, where one
//    eigenvalue leaves through infinity and P vanishes (realization event); the discriminant
//    a1^2 - 4 a2 a0 = 0 gives the oscillation threshold
//    s* = (48 m l^3 c - 36 d^2 l) / (36 d^2 + 72 m l^2 c), just below 2l/3.
#include "analysis/thresholds.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>

#include "analysis/characteristic_polynomial.h"
#include "models/errors.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;

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

TEST_CASE("collocated output only at s = 0: ideal turns non-ideal right after", "[analysis]") {
  const ThresholdSearch search =
      Search("rotational_arm.yaml", "s", 0.0, 0.5, ThresholdEvent::kRealization);
  REQUIRE(search.events.size() == 1);
  CHECK(search.events[0].value == Approx(0.0).margin(1e-9));
  CHECK(search.events[0].from == "ideal-orthogonal");
}

TEST_CASE("no event where nothing changes", "[analysis]") {
  const ThresholdSearch search =
      Search("rotational_arm.yaml", "s", 0.0, 0.5, ThresholdEvent::kStability);
  CHECK(search.events.empty());
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

TEST_CASE("no closed form where the operating point moves with the parameter", "[analysis]") {
  // The crane's hoist holds W = -m g at rest: u != 0, so M, K, D at q = 0, u = 0 do not apply.
  const Model model = LoadModel(ModelPath("gantry_crane.yaml"));
  CHECK_FALSE(DeriveCharacteristicPolynomial(model, *model.FindParameter("m"), 1, 10));
}

}  // namespace
}  // namespace servokit
