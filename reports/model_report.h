#pragma once
// `servokit report MODEL --vary ...`: the paper report's kind of study for any model.
#include <string>
#include <vector>

#include "analysis/options.h"
#include "analysis/parameter_grid.h"
#include "models/model.h"

namespace servokit {

/// Writes DIR/report.md, DIR/report.html and figures: the classification at the nominal point,
/// and for each axis (varied alone, the others nominal) the root locus, the real parts over the
/// parameter, the located stability, oscillation and realization thresholds within the axis'
/// range, and the closed-form characteristic polynomial where it applies (at the default
/// operating point only: it is derived at q = 0, u = 0). Every classification uses `options`
/// (the operating point of --y0 and --q0, the tolerances). With exactly two axes the report
/// opens with the map of their plane (reports/class_map.h): each grid point coloured by class,
/// and the threshold curves traced across it.
void WriteModelReport(const std::string& directory,
                      const Model& model,
                      const std::vector<GridAxis>& axes,
                      const ClassificationOptions& options = {});

}  // namespace servokit
