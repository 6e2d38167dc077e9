// Threshold curves in a parameter plane (issue #18, two-parameter maps), every traced point
// checked against closed forms derived by hand:
//  - Mass on car over (alpha, d): the zero dynamics m2 sin^2(a) s^2 + d s + k = 0 (paper
//    Eq. 36) has a double root where d^2 = 4 m2 k sin^2(a), so the over-damping (oscillation)
//    curve is d = 2 |sin a| sqrt(k m2) (k = 5, m2 = 2 in models/mass_on_car.yaml), i.e.
//    a = +-asin(d / (2 sqrt(k m2))); the realization is tangential on the line a = 0 only (P =
//    H M^-1 B ~ sin^2 a vanishes there). With d > 0 the roots have Re < 0 throughout: no
//    stability curve.
//  - Rotational arm over (s, d), paper Eq. (56): a2 = m l^2 (2l - 3s), a1 = 6 d (s + l),
//    a0 = 6 c (s + l). The leading coefficient changes sign on the line s = 2l/3 (an eigenvalue
//    leaves through infinity: stability), for any d; a1^2 = 4 a2 a0 gives the oscillation curve
//    36 d^2 (s + l) = 24 m l^2 c (2l - 3s), i.e. s = (48 m l^3 c - 36 d^2 l) / (36 d^2 + 72 m l^2
//    c) or d = sqrt(24 m l^2 c (2l - 3s) / (36 (s + l))).
#include "analysis/threshold_curves.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>

#include "base/errors.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;

constexpr double kDegree = std::numbers::pi / 180.0;
constexpr double kTolerance = 1e-8;

// |a - b| within kTolerance relative to max(1, |b|).
bool Near(double a, double b) { return std::abs(a - b) <= kTolerance * std::max(1.0, std::abs(b)); }

std::vector<const ThresholdCurve*> CurvesOf(const std::vector<ThresholdCurve>& curves,
                                            ThresholdEvent event,
                                            int traced_axis) {
  std::vector<const ThresholdCurve*> found;
  for (const ThresholdCurve& curve : curves) {
    if (curve.event == event && curve.traced_axis == traced_axis) found.push_back(&curve);
  }
  return found;
}

TEST_CASE(
    "the mass on car's (alpha, d) plane has the over-damping curve d = 2 sin(alpha) "
    "sqrt(k m2) and the tangential line alpha = 0",
    "[analysis][paper]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const std::size_t alpha = *model.FindParameter("alpha"), d = *model.FindParameter("d");
  const double k = 5.0, m2 = 2.0, scale = 2.0 * std::sqrt(k * m2);
  ThresholdCurveOptions options;
  options.lines = 20;
  const std::vector<ThresholdCurve> curves = TraceThresholdCurves(
      model, {alpha, -40 * kDegree, 60 * kDegree}, {d, 0.5, 4.0},
      {ThresholdEvent::kStability, ThresholdEvent::kOscillation, ThresholdEvent::kRealization},
      options);

  CHECK(CurvesOf(curves, ThresholdEvent::kStability, 0).empty());
  CHECK(CurvesOf(curves, ThresholdEvent::kStability, 1).empty());

  // Along alpha: one curve on each side of 0, a point on every line (asin(4 / scale) = 39.2
  // deg lies inside the range), read from oscillatory at negative alpha and to it at positive.
  const auto along_alpha = CurvesOf(curves, ThresholdEvent::kOscillation, 0);
  REQUIRE(along_alpha.size() == 2);
  for (const ThresholdCurve* curve : along_alpha) {
    CHECK(curve->points.size() == 21);
    const bool negative = curve->points.front().x < 0.0;
    CHECK(curve->from == (negative ? "oscillatory (1 mode)" : "non-oscillatory"));
    CHECK(curve->to == (negative ? "non-oscillatory" : "oscillatory (1 mode)"));
    for (const CurvePoint& point : curve->points) {
      const double expected = (negative ? -1.0 : 1.0) * std::asin(point.y / scale);
      INFO("d = " << point.y << ", alpha = " << point.x);
      CHECK(Near(point.x, expected));
    }
  }
  // Along d: the lines with 0.5 <= scale |sin alpha| <= 4 cross the curve, on both sides.
  const auto along_d = CurvesOf(curves, ThresholdEvent::kOscillation, 1);
  REQUIRE(along_d.size() == 2);
  std::size_t crossing_lines = 0;
  for (int j = 0; j <= options.lines; ++j) {
    const double a = -40 * kDegree + 100 * kDegree * j / options.lines;
    const double expected = scale * std::abs(std::sin(a));
    crossing_lines += expected > 0.5 && expected < 4.0 ? 1 : 0;
  }
  CHECK(along_d[0]->points.size() + along_d[1]->points.size() == crossing_lines);
  for (const ThresholdCurve* curve : along_d) {
    for (const CurvePoint& point : curve->points) {
      INFO("alpha = " << point.x << ", d = " << point.y);
      CHECK(Near(point.y, scale * std::abs(std::sin(point.x))));
    }
  }

  // The realization: tangential at alpha = 0 on every line along alpha; along d no line is
  // tangential at one d only.
  const auto tangential = CurvesOf(curves, ThresholdEvent::kRealization, 0);
  REQUIRE(tangential.size() == 1);
  CHECK(tangential[0]->via == "tangential");
  CHECK(tangential[0]->points.size() == 21);
  for (const CurvePoint& point : tangential[0]->points) CHECK(std::abs(point.x) <= kTolerance);
  CHECK(CurvesOf(curves, ThresholdEvent::kRealization, 1).empty());
}

TEST_CASE(
    "the rotational arm's (s, d) plane has the stability line s = 2l/3 and the "
    "oscillation curve of Eq. (56)",
    "[analysis][paper]") {
  const Model model = LoadModel(ModelPath("rotational_arm.yaml"));
  const std::size_t s = *model.FindParameter("s"), d = *model.FindParameter("d");
  const double l = 1.0, m = 3.438, c = 50.0;
  ThresholdCurveOptions options;
  options.lines = 16;
  const std::vector<ThresholdCurve> curves =
      TraceThresholdCurves(model, {s, 0.1, 1.2}, {d, 0.25, 2.0},
                           {ThresholdEvent::kStability, ThresholdEvent::kOscillation}, options);

  const auto stability = CurvesOf(curves, ThresholdEvent::kStability, 0);
  REQUIRE(stability.size() == 1);
  CHECK(stability[0]->from == "asymptotically-stable");
  CHECK(stability[0]->to == "unstable");
  REQUIRE(stability[0]->points.size() == 17);
  for (const CurvePoint& point : stability[0]->points) {
    INFO("d = " << point.y << ", s = " << point.x);
    CHECK(Near(point.x, 2.0 * l / 3.0));
  }
  // The line is parallel to the d axis: no line along d crosses it.
  CHECK(CurvesOf(curves, ThresholdEvent::kStability, 1).empty());

  const auto oscillation = CurvesOf(curves, ThresholdEvent::kOscillation, 0);
  REQUIRE(oscillation.size() == 1);
  CHECK(oscillation[0]->points.size() == 17);
  for (const CurvePoint& point : oscillation[0]->points) {
    const double d2 = point.y * point.y;
    INFO("d = " << point.y << ", s = " << point.x);
    CHECK(Near(point.x, (48 * m * l * l * l * c - 36 * d2 * l) / (36 * d2 + 72 * m * l * l * c)));
  }
  // Along d only the s lines in (s*(2), 2l/3) cross it: s = 0.1 + 1.1 j / 16 for j = 8
  // (0.65); s*(2) = 0.6475.
  for (const ThresholdCurve* curve : CurvesOf(curves, ThresholdEvent::kOscillation, 1)) {
    for (const CurvePoint& point : curve->points) {
      INFO("s = " << point.x << ", d = " << point.y);
      CHECK(Near(point.y,
                 std::sqrt(24 * m * l * l * c * (2 * l - 3 * point.x) / (36 * (point.x + l)))));
    }
  }
}

TEST_CASE("threshold curves refuse one parameter on both axes and bad options", "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const std::size_t d = *model.FindParameter("d");
  CHECK_THROWS_AS(TraceThresholdCurves(model, {d, 0, 1}, {d, 0, 1}, {ThresholdEvent::kStability}),
                  UsageError);
  ThresholdCurveOptions options;
  options.lines = 0;
  CHECK_THROWS_WITH(
      TraceThresholdCurves(model, {d, 0, 1}, {0, 1, 2}, {ThresholdEvent::kStability}, options),
      "ThresholdCurveOptions::lines = 0: must be >= 1");
  CHECK(ThresholdCurveOptions{}.lines >= 1);
  CHECK_NOTHROW(ThresholdCurveOptions{}.Validate(model));
}

}  // namespace
}  // namespace servokit
