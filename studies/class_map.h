#pragma once
// The map of a parameter plane (issue #18, `servokit report MODEL --vary a=.. --vary b=..`):
// every grid point coloured by its class (realization, stability, oscillatory or not), and the
// threshold curves traced by continuation of the threshold finder (analysis/threshold_curves.h).
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/options.h"
#include "analysis/parameter_grid.h"
#include "modeling/model.h"
#include "reports/document.h"

namespace servokit {

/// The class of a point as the map names it: "non-ideal-orthogonal, asymptotically-stable,
/// oscillatory" (realization, stability, and "oscillatory" when the zero dynamics has a complex
/// pair, else "non-oscillatory"); "no solution" where the point has none.
std::string MapClassName(const Model& model,
                         Workspace& workspace,
                         const ClassificationOptions& options);
/// The same name from a class's parts, as the sweep tables write them (a finished sweep's
/// points.csv: realization, stability; oscillatory: the point's eigenvalues have a complex pair).
std::string MapClassName(std::string_view realization,
                         std::string_view stability,
                         bool oscillatory);

/// Classifies every point of the grid x × y (the other parameters nominal, each point with
/// `options`), traces the stability, oscillation and realization curves within the grid's
/// ranges, and writes into `directory`: the figure map_<x>_<y> (.png, .svg, .pdf; one discrete
/// colour per class present, named in the key, and the curves as lines labelled by event and
/// change) and map_<x>_<y>_curves.csv (one row per traced point: curve, event, from, to, via,
/// traced_along, the two parameters' columns as GridAxis::ColumnName, bracket_width in the
/// traced parameter's unit). Adds the section to `document`. Throws UsageError when an axis
/// has fewer than two distinct values. `stored_classes`, when given, are the classes of the grid's
/// points (MapClassName; x varying slowest, as a sweep over x then y numbers them), read from a
/// finished sweep (`servokit report --from`): the grid is then not classified again.
void AddClassMap(Document& document,
                 const std::filesystem::path& directory,
                 const Model& model,
                 const GridAxis& x,
                 const GridAxis& y,
                 const ClassificationOptions& options = {},
                 const std::vector<std::string>* stored_classes = nullptr);

}  // namespace servokit
