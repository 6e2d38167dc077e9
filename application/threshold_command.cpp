// servokit threshold MODEL --vary p=a:b --event stability|oscillation|realization|structure
//   [--set ...] [--y0 v]... [--q0 v]... [--format json|text]
#include <algorithm>
#include <memory>
#include <ostream>
#include <string>

#include "application/commands.h"
#include "application/exit_codes.h"
#include "servokit/servokit.h"

namespace servokit {
namespace {

struct ThresholdArguments {
  std::string model_path;
  std::vector<std::string> overrides;
  std::vector<std::string> y0;
  std::vector<std::string> q0;
  std::string vary;  // p=a:b
  std::string event;
  bool closed_form = true;
  std::string format = "json";  // what stdout gets: json or text
  int scan_intervals = api::DefaultThresholdSettings().scan_intervals;
  double relative_tolerance = api::DefaultThresholdSettings().relative_tolerance;
};

struct Range {
  std::string parameter;
  api::ValueWithUnit low, high;  // as written; read in the parameter's unit once it is known
};

// "p=a:b", each end a number that may end in "deg" or "rad".
Range ParseRange(const std::string& text) {
  const auto equals = text.find('=');
  const auto colon = text.find(':', equals == std::string::npos ? 0 : equals);
  if (equals == std::string::npos || equals == 0 || colon == std::string::npos ||
      text.find(':', colon + 1) != std::string::npos) {
    throw UsageError("--vary " + text + ": expected name=low:high (e.g. --vary s=0:1)");
  }
  const auto low = api::ParseQuantity(text.substr(equals + 1, colon - equals - 1));
  const auto high = api::ParseQuantity(text.substr(colon + 1));
  if (!low || !high) {
    throw UsageError("--vary " + text + ": low and high must be numbers (may end in deg or rad)");
  }
  return {text.substr(0, equals), *low, *high};
}

int RunThreshold(const ThresholdArguments& arguments, std::ostream& out, std::ostream& err) {
  if (arguments.format != "json" && arguments.format != "text") {
    throw UsageError("--format " + arguments.format + ": expected json or text");
  }
  const std::optional<ThresholdEvent> event = ThresholdEventFromString(arguments.event);
  if (!event) {
    throw UsageError("--event " + arguments.event +
                     ": expected stability, oscillation, realization or structure");
  }
  const Range range = ParseRange(arguments.vary);
  const api::Model model = api::Model::MultibodyFromFile(arguments.model_path,
                                                         ParseParameterValues(arguments.overrides));
  const std::vector<std::string>& names = model.parameter_names();
  const auto parameter = std::find(names.begin(), names.end(), range.parameter);
  if (parameter == names.end()) {
    throw UsageError("--vary " + arguments.vary + ": the model has no parameter '" +
                     range.parameter + "'");
  }
  // Bare ends in the unit the model declares the parameter in (degrees stay degrees).
  const api::ValueWithUnit low = api::InParameterUnit(model, range.parameter, range.low);
  const api::ValueWithUnit high = api::InParameterUnit(model, range.parameter, range.high);
  if (!(low.value < high.value)) {
    throw UsageError("--vary " + arguments.vary + ": needs low < high");
  }
  const bool in_degrees = low.degrees || high.degrees;
  const bool unit_written = in_degrees || low.unit_written || high.unit_written;
  // Values stay SI; a parameter given in degrees (model file, --set or --vary) also gets its
  // values in degrees.
  if (const std::string warning = api::AngleSpanWarning(
          model, range.parameter, unit_written, low.value, high.value, "--vary " + arguments.vary);
      !warning.empty()) {
    err << "servokit: warning: " << warning << "\n";
  }
  api::ThresholdQuery query;
  query.parameter = range.parameter;
  query.low = low.value;
  query.high = high.value;
  query.event = *event;
  if (!arguments.y0.empty()) query.analysis.y0 = ParseValues("--y0", arguments.y0);
  if (!arguments.q0.empty()) query.analysis.q_guess = ParseValues("--q0", arguments.q0);
  query.scan_intervals = arguments.scan_intervals;
  query.relative_tolerance = arguments.relative_tolerance;
  query.closed_form = arguments.closed_form;
  query.show_degrees = in_degrees;
  const api::ThresholdReport report = api::SearchThresholds(model, query);
  out << (arguments.format == "text" ? report.text : report.json);
  return static_cast<int>(ExitCode::kSuccess);
}

}  // namespace

Command AddThresholdCommand(CLI::App& app) {
  auto arguments = std::make_shared<ThresholdArguments>();
  CLI::App* threshold =
      app.add_subcommand("threshold",
                         "Locate where stability, oscillation or the realization changes along a "
                         "parameter");
  threshold->footer(
      "Example:\n  servokit threshold models/rotational_arm.yaml --vary s=0:1 --event "
      "stability");
  threshold->add_option("MODEL", arguments->model_path, "Model file (YAML)")->required();
  threshold->add_option("--vary", arguments->vary, "Parameter range: name=low:high (deg allowed)")
      ->required();
  threshold
      ->add_option("--event", arguments->event,
                   "stability, oscillation, realization or structure (relative degree, index)")
      ->required();
  threshold->add_option("--set", arguments->overrides,
                        "Override a parameter: name=value (value may end in deg)");
  threshold->add_option("--y0", arguments->y0,
                        "Output value at the operating point, one per output (default: h(0))");
  threshold->add_option("--q0", arguments->q0, "Newton's starting point for q (default: 0)");
  threshold
      ->add_option("--scan", arguments->scan_intervals,
                   "Scan intervals before bisection, 1 to " +
                       std::to_string(api::DefaultThresholdSettings().max_scan_intervals))
      ->capture_default_str();
  threshold
      ->add_option("--tolerance", arguments->relative_tolerance,
                   "Relative width each event is located to")
      ->capture_default_str();
  threshold->add_flag("!--no-closed-form", arguments->closed_form,
                      "Skip the symbolic characteristic polynomial and its Routh-Hurwitz "
                      "conditions");
  threshold
      ->add_option("--format", arguments->format,
                   "What stdout gets: json (the result object) or text (a few lines for people: "
                   "each event as value +- half its bracket, from -> to)")
      ->capture_default_str();
  return {threshold, [arguments](std::ostream& out, std::ostream& err) {
            return RunThreshold(*arguments, out, err);
          }};
}

}  // namespace servokit
