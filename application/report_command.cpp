// servokit report paper --out DIR
// servokit report MODEL --vary p=a:b:n [--vary ...] [--set p=v]... [--y0 v]... [--q0 v]... --out
// DIR
// servokit report --from SWEEP_DIR --out DIR
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <ostream>
#include <string>
#include <system_error>
#include <vector>

#include "application/commands.h"
#include "application/exit_codes.h"
#include "servokit/servokit.h"

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
  std::string from;  // a finished sweep's directory
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
  if (!arguments.from.empty()) {
    if (!arguments.subject.empty() || !arguments.vary.empty() || !arguments.overrides.empty() ||
        !arguments.y0.empty() || !arguments.q0.empty()) {
      throw UsageError(
          "report --from: the sweep gives the model, grid and options; no SUBJECT, "
          "--vary, --set, --y0 or --q0");
    }
    // Read before --out is made: a bad sweep leaves nothing behind.
    const api::FinishedSweep sweep = api::FinishedSweep::Read(arguments.from, "--from");
    MakeOutputDirectory(arguments.out);
    api::WriteSweepReport(arguments.out, sweep);
  } else if (arguments.subject.empty()) {
    throw UsageError("report: give `paper`, a model file, or --from a finished sweep's directory");
  } else if (arguments.subject == "paper") {
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
    api::WritePaperReport(arguments.out, models);
  } else {
    const api::Model model =
        api::Model::MultibodyFromFile(arguments.subject, ParseParameterValues(arguments.overrides));
    std::vector<api::SweepAxis> axes;
    std::vector<std::string> warnings;
    for (const std::string& text : arguments.vary) {
      axes.push_back(api::ParseSweepAxis(model, text, "--vary", &warnings));
    }
    for (const std::string& warning : warnings) err << "servokit: warning: " << warning << "\n";
    api::AnalyzeOptions options;
    if (!arguments.y0.empty()) options.y0 = ParseValues("--y0", arguments.y0);
    if (!arguments.q0.empty()) options.q_guess = ParseValues("--q0", arguments.q0);
    MakeOutputDirectory(arguments.out);
    api::WriteModelReport(arguments.out, model, axes, options);
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
      "models/rotational_arm.yaml --vary s=0:1:n=201 --out arm-report\n  servokit report --from "
      "sweep-dir --out sweep-report");
  report->add_option("SUBJECT", arguments->subject, "`paper`, or a model file (YAML)");
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
  report->add_option("--from", arguments->from,
                     "A finished sweep's directory (servokit sweep --out, CSV): report its grid");
  report->add_option("--models", arguments->models_directory,
                     "Directory of the shipped models (for `report paper`)");
  return {report, [arguments](std::ostream& out, std::ostream& err) {
            return RunReport(*arguments, out, err);
          }};
}

}  // namespace servokit
