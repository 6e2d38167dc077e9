#pragma once
// How numbers are written, in every layer: one helper for machine-read files (CSV, JSON), exact on
// read-back; one for messages (shortest round trip); and a few for people (text and Markdown
// reports, explanations), to a fixed number of significant digits.
#include <Eigen/Core>
#include <charconv>
#include <complex>
#include <string>

namespace servokit {

/// -0.0 becomes 0.0 (a held force of "-0" reads as a sign error to people); others unchanged.
inline double WithoutNegativeZero(double value) { return value + 0.0; }

/// std::to_chars's text of `value` appended to `out` in place: for a double the shortest text
/// that reads back to the same bits ("-0" and a NaN's sign kept), for an integer its digits.
/// No temporary string, for writers of many numbers.
template <typename Number>
void AppendShortest(std::string& out, Number value) {
  char buffer[32];  // the longest shortest double, "-2.2250738585072014e-308", has 24
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, result.ptr);
}

/// AppendShortest of a double as a string: what reads back bit for bit, "-0" and "-nan"
/// included (a file another program reads back exactly).
std::string FormatShortest(double value);

/// The shortest text that reads back to the same double, -0 written as 0. NaN and Inf are
/// written as "nan" / "inf"; callers that may produce them say so next to the number.
std::string FormatExact(double value);

/// FormatExact appended to `out` in place: no temporary string, for writers of many numbers.
void AppendExact(std::string& out, double value);

/// A number in a message, in its shortest form that reads back to the same double: 2 as "2",
/// 1e-15 as "1e-15" (as the user wrote it), a time to every digit that tells it apart; "nan",
/// "inf" and "-inf" for the non-finite values.
std::string FormatNumber(double value);

/// `digits` (at most 17) significant digits, as printf's "%.<digits>g" writes them ("-0", "nan",
/// "-nan" as it does): numbers in explanations, where more digits would only be noise.
std::string FormatSignificant(double value, int digits);

/// "[a, b, ...]", each value by FormatSignificant with `digits`: a vector in a message.
std::string FormatList(const Eigen::VectorXd& values, int digits);

/// A short form for people: 6 significant digits, and "0" for |value| < 1e-300.
std::string FormatShort(double value);

/// 12 significant digits: located thresholds, where the digits are the point.
std::string FormatPrecise(double value);

/// "a + bi" / "a - bi" / "a" with FormatShort parts.
std::string FormatComplex(std::complex<double> value);

/// "a + bi" / "a - bi" with `format` for a and |b|; the imaginary part is written even when 0.
std::string FormatComplexWith(std::complex<double> value, std::string (*format)(double));

}  // namespace servokit
