#pragma once
// The analysis of one parameter point of a model of either kind (AnalyzePoint, for `servokit
// analyze`) and what a parameter sweep records of it (docs/sweep.md, "The files": points.csv
// and eigenvalues.csv). The multibody numerics (dense, GiNaC-compiled, Newton) and the linear ones
// (sparse LU, ARPACK) are different algorithms; this is the one place that picks between them.
// A sweep point is computed with the parameters in the workspace and never throws for a point
// without a solution: the failure is recorded in the point and the sweep carries on (style:
// errors, docs/development.md).
#include <Eigen/Dense>
#include <complex>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "analysis/classification.h"
#include "analysis/linear_analysis.h"
#include "analysis/linear_zero_dynamics.h"
#include "analysis/options.h"
#include "base/vocabulary.h"
#include "modeling/loaded_model.h"
#include "modeling/model.h"

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
/// except inside the tolerance band of a singular point, where the fast path defers. The fast
/// path runs analyze's checks of the linearization (FindLinearizationProblem) and answers only
/// where its numbers are well scaled, so that a point fails exactly where `analyze` fails, with
/// analyze's message (issue #29).
enum class SweepPath { kFast, kGeneral };

/// True when the fast path tries the closed-form zero-dynamics polynomial at every point: the
/// model has one within its budget (Model::has_zero_dynamics_polynomial, which derives it), one
/// output, and the equilibrium is the one at q = 0 (no y0, no q0). Points it cannot decide, and
/// every point otherwise, take the eigenvalues of the linearized zero dynamics.
bool SweepTriesPolynomial(const Model& model, const ClassificationOptions& options);

/// Classifies at workspace.parameters. Options are validated by the caller once per sweep;
/// the QZ cross-check is not run (it is for single analyses and tests).
SweepPoint AnalyzeSweepPoint(const Model& model,
                             Workspace& workspace,
                             const ClassificationOptions& options,
                             SweepPath path = SweepPath::kFast);
/// The same into `point`, reusing the memory its vectors and strings hold: a sweep analyses
/// millions of points into the same few thousand SweepPoints, and the fast path then allocates
/// nothing.
void AnalyzeSweepPointInto(const Model& model,
                           Workspace& workspace,
                           const ClassificationOptions& options,
                           SweepPath path,
                           SweepPoint& point);

/// How a point is analysed: the options of each kind's analysis; the model's kind picks one.
struct AnalysisOptions {
  ClassificationOptions classification;  // a multibody model (Classify)
  LinearAnalysisOptions linear;          // a linear model (AnalyzeLinearSystem)
};

/// The analysis of one point: a multibody model's Classification or a linear model's
/// LinearAnalysis.
using ModelAnalysis = std::variant<Classification, LinearAnalysis>;

/// What one thread needs to analyse points of one model, reused from point to point: the
/// point's parameter values and the buffers of the model's kind (a Workspace; or, for a linear
/// model, the factorisations of the Rosenbrock matrix, whose sparsity pattern is the same at
/// every point and so is analysed once).
class PointWorkspace {
 public:
  explicit PointWorkspace(const LoadedModel& model);

  /// The parameter values of the point to analyse, in the order of the model's
  /// parameter_names() (SI); they start as the model's own.
  Eigen::VectorXd& parameters();
  /// The multibody model's Workspace (its `parameters` are parameters()), or nullptr.
  Workspace* multibody() { return multibody_ ? &*multibody_ : nullptr; }
  /// The linear model's workspace, or nullptr.
  LinearZeroDynamicsWorkspace* linear() { return linear_.get(); }
  /// Sparsity-pattern analyses (symbolic factorisations) done so far; 0 for a multibody model.
  int pattern_analyses() const { return linear_ ? linear_->pattern_analyses() : 0; }

 private:
  std::optional<Workspace> multibody_;
  std::unique_ptr<LinearZeroDynamicsWorkspace> linear_;
  Eigen::VectorXd linear_parameters_;
};

/// Analyses `model` at workspace.parameters(), which `workspace` (built for `model`) holds:
/// Classify (options.classification) for a multibody model; for a linear one, AnalyzeLinearSystem
/// (options.linear) on its matrices assembled there. ARPACK is not reentrant (Fortran SAVE
/// state): points on the ARPACK route are analysed one at a time in a process (a lock). Throws
/// UsageError for bad options, NoSolution for a point without an answer of the kind asked, and
/// ModelError for a linear model's factor that is not finite at these parameter values.
ModelAnalysis AnalyzePoint(const LoadedModel& model,
                           PointWorkspace& workspace,
                           const AnalysisOptions& options);

/// A sweep's point of `model` at workspace.parameters(): for a multibody model AnalyzeSweepPoint
/// above; for a linear one AnalyzePoint, whose zeros (all, or the k nearest the shift with
/// ARPACK) are the eigenvalues and whose relative degrees, when not determined numerically, give
/// an internal dynamics order of -1 (three empty CSV columns). A point without a solution
/// (NoSolution; for a linear model also a factor not finite there) is recorded (ok = false, the
/// one-line message in `error`). Options are validated by the caller once per sweep.
SweepPoint AnalyzeSweepPoint(const LoadedModel& model,
                             PointWorkspace& workspace,
                             const AnalysisOptions& options);
/// The same into `point`, reusing its memory (AnalyzeSweepPointInto above).
void AnalyzeSweepPointInto(const LoadedModel& model,
                           PointWorkspace& workspace,
                           const AnalysisOptions& options,
                           SweepPoint& point);

}  // namespace servokit
