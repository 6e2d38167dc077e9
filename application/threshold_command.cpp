// servokit threshold MODEL --vary p=a:b --event stability|oscillation|realization|structure
//   [--set ...] [--y0 v]... [--q0 v]... [--format json|text]
#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>
#include <sstream>
#include <string>

#include "analysis/characteristic_polynomial.h"
#include "analysis/thresholds.h"
#include "application/commands.h"
#include "application/exit_codes.h"
#include "application/grid_arguments.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "modeling/units.h"

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
  ThresholdOptions options;
};

struct Range {
  std::string parameter;
  double low = 0.0, high = 0.0;
  bool in_degrees = false;  // low or high was written with deg
};

// "p=a:b", each end a number that may end in "deg".
Range ParseRange(const std::string& text) {
  const auto equals = text.find('=');
  const auto colon = text.find(':', equals == std::string::npos ? 0 : equals);
  if (equals == std::string::npos || equals == 0 || colon == std::string::npos ||
      text.find(':', colon + 1) != std::string::npos) {
    throw UsageError("--vary " + text + ": expected name=low:high (e.g. --vary s=0:1)");
  }
  const auto low = ParseQuantityWithUnit(text.substr(equals + 1, colon - equals - 1));
  const auto high = ParseQuantityWithUnit(text.substr(colon + 1));
  if (!low || !high) {
    throw UsageError("--vary " + text + ": low and high must be numbers (may end in deg)");
  }
  if (!(low->value < high->value)) throw UsageError("--vary " + text + ": needs low < high");
  return {text.substr(0, equals), low->value, high->value,
          low->unit == DisplayUnit::kDegree || high->unit == DisplayUnit::kDegree};
}

nlohmann::ordered_json ClosedFormToJson(const CharacteristicPolynomial& closed_form) {
  nlohmann::ordered_json conditions = nlohmann::ordered_json::array();
  for (const HurwitzCondition& condition : closed_form.hurwitz) {
    conditions.push_back({{"name", condition.name},
                          {"expression", condition.expression + " > 0"},
                          {"solved", condition.solved},
                          {"sign_changes", condition.sign_changes}});
  }
  return {{"characteristic_polynomial", closed_form.polynomial},
          {"variable", closed_form.variable},
          {"degree", closed_form.degree},
          {"coefficients", closed_form.coefficients},
          {"routh_hurwitz", conditions},
          {"discriminant", closed_form.discriminant},
          {"discriminant_sign_changes", closed_form.discriminant_sign_changes}};
}

// --format text: the JSON object's parameter, event and located events in a few lines, every
// number taken from it; each event is its value +- half its bracket, in degrees too for a
// parameter shown in degrees.
std::string ThresholdText(const nlohmann::ordered_json& result) {
  const std::string parameter = result["parameter"].get<std::string>();
  const bool degrees = result.contains("display_unit");
  const auto& range = result["range"];
  const auto& events = result["events"];
  std::ostringstream text;
  text << result["event"].get<std::string>() << " thresholds of " << parameter << " on ["
       << FormatPrecise(range[0].get<double>()) << ", " << FormatPrecise(range[1].get<double>())
       << "] (" << result["unit"].get<std::string>() << "), model "
       << result["model"].get<std::string>() << ": " << events.size()
       << (events.size() == 1 ? " event" : " events") << "\n";
  for (const auto& event : events) {
    const double half_width = event["bracket_width"].get<double>() / 2.0;
    text << "  " << parameter << " = " << FormatPrecise(event["value"].get<double>()) << " +- "
         << FormatShort(half_width);
    if (degrees) {
      text << " (" << FormatPrecise(event["value_deg"].get<double>()) << " deg +- "
           << FormatShort(RadiansToDegrees(half_width)) << " deg)";
    }
    text << ": " << event["from"].get<std::string>() << " -> " << event["to"].get<std::string>();
    if (event.contains("via")) text << " (via " << event["via"].get<std::string>() << ")";
    text << "\n";
  }
  if (const auto closed_form = result.find("closed_form");
      closed_form != result.end() && !closed_form->is_null()) {
    text << "characteristic polynomial: "
         << (*closed_form)["characteristic_polynomial"].get<std::string>() << "\n";
  }
  return text.str();
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
  const Model model = LoadModel(arguments.model_path, ParseOverrides(arguments.overrides));
  const auto parameter = model.FindParameter(range.parameter);
  if (!parameter) {
    throw UsageError("--vary " + arguments.vary + ": the model has no parameter '" +
                     range.parameter + "'");
  }
  // Values stay SI; a parameter given in degrees (model file, --set or --vary) also gets its
  // values in degrees.
  const DisplayUnit declared = model.parameter_display_units()[*parameter];
  const bool degrees = range.in_degrees || declared == DisplayUnit::kDegree;
  if (const std::string warning =
          AngleSpanWarning("--vary " + arguments.vary, range.parameter, declared, range.in_degrees,
                           range.low, range.high);
      !warning.empty()) {
    err << "servokit: warning: " << warning << "\n";
  }
  ThresholdOptions options = arguments.options;
  if (!arguments.y0.empty()) {
    options.classification.operating_point.y0 = ParseValues("--y0", arguments.y0);
  }
  if (!arguments.q0.empty()) {
    options.classification.operating_point.q_guess = ParseValues("--q0", arguments.q0);
  }
  const ThresholdSearch search =
      FindThresholds(model, *parameter, range.low, range.high, *event, options);

  nlohmann::ordered_json events = nlohmann::ordered_json::array();
  for (const ThresholdCrossing& crossing : search.events) {
    nlohmann::ordered_json entry = {{"value", WithoutNegativeZero(crossing.value)},
                                    {"from", crossing.from},
                                    {"to", crossing.to}};
    if (!crossing.via.empty()) entry["via"] = crossing.via;
    entry["bracket_width"] = crossing.bracket_width;
    if (degrees) entry["value_deg"] = WithoutNegativeZero(RadiansToDegrees(crossing.value));
    events.push_back(entry);
  }
  nlohmann::ordered_json result = {{"parameter", search.parameter},
                                   {"event", ToString(search.event)},
                                   {"events", events},
                                   {"model", model.name()},
                                   {"range", {search.low, search.high}},
                                   {"scan_intervals", options.scan_intervals},
                                   {"relative_tolerance", options.relative_tolerance},
                                   {"classifications", search.classifications},
                                   {"unit", degrees ? "rad" : "SI"}};
  if (degrees) result["display_unit"] = "deg";
  // The closed form is taken at q = 0, u = 0: not where --y0 or --q0 moves the operating point.
  if (arguments.closed_form && !options.classification.operating_point.y0 &&
      !options.classification.operating_point.q_guess) {
    const auto closed_form =
        DeriveCharacteristicPolynomial(model, *parameter, range.low, range.high);
    result["closed_form"] =
        closed_form ? ClosedFormToJson(*closed_form) : nlohmann::ordered_json(nullptr);
  }
  if (arguments.format == "text") {
    out << ThresholdText(result);
  } else {
    out << result.dump(2) << "\n";
  }
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
      ->add_option("--scan", arguments->options.scan_intervals,
                   "Scan intervals before bisection, 1 to " + std::to_string(kMaxScanIntervals))
      ->capture_default_str();
  threshold
      ->add_option("--tolerance", arguments->options.relative_tolerance,
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
