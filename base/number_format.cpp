#include "base/number_format.h"

#include <charconv>
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

void AppendExact(std::string& out, double value) {
  // The shortest text that reads back to the same double (std::to_chars without a precision):
  // exact like "%.17g", without its noise digits, and several times faster, which matters for
  // sweeps that write tens of millions of numbers.
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, WithoutNegativeZero(value));
  out.append(buffer, result.ptr);
}

std::string FormatExact(double value) {
  std::string text;
  AppendExact(text, value);
  return text;
}

std::string FormatShort(double value) {
  // Below this the value is round-off of an exact zero; printing "-1.2e-317" helps no one.
  constexpr double kPrintedAsZero = 1e-300;
  if (std::abs(value) < kPrintedAsZero) return "0";
  return Printf("%.6g", value);
}

std::string FormatPrecise(double value) { return Printf("%.12g", WithoutNegativeZero(value)); }

std::string FormatComplex(std::complex<double> value) {
  if (value.imag() == 0.0) return FormatShort(value.real());
  return FormatShort(value.real()) + (value.imag() < 0 ? " - " : " + ") +
         FormatShort(std::abs(value.imag())) + "i";
}

}  // namespace servokit
