#include "models/units.h"

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
       {"", "   ", "abc", "5 rad", "deg", "5 deg deg", "5x", "1,5", "nan", "NaN", "inf", "-inf",
        "infinity", "1e400", "nan deg", "inf deg", "0x10", "5 5"}) {
    INFO("text: '" << text << "'");
    CHECK_FALSE(ParseQuantity(text).has_value());
  }
}

TEST_CASE("radians convert back to degrees", "[models]") {
  CHECK(RadiansToDegrees(std::numbers::pi) == Approx(180.0).epsilon(kRelativeTolerance));
  CHECK(RadiansToDegrees(*ParseQuantity("5 deg")) == Approx(5.0).epsilon(kRelativeTolerance));
}

}  // namespace
}  // namespace servokit
