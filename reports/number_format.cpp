#include "reports/number_format.h"

#include <cmath>
#include <cstdio>

namespace servokit {
namespace {

std::string Printf(const char* format, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

}  // namespace

std::string FormatExact(double value) { return Printf("%.17g", WithoutNegativeZero(value)); }

std::string FormatShort(double value) {
  // Below this the value is round-off of an exact zero; printing "-1.2e-317" helps no one.
  constexpr double kPrintedAsZero = 1e-300;
  if (std::abs(value) < kPrintedAsZero) return "0";
  return Printf("%.6g", value);
}

std::string FormatComplex(std::complex<double> value) {
  if (value.imag() == 0.0) return FormatShort(value.real());
  return FormatShort(value.real()) + (value.imag() < 0 ? " - " : " + ") +
         FormatShort(std::abs(value.imag())) + "i";
}

}  // namespace servokit
