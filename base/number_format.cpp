#include "base/number_format.h"

#include <cmath>
#include <cstdio>

namespace servokit {

std::string FormatShortest(double value) {
  std::string text;
  AppendShortest(text, value);
  return text;
}

void AppendExact(std::string& out, double value) {
  // The shortest text that reads back to the same double (std::to_chars without a precision):
  // exact like "%.17g", without its noise digits, and several times faster, which matters for
  // sweeps that write tens of millions of numbers.
  AppendShortest(out, WithoutNegativeZero(value));
}

std::string FormatExact(double value) {
  std::string text;
  AppendExact(text, value);
  return text;
}

std::string FormatNumber(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  return FormatShortest(value);
}

std::string FormatSignificant(double value, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, value);
  return buffer;
}

std::string FormatList(const Eigen::VectorXd& values, int digits) {
  std::string text = "[";
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    text += (i ? ", " : "") + FormatSignificant(values(i), digits);
  }
  return text + "]";
}

std::string FormatShort(double value) {
  // Below this the value is round-off of an exact zero; printing "-1.2e-317" helps no one.
  constexpr double kPrintedAsZero = 1e-300;
  if (std::abs(value) < kPrintedAsZero) return "0";
  return FormatSignificant(value, 6);
}

std::string FormatPrecise(double value) {
  return FormatSignificant(WithoutNegativeZero(value), 12);
}

std::string FormatComplexWith(std::complex<double> value, std::string (*format)(double)) {
  return format(value.real()) + (value.imag() < 0 ? " - " : " + ") +
         format(std::abs(value.imag())) + "i";
}

std::string FormatComplex(std::complex<double> value) {
  if (value.imag() == 0.0) return FormatShort(value.real());
  return FormatComplexWith(value, FormatShort);
}

}  // namespace servokit
