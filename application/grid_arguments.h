#pragma once
// The command-line grammar of a varied parameter, `--vary name=a:b:n` (a range) or
// `--vary name=v1,v2,...` (a list), read into the toolkit's GridAxis and ParameterGrid
// (analysis/parameter_grid.h). Used by `servokit sweep` and `servokit report MODEL`, for models
// of either kind: only the parameter names come from the model.
#include <string>
#include <string_view>
#include <vector>

#include "analysis/parameter_grid.h"

namespace servokit {

/// Parses one `--vary` argument: "name=a:b:n" (a range) or "name=v1,v2,..." (a list; one value
/// is a list of one). Each of a, b and v is a number in SI units or "<number> deg" (ParseQuantity),
/// so "alpha=0deg:90deg:91" and "alpha=0 deg:90 deg:91" mean the same; n is a whole number >= 1.
/// `parameter_names` are the model's. Throws UsageError "--vary <text>: ..." naming the problem:
/// bad syntax, unknown parameter (the message lists the known ones), a value that is not a
/// number, n < 1.
GridAxis ParseGridAxis(const std::vector<std::string>& parameter_names, std::string_view text);

/// ParseGridAxis for each text, then the grid over them in the same order. Throws UsageError
/// "--vary name: ..." also when a parameter is varied twice or the grid is too large.
ParameterGrid ParseParameterGrid(const std::vector<std::string>& parameter_names,
                                 const std::vector<std::string>& texts);

}  // namespace servokit
