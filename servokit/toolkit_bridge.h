#pragma once
// Inside the library: what an api::Model holds, and the translations from the API's options to
// the toolkit's. Not installed (only servokit/servokit.h and base/errors.h are).
#include "analysis/parameter_grid.h"
#include "analysis/sweep.h"
#include "analysis/sweep_point.h"
#include "modeling/loaded_model.h"
#include "servokit/servokit.h"

namespace servokit::api {

struct Model::Loaded {
  LoadedModel model;
};

/// What `model` holds (the friend of api::Model), and the toolkit's model in it.
const Model::Loaded& Unwrap(const Model& model);
inline const LoadedModel& ToolkitModel(const Model& model) { return Unwrap(model).model; }

/// The multibody model behind `model`; throws UsageError naming `operation` for a linear model.
const servokit::Model& MultibodyModel(const Model& model, const char* operation);

/// The API's view of a multibody model's classification, with its three reports.
Analysis FromClassification(const servokit::Model& model,
                            const Classification& classification,
                            const ClassificationOptions& options);

/// The classification options of AnalyzeOptions (its tolerances and operating point).
ClassificationOptions ToClassificationOptions(const AnalyzeOptions& options);

/// The analysis options of a linear model; throws UsageError naming a bad eigen_solver or which,
/// or y0 / q_guess given (a linear model is analysed at q = 0, y = 0).
LinearAnalysisOptions ToLinearAnalysisOptions(const AnalyzeOptions& options);

/// The options of AnalyzePoint for `model`'s kind (the other kind's stay at their defaults).
AnalysisOptions ToAnalysisOptions(const Model& model, const AnalyzeOptions& options);

/// The toolkit's axis of a parameter of `model`; throws UsageError for an unknown parameter or
/// an axis without values.
GridAxis ToGridAxis(const Model& model, const SweepAxis& axis);
/// The grid over `axes`; throws UsageError also for a grid the sweep tables cannot hold (a
/// parameter varied twice, too many points, a column that clashes).
ParameterGrid ToGrid(const Model& model, const std::vector<SweepAxis>& axes);

/// The toolkit's sweep options of `options` for `model`'s kind.
servokit::SweepOptions ToSweepOptions(const Model& model, const SweepOptions& options);

}  // namespace servokit::api
