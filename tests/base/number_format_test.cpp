// base/number_format.h: how every layer writes numbers. The expected texts are written out by
// hand: the shortest decimal that reads back to the same double (IEEE 754 round trip), integers
// exactly, and printf's %g to a number of significant digits (C11 7.21.6.1).
#include "base/number_format.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <string>

namespace servokit {
namespace {

TEST_CASE("numbers in messages are the shortest text that reads back exactly", "[base]") {
  CHECK(FormatNumber(2.0) == "2");
  CHECK(FormatNumber(-1.0) == "-1");
  CHECK(FormatNumber(1e-15) == "1e-15");
  CHECK(FormatNumber(0.1) == "0.1");
  CHECK(FormatNumber(0.1 + 0.2) == "0.30000000000000004");  // 0.1 + 0.2 is not 0.3 in binary
  CHECK(FormatNumber(1.0 / 3.0) == "0.3333333333333333");
  CHECK(FormatNumber(std::nan("")) == "nan");
  CHECK(FormatNumber(std::numeric_limits<double>::infinity()) == "inf");
  CHECK(FormatNumber(-std::numeric_limits<double>::infinity()) == "-inf");
  CHECK(FormatNumber(-std::numeric_limits<double>::denorm_min()) == "-5e-324");
}

TEST_CASE("the shortest text keeps what reads back bit for bit: -0 and integers", "[base]") {
  CHECK(FormatShortest(0.1) == "0.1");
  CHECK(FormatShortest(-0.0) == "-0");
  CHECK(FormatExact(-0.0) == "0");  // a held force of "-0" reads as a sign error to people
  CHECK(FormatShortest(std::numeric_limits<double>::infinity()) == "inf");
  std::string row;
  AppendShortest(row, 12);
  row += ' ';
  AppendShortest(row, std::size_t{7});
  row += ' ';
  AppendShortest(row, -2.5);
  CHECK(row == "12 7 -2.5");
}

TEST_CASE("significant digits are printf's %g: no trailing zeros, exponent when small", "[base]") {
  CHECK(FormatSignificant(2.0, 6) == "2");
  CHECK(FormatSignificant(1.0 / 3.0, 6) == "0.333333");
  CHECK(FormatSignificant(1.0 / 3.0, 2) == "0.33");
  CHECK(FormatSignificant(123456789.0, 3) == "1.23e+08");
  CHECK(FormatSignificant(1e-5, 6) == "1e-05");
  CHECK(FormatSignificant(-0.0, 6) == "-0");
  CHECK(FormatShort(-0.0) == "0");  // below 1e-300: round-off of an exact zero
  CHECK(FormatShort(1e-301) == "0");
  CHECK(FormatPrecise(1.0 / 3.0) == "0.333333333333");
}

TEST_CASE("vectors and complex numbers are joined from their parts' texts", "[base]") {
  CHECK(FormatList(Eigen::Vector3d(1.0, -0.5, 1.0 / 3.0), 6) == "[1, -0.5, 0.333333]");
  CHECK(FormatList(Eigen::VectorXd(0), 6) == "[]");
  CHECK(FormatComplex({1.5, 0.0}) == "1.5");
  CHECK(FormatComplex({1.5, -2.0}) == "1.5 - 2i");
  CHECK(FormatComplexWith({0.1, 0.0}, FormatNumber) == "0.1 + 0i");
  CHECK(FormatComplexWith({0.1 + 0.2, -1.0}, FormatNumber) == "0.30000000000000004 - 1i");
}

}  // namespace
}  // namespace servokit
