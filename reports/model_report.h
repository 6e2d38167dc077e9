#pragma once
// `servokit report MODEL --vary ...`: the paper report's kind of study for any model.
#include <string>
#include <vector>

#include "analysis/parameter_grid.h"
#include "models/model.h"

namespace servokit {

/// Writes DIR/report.md, DIR/report.html and figures: the classification at the nominal point,
/// and for each axis (varied alone, the others nominal) the root locus, the real parts over the
/// parameter, the located stability, oscillation and realization thresholds within the axis'
/// range, and the closed-form characteristic polynomial where it applies.
void WriteModelReport(const std::string& directory,
                      const Model& model,
                      const std::vector<GridAxis>& axes);

}  // namespace servokit
