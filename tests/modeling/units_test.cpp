#include "modeling/units.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>

namespace servokit {
namespace {

// Parsing and the degree conversion are exact up to one rounding of the product.
constexpr double kRelativeTolerance = 1e-15;

TEST_CASE("plain numbers are taken as SI values", "[models]") {
  CHECK(ParseQuantity("5") == 5.0);
  CHECK(ParseQuantity("-1.5e-3") == -1.5e-3);
  CHECK(ParseQuantity(" 2.0 ") == 2.0);
  CHECK(ParseQuantity("0") == 0.0);
  CHECK(ParseQuantity("1E3") == 1000.0);
}

TEST_CASE("degrees are converted to radians with or without a blank", "[models]") {
  const double five_degrees = 5.0 * std::numbers::pi / 180.0;
  CHECK(*ParseQuantity("5 deg") == Approx(five_degrees).epsilon(kRelativeTolerance));
  CHECK(*ParseQuantity("5deg") == Approx(five_degrees).epsilon(kRelativeTolerance));
  CHECK(*ParseQuantity(" 90  deg ") == Approx(std::numbers::pi / 2).epsilon(kRelativeTolerance));
  CHECK(*ParseQuantity("-1.5e1 deg") == Approx(-std::numbers::pi / 12).epsilon(kRelativeTolerance));
}

TEST_CASE("garbage, empty text, NaN and infinity are rejected", "[models]") {
  for (const char* text :
       {"", "   ", "abc", "rad", "5 rad rad", "deg", "5 deg deg", "5x", "1,5", "nan", "NaN", "inf",
        "-inf", "infinity", "1e400", "nan deg", "inf deg", "0x10", "5 5"}) {
    INFO("text: '" << text << "'");
    CHECK_FALSE(ParseQuantity(text).has_value());
  }
}

TEST_CASE("radians convert back to degrees", "[models]") {
  CHECK(RadiansToDegrees(std::numbers::pi) == Approx(180.0).epsilon(kRelativeTolerance));
  CHECK(RadiansToDegrees(*ParseQuantity("5 deg")) == Approx(5.0).epsilon(kRelativeTolerance));
}

TEST_CASE("the unit a quantity was written in is kept beside its SI value", "[models]") {
  CHECK(ParseQuantityWithUnit("5 deg")->unit == DisplayUnit::kDegree);
  CHECK(ParseQuantityWithUnit("5 deg")->value == DegreesToRadians(5.0));
  CHECK(ParseQuantityWithUnit("0.1")->unit == DisplayUnit::kSI);
  CHECK(ParseQuantityWithUnit("0.1")->value == 0.1);
  CHECK(ParseQuantityWithUnit("5 rad")->value == 5.0);  // named: read as radians
  CHECK(ParseQuantityWithUnit("5 rad")->unit_written);
  CHECK_FALSE(ParseQuantityWithUnit("5")->unit_written);
  CHECK(ToString(DisplayUnit::kDegree) == "deg");
  CHECK(ToString(DisplayUnit::kSI) == "SI");
}

TEST_CASE("degrees shown for an angle given in degrees are the degrees given, exactly",
          "[models]") {
  // x pi/180 * 180/pi is not always x in floating point; DisplayDegrees finds the shortest
  // degree value that converts back to the same radians, which is the one given. Checked on
  // every tenth of a degree in [-720, 720] and on a few long decimals.
  std::size_t inexact_products = 0;
  for (int tenths = -7200; tenths <= 7200; ++tenths) {
    const double degrees = tenths / 10.0;
    const double radians = DegreesToRadians(degrees);
    INFO(degrees);
    CHECK(DisplayDegrees(radians) == degrees);
    if (RadiansToDegrees(radians) != degrees) ++inexact_products;
  }
  CHECK(inexact_products > 0);  // so that the search is needed (else this test says little)
  for (const double degrees : {9.0974361693, 0.001, 1e-300, 123456.789, -33.3}) {
    INFO(degrees);
    CHECK(DisplayDegrees(DegreesToRadians(degrees)) == degrees);
  }
  // 0 deg is +0, not -0 (an HDF5 table keeps the sign that CSV text drops).
  CHECK(DisplayDegrees(0.0) == 0.0);
  CHECK_FALSE(std::signbit(DisplayDegrees(0.0)));
  CHECK(std::signbit(DisplayDegrees(-0.0)));
  // Radians that no short degree value gives are shown as the product.
  CHECK(DisplayDegrees(1.0) == Approx(RadiansToDegrees(1.0)).epsilon(1e-15));
  CHECK(DegreesToRadians(DisplayDegrees(1.0)) == Approx(1.0).epsilon(1e-15));
}

}  // namespace
}  // namespace servokit
