// servokit analyze MODEL [--set p=v]... [--y0 v]... [--q0 v]... [--format text|json|md]
//   [--eigenvalues K] [--shift S] [--eigen-solver auto|dense|arpack] [--which nearest|rightmost]
// A nonlinear model (YAML with expressions) is classified at its operating point; a large linear
// model (`kind: linear`, modeling/linear_model.h) at q = 0, u = 0 with sparse matrices.
#include <memory>
#include <optional>
#include <ostream>

#include "application/commands.h"
#include "application/exit_codes.h"
#include "servokit/servokit.h"

namespace servokit {
namespace {

struct AnalyzeArguments {
  std::string model_path;
  std::vector<std::string> overrides;  // "name=value"
  std::vector<std::string> y0;         // each may hold several values separated by commas
  std::vector<std::string> q0;
  std::string format = "text";
  api::AnalyzeOptions options;
  LinearModelArguments linear;  // linear models only
};

int RunAnalyze(const AnalyzeArguments& arguments, const CLI::App& analyze, std::ostream& out) {
  const std::optional<ReportFormat> format = ReportFormatFromString(arguments.format);
  if (!format) {
    throw UsageError("--format " + arguments.format + ": expected text, json or md");
  }
  const api::Model model =
      api::Model::FromFile(arguments.model_path, ParseParameterValues(arguments.overrides));
  api::AnalyzeOptions options = arguments.options;
  if (model.kind() == ModelKind::kLinear) {
    ApplyLinearModelArguments(arguments.linear, !arguments.y0.empty(), !arguments.q0.empty(),
                              options);
  } else {
    RefuseLinearModelOptions(analyze);
    if (!arguments.y0.empty()) options.y0 = ParseValues("--y0", arguments.y0);
    if (!arguments.q0.empty()) options.q_guess = ParseValues("--q0", arguments.q0);
  }
  const api::Analysis analysis = api::Analyze(model, options);
  switch (*format) {
    case ReportFormat::kText:
      out << analysis.text;
      break;
    case ReportFormat::kJson:
      out << analysis.json;
      break;
    case ReportFormat::kMarkdown:
      out << analysis.markdown;
      break;
  }
  return static_cast<int>(ExitCode::kSuccess);
}

}  // namespace

Command AddAnalyzeCommand(CLI::App& app) {
  auto arguments = std::make_shared<AnalyzeArguments>();
  CLI::App* analyze =
      app.add_subcommand("analyze", "Classify the servo-constraint problem at an operating point");
  analyze->alias("analyse");  // British spelling, as servokit's own description has it
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
                   "Damping ratio |Re lambda|/|lambda| at or below which an eigenvalue is on the "
                   "imaginary axis")
      ->capture_default_str();
  AddLinearModelOptions(*analyze, arguments->linear, "zero-dynamics eigenvalues");
  return {analyze, [arguments, analyze](std::ostream& out, std::ostream&) {
            return RunAnalyze(*arguments, *analyze, out);
          }};
}

}  // namespace servokit
