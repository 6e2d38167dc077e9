// servokit analyze MODEL [--set p=v]... [--y0 v]... [--q0 v]... [--format text|json|md]
//   [--eigenvalues K] [--shift S] [--eigen-solver auto|dense|arpack] [--which nearest|rightmost]
// A nonlinear model (YAML with expressions) is classified at its operating point; a large linear
// model (`kind: linear`, models/linear_model.h) at q = 0, u = 0 with sparse matrices.
#include <memory>
#include <ostream>

#include "analysis/classification.h"
#include "analysis/linear_analysis.h"
#include "models/errors.h"
#include "models/linear_model.h"
#include "reports/classification_report.h"
#include "reports/commands.h"
#include "reports/exit_codes.h"

namespace servokit {
namespace {

struct AnalyzeArguments {
  std::string model_path;
  std::vector<std::string> overrides;  // "name=value"
  std::vector<std::string> y0;         // each may hold several values separated by commas
  std::vector<std::string> q0;
  std::string format = "text";
  ClassificationOptions options;
  // Linear models only.
  int eigenvalues = ArpackOptions{}.eigenvalues;
  double shift = 0.0;
  std::string eigen_solver = "auto";
  std::string which = "nearest";
};

int RunLinearAnalyze(const AnalyzeArguments& arguments, ReportFormat format, std::ostream& out) {
  if (!arguments.y0.empty() || !arguments.q0.empty()) {
    throw UsageError(std::string(arguments.y0.empty() ? "--q0" : "--y0") +
                     ": a linear model is analysed at q = 0, y = 0; the option does not apply");
  }
  LinearAnalysisOptions options;
  options.rank_tolerance = arguments.options.rank_tolerance;
  options.zero_dynamics.imaginary_axis_tolerance = arguments.options.imaginary_axis_tolerance;
  options.zero_dynamics.arpack.eigenvalues = arguments.eigenvalues;
  options.zero_dynamics.shift = arguments.shift;
  const auto solver = LinearEigenSolverFromString(arguments.eigen_solver);
  if (!solver) {
    throw UsageError("--eigen-solver " + arguments.eigen_solver +
                     ": expected auto, dense or arpack");
  }
  options.zero_dynamics.solver = *solver;
  const auto target = EigenvalueTargetFromString(arguments.which);
  if (!target) throw UsageError("--which " + arguments.which + ": expected nearest or rightmost");
  options.zero_dynamics.target = *target;
  options.Validate();

  const LinearModel model =
      LoadLinearModel(arguments.model_path, ParseOverrides(arguments.overrides));
  const LinearSystem system = AssembleLinearSystem(model, model.parameters());
  LinearZeroDynamicsWorkspace workspace;
  const LinearAnalysis analysis = AnalyzeLinearSystem(system, workspace, options);
  out << FormatLinearAnalysis(model, analysis, options, format);
  return static_cast<int>(ExitCode::kSuccess);
}

int RunAnalyze(const AnalyzeArguments& arguments, std::ostream& out) {
  const std::optional<ReportFormat> format = ReportFormatFromString(arguments.format);
  if (!format) {
    throw UsageError("--format " + arguments.format + ": expected text, json or md");
  }
  if (IsLinearModelFile(arguments.model_path)) return RunLinearAnalyze(arguments, *format, out);
  const Model model = LoadModel(arguments.model_path, ParseOverrides(arguments.overrides));
  ClassificationOptions options = arguments.options;
  if (!arguments.y0.empty()) options.operating_point.y0 = ParseValues("--y0", arguments.y0);
  if (!arguments.q0.empty()) options.operating_point.q_guess = ParseValues("--q0", arguments.q0);
  Workspace workspace(model);
  const Classification classification = Classify(model, workspace, options);
  out << FormatClassification(model, classification, options, *format);
  return static_cast<int>(ExitCode::kSuccess);
}

}  // namespace

Command AddAnalyzeCommand(CLI::App& app) {
  auto arguments = std::make_shared<AnalyzeArguments>();
  CLI::App* analyze =
      app.add_subcommand("analyze", "Classify the servo-constraint problem at an operating point");
  analyze->footer(
      "Example:\n  servokit analyze models/mass_on_car.yaml --set alpha=\"90 deg\" --set d=0 "
      "--format json\n"
      "  servokit generate chain --masses 100000 --out DIR && servokit analyze "
      "DIR/chain_100000.yaml "
      "--eigenvalues 10 --which nearest");
  analyze
      ->add_option("MODEL", arguments->model_path,
                   "Model file (YAML; `kind: linear` for a large sparse linear model)")
      ->required();
  analyze->add_option("--set", arguments->overrides,
                      "Override a parameter: name=value (value may end in deg)");
  analyze->add_option("--y0", arguments->y0,
                      "Output value at the operating point, one per output (default: h(0))");
  analyze->add_option("--q0", arguments->q0, "Newton's starting point for q (default: 0)");
  analyze->add_option("--format", arguments->format, "Output format: text, json or md")
      ->capture_default_str();
  analyze
      ->add_option("--rank-tolerance", arguments->options.rank_tolerance,
                   "Relative tolerance of rank decisions (P, Markov parameters)")
      ->capture_default_str();
  analyze
      ->add_option("--axis-tolerance", arguments->options.imaginary_axis_tolerance,
                   "Relative distance to the imaginary axis counted as on it")
      ->capture_default_str();
  analyze
      ->add_option("--eigenvalues", arguments->eigenvalues,
                   "Linear models: how many zero-dynamics eigenvalues ARPACK computes (the dense "
                   "route computes all)")
      ->capture_default_str();
  analyze
      ->add_option("--shift", arguments->shift,
                   "Linear models: real shift sigma (1/s) of the shift-invert (A - sigma E)^-1 E; "
                   "must not be a zero")
      ->capture_default_str();
  analyze
      ->add_option("--eigen-solver", arguments->eigen_solver,
                   "Linear models: auto (dense up to 200 coordinates, ARPACK above), dense (every "
                   "zero, O(n^3)) or arpack (K zeros, shift-invert)")
      ->capture_default_str();
  analyze
      ->add_option("--which", arguments->which,
                   "Linear models, ARPACK: nearest (the K zeros nearest the shift: the slowest "
                   "modes) or rightmost (largest Re 1/(lambda - shift): any zero right of the "
                   "shift ranks first, which decides stability at shift 0)")
      ->capture_default_str();
  return {analyze,
          [arguments](std::ostream& out, std::ostream&) { return RunAnalyze(*arguments, out); }};
}

}  // namespace servokit
