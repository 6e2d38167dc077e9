#pragma once
// What a parameter sweep records at each point (DESIGN.md: points.csv and eigenvalues.csv).
// Computed with the parameters in workspace.parameters; never throws for a point without a
// solution: the failure is recorded in the point and the sweep carries on (STYLE.md, errors).
#include <complex>
#include <string>
#include <vector>

#include "analysis/options.h"
#include "analysis/types.h"
#include "models/model.h"

namespace servokit {

struct SweepPoint {
  bool ok = false;
  std::string error;  // one line, when !ok (NoSolution's message)
  Realization realization = Realization::kTangential;
  long rank = 0;                     // rank of P
  std::vector<int> relative_degree;  // one per output
  int differentiation_index = 0;
  int internal_dynamics_order = 0;
  Stability stability = Stability::kNone;
  // Largest real part of the zero-dynamics eigenvalues; NaN when there are none (flat), which
  // the CSV writes as an empty field.
  double max_real_part = 0.0;
  std::vector<std::complex<double>> eigenvalues;  // sorted as SortEigenvalues
};

/// Which way a sweep point is computed. kFast (the default) takes the compiled zero-dynamics
/// polynomial where it applies (one output, small model, operating point at rest at q = 0)
/// and the general path elsewhere; kGeneral always classifies in full (Classify). The two
/// agree on every class and on the eigenvalues to round-off (tests/analysis/sweep_point_test.cpp),
/// except inside the tolerance band of a singular point, where the fast path defers.
enum class SweepPath { kFast, kGeneral };

/// Classifies at workspace.parameters. Options are validated by the caller once per sweep;
/// the QZ cross-check is not run (it is for single analyses and tests).
SweepPoint AnalyzeSweepPoint(const Model& model,
                             Workspace& workspace,
                             const ClassificationOptions& options,
                             SweepPath path = SweepPath::kFast);

}  // namespace servokit
