#pragma once
// `servokit report MODEL --vary ...`: the paper report's kind of study for any model.
#include <string>
#include <vector>

#include "analysis/options.h"
#include "analysis/parameter_grid.h"
#include "analysis/sweep_point.h"
#include "modeling/model.h"

namespace servokit {

/// Writes DIR/report.md, DIR/report.html and figures: the classification at the nominal point,
/// and for each axis (varied alone, the others nominal) the root locus, the real parts over the
/// parameter, the located stability, oscillation and realization thresholds within the axis'
/// range, and the closed-form characteristic polynomial where it applies (at the default
/// operating point only: it is derived at q = 0, u = 0). Every classification uses `options`
/// (the operating point of --y0 and --q0, the tolerances). With exactly two axes the report
/// opens with the map of their plane (studies/class_map.h): each grid point coloured by class,
/// and the threshold curves traced across it.
/// A finished sweep over `axes` (`servokit report --from DIR`, read from its points.csv and
/// eigenvalues.csv), in the grid's order (the first axis varying slowest).
struct StoredSweep {
  // Each point's solution (ok, error) and eigenvalues; the class columns are not needed.
  std::vector<SweepPoint> points;
  // Each point's class as the map names it (MapClassName).
  std::vector<std::string> classes;
};

/// With `stored`, the report draws what the sweep computed instead of computing it again: for
/// one axis, the root locus and real parts from its points (the thresholds are still located
/// on `model`); for two, the map's classes (the curves are traced on `model`, and each axis'
/// study, through the nominal point, is computed as without it).
void WriteModelReport(const std::string& directory,
                      const Model& model,
                      const std::vector<GridAxis>& axes,
                      const ClassificationOptions& options = {},
                      const StoredSweep* stored = nullptr);

}  // namespace servokit
