#pragma once
// The map of a parameter plane (issue #18, `servokit report MODEL --vary a=.. --vary b=..`):
// every grid point coloured by its class (realization, stability, oscillatory or not), and the
// threshold curves traced by continuation of the threshold finder (analysis/threshold_curves.h).
#include <filesystem>
#include <string>

#include "analysis/options.h"
#include "analysis/parameter_grid.h"
#include "models/model.h"
#include "reports/document.h"

namespace servokit {

/// The class of a point as the map names it: "non-ideal-orthogonal, asymptotically-stable,
/// oscillatory" (realization, stability, and "oscillatory" when the zero dynamics has a complex
/// pair, else "non-oscillatory"); "no solution" where the point has none.
std::string MapClassName(const Model& model,
                         Workspace& workspace,
                         const ClassificationOptions& options);

/// Classifies every point of the grid x × y (the other parameters nominal, each point with
/// `options`), traces the stability, oscillation and realization curves within the grid's
/// ranges, and writes into `directory`: the figure map_<x>_<y> (.png, .svg, .pdf; one discrete
/// colour per class present, named in the key, and the curves as lines labelled by event and
/// change) and map_<x>_<y>_curves.csv (one row per traced point: curve, event, from, to, via,
/// traced_along, the two parameters' columns as GridAxis::ColumnName, bracket_width in the
/// traced parameter's unit). Adds the section to `document`. Throws UsageError when an axis
/// has fewer than two distinct values.
void AddClassMap(Document& document,
                 const std::filesystem::path& directory,
                 const Model& model,
                 const GridAxis& x,
                 const GridAxis& y,
                 const ClassificationOptions& options = {});

}  // namespace servokit
