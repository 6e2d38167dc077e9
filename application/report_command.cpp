// servokit report paper --out DIR
// servokit report MODEL --vary p=a:b:n [--vary ...] [--set p=v]... [--y0 v]... [--q0 v]... --out
// DIR
#include <filesystem>
#include <memory>
#include <ostream>
#include <system_error>

#include "analysis/parameter_grid.h"
#include "application/commands.h"
#include "application/exit_codes.h"
#include "application/grid_arguments.h"
#include "models/errors.h"
#include "models/model.h"
#include "reports/model_report.h"
#include "reports/paper_report.h"

#ifndef SERVOKIT_MODELS_DIR
#error "SERVOKIT_MODELS_DIR must be defined by the build"
#endif

namespace servokit {
namespace {

struct ReportArguments {
  std::string subject;  // "paper" or a model file
  std::string out;
  std::vector<std::string> vary;
  std::vector<std::string> overrides;
  std::vector<std::string> y0;  // the operating point, as for `analyze`
  std::vector<std::string> q0;
  std::string models_directory;
};

// Where the shipped models are: --models, else $SERVOKIT_MODELS, else beside an installed
// executable (<prefix>/bin/servokit -> <prefix>/share/servokit/models, cmake/install.cmake),
// else the source tree's.
std::string ModelsDirectory(const ReportArguments& arguments) {
  if (!arguments.models_directory.empty()) return arguments.models_directory;
  if (const char* environment = std::getenv("SERVOKIT_MODELS")) return environment;
  std::error_code no_executable;
  const std::filesystem::path installed =
      std::filesystem::read_symlink("/proc/self/exe", no_executable).parent_path().parent_path() /
      "share" / "servokit" / "models";
  if (!no_executable && std::filesystem::is_directory(installed)) return installed.string();
  return SERVOKIT_MODELS_DIR;
}

int RunReport(const ReportArguments& arguments, std::ostream& out, std::ostream& err) {
  if (arguments.subject == "paper") {
    if (!arguments.vary.empty() || !arguments.overrides.empty() || !arguments.y0.empty() ||
        !arguments.q0.empty()) {
      throw UsageError(
          "report paper: --vary and --set are for `report MODEL` (and so are --y0, --q0)");
    }
    const std::string models = ModelsDirectory(arguments);
    if (!std::filesystem::exists(models + "/mass_on_car.yaml")) {
      throw UsageError("report paper: no mass_on_car.yaml in " + models +
                       " (give the shipped models with --models DIR)");
    }
    MakeOutputDirectory(arguments.out);
    WritePaperReport(arguments.out, models);
  } else {
    const Model model = LoadModel(arguments.subject, ParseOverrides(arguments.overrides));
    std::vector<GridAxis> axes;
    std::vector<std::string> warnings;
    for (const std::string& text : arguments.vary) {
      axes.push_back(ParseGridAxis({model.parameter_names(), model.parameter_display_units()}, text,
                                   &warnings));
    }
    for (const std::string& warning : warnings) err << "servokit: warning: " << warning << "\n";
    ClassificationOptions options;
    if (!arguments.y0.empty()) options.operating_point.y0 = ParseValues("--y0", arguments.y0);
    if (!arguments.q0.empty()) options.operating_point.q_guess = ParseValues("--q0", arguments.q0);
    MakeOutputDirectory(arguments.out);
    WriteModelReport(arguments.out, model, axes, options);
  }
  out << "report written to " << (std::filesystem::path(arguments.out) / "report.md").string()
      << " and report.html\n";
  return static_cast<int>(ExitCode::kSuccess);
}

}  // namespace

Command AddReportCommand(CLI::App& app) {
  auto arguments = std::make_shared<ReportArguments>();
  CLI::App* report = app.add_subcommand(
      "report", "Write a Markdown and HTML report with figures: the paper's, or any model's");
  report->footer(
      "Examples:\n  servokit report paper --out paper-report\n  servokit report "
      "models/rotational_arm.yaml --vary s=0:1:n=201 --out arm-report");
  report->add_option("SUBJECT", arguments->subject, "`paper`, or a model file (YAML)")->required();
  report->add_option("--out", arguments->out, "Directory for report.md, report.html, figures")
      ->required();
  report->add_option("--vary", arguments->vary,
                     "A parameter study: name=a:b:n, name=a:b:n=N, name=a:b:step=h or "
                     "name=v1,v2,.. (deg allowed)");
  report->add_option("--set", arguments->overrides,
                     "Override a parameter: name=value (value may end in deg)");
  report->add_option("--y0", arguments->y0,
                     "Output value at the operating point, one per output (default: h(0))");
  report->add_option("--q0", arguments->q0, "Newton's starting point for q (default: 0)");
  report->add_option("--models", arguments->models_directory,
                     "Directory of the shipped models (for `report paper`)");
  return {report, [arguments](std::ostream& out, std::ostream& err) {
            return RunReport(*arguments, out, err);
          }};
}

}  // namespace servokit
