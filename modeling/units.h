#pragma once
// SI in, SI out: the one place where "<number> deg" becomes radians (style: units,
// docs/development.md), and where a parameter given in degrees is turned back into degrees for
// display.
#include <optional>
#include <string_view>

namespace servokit {

/// The unit a parameter is shown in (tables, report axes, threshold results). Values are held
/// and computed in SI whatever it is; a parameter given in degrees (in the model file, or with
/// "deg" in --set/--vary) is shown in degrees, so that degrees stay degrees.
enum class DisplayUnit { kSI, kDegree };

/// "SI" or "deg": the unit's name in JSON and sweep.json.
std::string_view ToString(DisplayUnit unit);

/// A number as written: its value in SI units and the unit it was written in.
struct ParsedQuantity {
  double value = 0.0;                   // SI (radians for degrees)
  DisplayUnit unit = DisplayUnit::kSI;  // kDegree when written "<number> deg"
};

/// Parses "<number>" or "<number> deg" (blank before "deg" optional) into SI units, degrees
/// converted to radians. Returns std::nullopt for anything else, including NaN and Inf.
std::optional<double> ParseQuantity(std::string_view text);

/// As ParseQuantity, and says whether the text was in degrees.
std::optional<ParsedQuantity> ParseQuantityWithUnit(std::string_view text);

/// Degrees to radians: degrees * pi / 180, the one conversion every "deg" goes through.
double DegreesToRadians(double degrees);

/// Radians to degrees, for reports: radians * 180 / pi.
double RadiansToDegrees(double radians);

/// The degree value shown for an angle given in degrees: of the doubles within a few units in the
/// last place of RadiansToDegrees(radians), the one with the shortest decimal form among those
/// that DegreesToRadians takes back to exactly `radians`. So "5 deg" is shown as 5 although
/// 5 * pi / 180 * 180 / pi is not exactly 5 in floating point, and a shown value read back as
/// "<value> deg" gives the same SI value bit for bit. RadiansToDegrees(radians) when no
/// neighbour goes back exactly.
double DisplayDegrees(double radians);

}  // namespace servokit
