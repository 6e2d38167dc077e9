#pragma once
// servokit's text of a varied parameter (docs/sweep.md, "The grid"; `servokit sweep --vary`),
// read into the toolkit's GridAxis and ParameterGrid (analysis/parameter_grid.h). Used through
// the API (api::ParseSweepAxes) by `servokit sweep` and `servokit report MODEL`, for models of
// either kind: only the parameter names and display units come from the model. Every message
// starts with the caller's `label` for the text (the command line's "--vary"), so that the
// library names no flag.
//
//   name=a:b:n          n values evenly spaced from a to b, both included (servokit's range)
//   name=a:b:n=N        the same, said explicitly: N values from a to b
//   name=a:b:step=h     a, a + h, a + 2h, ... up to b: h > 0 and a <= b; b is included when
//                       (b - a) / h is within 1e-9 (relative) of a whole number m (then the
//                       values are exactly a..b in m + 1 even steps), otherwise the values stop
//                       at the last a + i h below b
//   name=v1,v2,...      a list, in its order (one value is a list of one)
//
// Each of a, b, h and v is a number in SI units or "<number> deg" (ParseQuantity). An axis with
// a value in degrees, or of a parameter the model gives in degrees, is shown in degrees
// (GridAxis::display_unit; its table column is "<name>_deg").
#include <string>
#include <string_view>
#include <vector>

#include "analysis/parameter_grid.h"
#include "modeling/units.h"

namespace servokit {

/// The model's parameters as the grammar needs them: names (parameter_names()) and the unit each
/// is shown in (parameter_display_units(); empty: all SI).
struct GridParameters {
  const std::vector<std::string>& names;
  const std::vector<DisplayUnit>& units;
};

/// Parses one axis's text (the forms above). Throws UsageError "<label> <text>: ..." naming
/// the problem: bad syntax, unknown parameter (the message lists the known ones), a value that
/// is not a number, n < 1, h <= 0, b < a in the step form. Appends to `warnings` (one line each,
/// without the "servokit: warning: " prefix) when the text is probably not what was meant:
///   - a bare a:b:n that MATLAB would read as start:step:end (no unit on a or b, b > a, n > b
///     and (n - a) / b whole): the message says how it is read and how to write either meaning;
///   - the values of an angle-like parameter (given in degrees by the model, or named alpha,
///     beta, gamma, theta, phi, psi or containing "angle") carry no unit and span more than
///     2 pi: they are radians, maybe meant as degrees.
GridAxis ParseGridAxis(const GridParameters& parameters,
                       std::string_view label,
                       std::string_view text,
                       std::vector<std::string>* warnings = nullptr);

/// ParseGridAxis for each text, then the grid over them in the same order. Throws UsageError
/// "<label> name: ..." also when a parameter is varied twice, the grid is too large, or a
/// parameter's column would clash with another column of the sweep tables (CheckSweepColumns).
ParameterGrid ParseParameterGrid(const GridParameters& parameters,
                                 std::string_view label,
                                 const std::vector<std::string>& texts,
                                 std::vector<std::string>* warnings = nullptr);

/// The same for a model whose parameters are all shown in SI, without warnings.
GridAxis ParseGridAxis(const std::vector<std::string>& parameter_names,
                       std::string_view label,
                       std::string_view text);
ParameterGrid ParseParameterGrid(const std::vector<std::string>& parameter_names,
                                 std::string_view label,
                                 const std::vector<std::string>& texts);

/// True for a parameter that is probably an angle: given in degrees by the model (`unit`), or
/// named alpha, beta, gamma, theta, phi or psi, or with "angle" in its name.
bool IsAngleLike(std::string_view name, DisplayUnit unit);

/// The warning for values of an angle-like parameter that carry no unit and span more than 2 pi
/// (from `low` to `high`, SI), or "" when there is none. `option` names the argument
/// ("--vary alpha=0:90:91").
std::string AngleSpanWarning(std::string_view option,
                             std::string_view name,
                             DisplayUnit unit,
                             bool has_unit,
                             double low,
                             double high);

}  // namespace servokit
