#include "analysis/sweep_point.h"

#include <limits>

#include "analysis/classification.h"
#include "models/errors.h"

namespace servokit {

SweepPoint AnalyzeSweepPoint(const Model& model,
                             Workspace& workspace,
                             const ClassificationOptions& options) {
  ClassificationOptions point_options = options;
  point_options.cross_check = false;
  SweepPoint point;
  try {
    const Classification c = Classify(model, workspace, point_options);
    point.ok = true;
    point.realization = c.decoupling.realization;
    point.rank = static_cast<long>(c.decoupling.rank);
    point.relative_degree = c.structure.relative_degree;
    point.differentiation_index = c.structure.differentiation_index;
    point.internal_dynamics_order = c.structure.internal_dynamics_order;
    point.stability = c.zero_dynamics.stability;
    point.eigenvalues = c.zero_dynamics.eigenvalues;
    point.max_real_part = point.eigenvalues.empty() ? std::numeric_limits<double>::quiet_NaN()
                                                    : point.eigenvalues.front().real();
  } catch (const NoSolution& error) {
    point.ok = false;
    point.error = error.what();
  }
  return point;
}

}  // namespace servokit
