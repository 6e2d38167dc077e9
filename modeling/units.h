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
  bool unit_written = false;            // "deg" or "rad" written: not a bare number
};

/// Parses "<number>", "<number> deg" or "<number> rad" (a blank before the unit optional) into
/// SI units, degrees converted to radians. Returns std::nullopt for anything else, including
/// NaN and Inf.
std::optional<double> ParseQuantity(std::string_view text);

/// As ParseQuantity, and says whether the text was in degrees, and whether it named a unit.
std::optional<ParsedQuantity> ParseQuantityWithUnit(std::string_view text);

/// `quantity` read in the unit its parameter is declared in: a bare number for a parameter the
/// model gives in degrees ("alpha: 5 deg") is in degrees, so that --set alpha=45 is 45 deg, never
/// 45 rad; a number that names its unit keeps it ("0.5 rad", "30 deg"). The result is in SI and
/// says kDegree where the number is now read as degrees.
ParsedQuantity InDeclaredUnit(ParsedQuantity quantity, DisplayUnit declared);

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
