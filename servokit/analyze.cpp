// api::Analyze: the classification of either kind of model at its operating point, with the
// reports `servokit analyze` prints.
#include "analysis/classification.h"
#include "analysis/linear_analysis.h"
#include "analysis/linear_zero_dynamics.h"
#include "analysis/sweep_point.h"
#include "base/option_check.h"
#include "reports/classification_report.h"
#include "servokit/toolkit_bridge.h"

namespace servokit::api {
namespace {

template <typename ZeroDynamicsResult>
ZeroDynamics ToZeroDynamics(const ZeroDynamicsResult& result) {
  ZeroDynamics zero_dynamics;
  zero_dynamics.eigenvalues = result.eigenvalues;
  zero_dynamics.stability = result.stability;
  zero_dynamics.minimum_phase = result.minimum_phase;
  zero_dynamics.stability_note = result.stability_note;
  for (const Mode& mode : result.modes) {
    zero_dynamics.modes.push_back({mode.frequency_hz, mode.damping_ratio});
  }
  return zero_dynamics;
}

}  // namespace

Analysis FromClassification(const servokit::Model& model,
                            const Classification& classification,
                            const ClassificationOptions& options) {
  Analysis analysis;
  analysis.q = classification.operating_point.q;
  analysis.u = classification.operating_point.u;
  analysis.y = classification.operating_point.y;
  analysis.multipliers = classification.operating_point.multipliers;
  analysis.curve_direction = classification.operating_point.curve_direction;
  analysis.P = classification.decoupling.decoupling_matrix;
  analysis.P_rank = int(classification.decoupling.rank);
  analysis.realization = classification.decoupling.realization;
  analysis.relative_degree = classification.structure.relative_degree;
  analysis.differentiation_index = classification.structure.differentiation_index;
  analysis.projected_index = classification.structure.projected_index;
  analysis.internal_dynamics_order = classification.structure.internal_dynamics_order;
  analysis.flat = classification.flat;
  analysis.zero_dynamics = ToZeroDynamics(classification.zero_dynamics);
  analysis.recommended_solver = classification.recommended_solver;
  analysis.text = FormatClassification(model, classification, options, ReportFormat::kText);
  analysis.json = FormatClassification(model, classification, options, ReportFormat::kJson);
  analysis.markdown = FormatClassification(model, classification, options, ReportFormat::kMarkdown);
  return analysis;
}

namespace {

Analysis FromLinearAnalysis(const LinearModel& model,
                            const LinearAnalysis& result,
                            const LinearAnalysisOptions& options) {
  Analysis analysis;
  analysis.q = Eigen::VectorXd::Zero(Eigen::Index(model.dof()));
  analysis.u = Eigen::VectorXd::Zero(Eigen::Index(model.num_inputs()));
  analysis.y = Eigen::VectorXd::Zero(Eigen::Index(model.num_outputs()));
  analysis.P = result.decoupling.decoupling_matrix;
  analysis.P_rank = int(result.decoupling.rank);
  analysis.realization = result.decoupling.realization;
  if (result.relative_degrees.determined) {
    analysis.relative_degree = result.relative_degrees.relative_degree;
    analysis.differentiation_index = result.differentiation_index;
    analysis.projected_index = result.projected_index;
  } else {
    analysis.differentiation_index = -1;
    analysis.projected_index = -1;
  }
  analysis.internal_dynamics_order = int(result.internal_dynamics_order);
  analysis.flat = result.flat;
  analysis.zero_dynamics = ToZeroDynamics(result.zero_dynamics);
  analysis.recommended_solver = result.recommended_solver;
  analysis.text = FormatLinearAnalysis(model, result, options, ReportFormat::kText);
  analysis.json = FormatLinearAnalysis(model, result, options, ReportFormat::kJson);
  analysis.markdown = FormatLinearAnalysis(model, result, options, ReportFormat::kMarkdown);
  return analysis;
}

}  // namespace

const AnalyzeOptions& DefaultAnalyzeOptions() {
  // Built once; every field given, so that AnalyzeOptions' own defaults (which read this) are
  // not used here.
  static const ClassificationOptions classification;
  static const LinearZeroDynamicsOptions linear;
  static const AnalyzeOptions defaults{
      .y0 = std::nullopt,
      .q_guess = std::nullopt,
      .rank_tolerance = classification.rank_tolerance,
      .imaginary_axis_tolerance = classification.imaginary_axis_tolerance,
      .nonlinear_structure = true,  // the API's own: what `analyze` prints
      .eigen_solver = linear.solver,
      .eigenvalues = linear.arpack.eigenvalues,
      .shift = linear.shift,
      .which = linear.target};
  return defaults;
}

ClassificationOptions ToClassificationOptions(const AnalyzeOptions& options) {
  ClassificationOptions classification;
  classification.rank_tolerance = options.rank_tolerance;
  classification.imaginary_axis_tolerance = options.imaginary_axis_tolerance;
  classification.operating_point.y0 = options.y0;
  classification.operating_point.q_guess = options.q_guess;
  return classification;
}

LinearAnalysisOptions ToLinearAnalysisOptions(const AnalyzeOptions& options) {
  constexpr const char* kOwner = "AnalyzeOptions";
  constexpr const char* kAtZero = "a linear model is analysed at q = 0, y = 0; must be unset";
  RequireOption(!options.y0, kOwner, "y0", options.y0.value_or(Eigen::VectorXd()), kAtZero);
  RequireOption(!options.q_guess, kOwner, "q_guess", options.q_guess.value_or(Eigen::VectorXd()),
                kAtZero);
  LinearAnalysisOptions linear;
  linear.rank_tolerance = options.rank_tolerance;
  linear.zero_dynamics.imaginary_axis_tolerance = options.imaginary_axis_tolerance;
  linear.zero_dynamics.arpack.eigenvalues = options.eigenvalues;
  linear.zero_dynamics.shift = options.shift;
  linear.zero_dynamics.solver = options.eigen_solver;
  linear.zero_dynamics.target = options.which;
  linear.Validate();
  return linear;
}

AnalysisOptions ToAnalysisOptions(const Model& model, const AnalyzeOptions& options) {
  AnalysisOptions analysis;
  if (model.kind() == ModelKind::kLinear) {
    analysis.linear = ToLinearAnalysisOptions(options);
  } else {
    analysis.classification = ToClassificationOptions(options);
  }
  return analysis;
}

StateSpaceModel LinearizeAt(const Model& model, const AnalyzeOptions& options) {
  const servokit::Model& multibody = MultibodyModel(model, "LinearizeAt");
  Workspace workspace(multibody);
  const Classification classification =
      Classify(multibody, workspace, ToClassificationOptions(options));
  const Linearization& linear = classification.linearization;
  StateSpace unscaled;
  ToStateSpace(linear, 1.0, unscaled);  // time scale 1: x = (dq, dq') in SI
  StateSpaceModel state_space;
  state_space.A = std::move(unscaled.state_matrix);
  state_space.B = std::move(unscaled.input_matrix);
  state_space.C = std::move(unscaled.output_matrix);
  state_space.D = Eigen::MatrixXd::Zero(state_space.C.rows(), state_space.B.cols());
  state_space.tangent_basis = linear.tangent_basis;
  return state_space;
}

Analysis Analyze(const Model& model, const AnalyzeOptions& options) {
  const LoadedModel& loaded = ToolkitModel(model);
  const AnalysisOptions analysis_options = ToAnalysisOptions(model, options);
  PointWorkspace workspace(loaded);
  ModelAnalysis analysis = AnalyzePoint(loaded, workspace, analysis_options);
  if (auto* classification = std::get_if<Classification>(&analysis)) {
    if (options.nonlinear_structure) DeriveNonlinearStructure(*loaded.multibody(), *classification);
    return FromClassification(*loaded.multibody(), *classification,
                              analysis_options.classification);
  }
  return FromLinearAnalysis(*loaded.linear(), std::get<LinearAnalysis>(analysis),
                            analysis_options.linear);
}

}  // namespace servokit::api
