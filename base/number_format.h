#pragma once
// How numbers are written: one helper for machine-read files (CSV), exact on read-back, and one
// for people (text and Markdown reports).
#include <complex>
#include <string>

namespace servokit {

/// -0.0 becomes 0.0 (a held force of "-0" reads as a sign error to people); others unchanged.
inline double WithoutNegativeZero(double value) { return value + 0.0; }

/// The shortest text that reads back to the same double (std::to_chars). NaN and Inf are
/// written as "nan" / "inf"; callers that may produce them say so next to the number.
std::string FormatExact(double value);

/// FormatExact appended to `out` in place: no temporary string, for writers of many numbers.
void AppendExact(std::string& out, double value);

/// A short form for people: 6 significant digits, and "0" for |value| < 1e-300.
std::string FormatShort(double value);

/// 12 significant digits: located thresholds, where the digits are the point.
std::string FormatPrecise(double value);

/// "a + bi" / "a - bi" / "a" with FormatShort parts.
std::string FormatComplex(std::complex<double> value);

}  // namespace servokit
