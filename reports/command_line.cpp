#include "reports/command_line.h"

#include <CLI/CLI.hpp>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/classification.h"
#include "models/errors.h"
#include "models/model.h"
#include "models/units.h"
#include "reports/classification_report.h"
#include "reports/exit_codes.h"

#ifndef SERVOKIT_VERSION
#error "SERVOKIT_VERSION must be defined by the build"
#endif

namespace servokit {
namespace {

struct AnalyzeArguments {
  std::string model_path;
  std::vector<std::string> overrides;  // "name=value"
  std::vector<std::string> y0;         // each may hold several values separated by commas
  std::vector<std::string> q0;
  std::string format = "text";
  ClassificationOptions options;
};

std::vector<ParameterOverride> ParseOverrides(const std::vector<std::string>& texts) {
  std::vector<ParameterOverride> overrides;
  for (const std::string& text : texts) {
    const auto equals = text.find('=');
    if (equals == std::string::npos || equals == 0) {
      throw UsageError("--set " + text + ": expected name=value (e.g. --set alpha=\"5 deg\")");
    }
    overrides.push_back({text.substr(0, equals), text.substr(equals + 1)});
  }
  return overrides;
}

// "--y0 1,2 --y0 3" -> [1, 2, 3]; each value may end in "deg".
Eigen::VectorXd ParseValues(const std::string& option, const std::vector<std::string>& texts) {
  std::vector<double> values;
  for (const std::string& text : texts) {
    std::stringstream stream(text);
    std::string item;
    while (std::getline(stream, item, ',')) {
      const std::optional<double> value = ParseQuantity(item);
      if (!value) {
        throw UsageError(option + " " + text + ": '" + item +
                         "' is not a number (use e.g. 0.5 or \"5 deg\")");
      }
      values.push_back(*value);
    }
  }
  return Eigen::Map<const Eigen::VectorXd>(values.data(), Eigen::Index(values.size()));
}

int RunAnalyze(const AnalyzeArguments& arguments, std::ostream& out) {
  const std::optional<ReportFormat> format = ReportFormatFromString(arguments.format);
  if (!format) {
    throw UsageError("--format " + arguments.format + ": expected text, json or md");
  }
  const Model model = LoadModel(arguments.model_path, ParseOverrides(arguments.overrides));
  ClassificationOptions options = arguments.options;
  if (!arguments.y0.empty()) options.operating_point.y0 = ParseValues("--y0", arguments.y0);
  if (!arguments.q0.empty()) options.operating_point.q_guess = ParseValues("--q0", arguments.q0);
  Workspace workspace(model);
  const Classification classification = Classify(model, workspace, options);
  out << FormatClassification(model, classification, options, *format);
  return static_cast<int>(ExitCode::kSuccess);
}

void AddAnalyzeCommand(CLI::App& app, AnalyzeArguments& arguments) {
  CLI::App* analyze =
      app.add_subcommand("analyze", "Classify the servo-constraint problem at an operating point");
  analyze->footer(
      "Example:\n  servokit analyze models/mass_on_car.yaml --set alpha=\"90 deg\" --set d=0 "
      "--format json");
  analyze->add_option("MODEL", arguments.model_path, "Model file (YAML)")->required();
  analyze->add_option("--set", arguments.overrides,
                      "Override a parameter: name=value (value may end in deg)");
  analyze->add_option("--y0", arguments.y0,
                      "Output value at the operating point, one per output (default: h(0))");
  analyze->add_option("--q0", arguments.q0, "Newton's starting point for q (default: 0)");
  analyze->add_option("--format", arguments.format, "Output format: text, json or md")
      ->capture_default_str();
  analyze
      ->add_option("--rank-tolerance", arguments.options.rank_tolerance,
                   "Relative tolerance of rank decisions (P, Markov parameters)")
      ->capture_default_str();
  analyze
      ->add_option("--axis-tolerance", arguments.options.imaginary_axis_tolerance,
                   "Relative distance to the imaginary axis counted as on it")
      ->capture_default_str();
}

}  // namespace

int RunCommandLine(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  CLI::App app(
      "servokit: analyse and solve servo-constraint problems of underactuated "
      "multibody systems");
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("servokit ") + SERVOKIT_VERSION);
  AnalyzeArguments analyze_arguments;
  AddAnalyzeCommand(app, analyze_arguments);
  try {
    try {
      app.parse(argc, argv);
    } catch (const CLI::CallForHelp&) {
      out << app.help();
      return 0;
    } catch (const CLI::CallForAllHelp&) {
      out << app.help("", CLI::AppFormatMode::All);
      return 0;
    } catch (const CLI::CallForVersion&) {
      out << app.version() << "\n";
      return 0;
    } catch (const CLI::ParseError& error) {
      throw UsageError(error.what());
    }
    if (app.got_subcommand("analyze")) return RunAnalyze(analyze_arguments, out);
    throw UsageError("no command given (try servokit --help)");
  } catch (const std::exception& error) {
    err << "servokit: error: " << error.what() << "\n";
    return static_cast<int>(ExitCodeFor(error));
  } catch (...) {
    err << "servokit: error: unknown internal error\n";
    return static_cast<int>(ExitCode::kOther);
  }
}

}  // namespace servokit
