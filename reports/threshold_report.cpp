#include "reports/threshold_report.h"

#include <nlohmann/json.hpp>
#include <sstream>

#include "base/number_format.h"
#include "modeling/units.h"

namespace servokit {
namespace {

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

nlohmann::ordered_json EventsToJson(const ThresholdSearch& search, bool degrees) {
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
  return events;
}

}  // namespace

std::string ThresholdReportJson(const ThresholdSearch& search,
                                const ThresholdReportContext& context) {
  const ThresholdOptions& options = *context.options;
  nlohmann::ordered_json result = {{"parameter", search.parameter},
                                   {"event", ToString(search.event)},
                                   {"events", EventsToJson(search, context.degrees)},
                                   {"model", context.model->name()},
                                   {"range", {search.low, search.high}},
                                   {"scan_intervals", options.scan_intervals},
                                   {"relative_tolerance", options.relative_tolerance},
                                   {"classifications", search.classifications},
                                   {"unit", context.degrees ? "rad" : "SI"}};
  if (context.degrees) result["display_unit"] = "deg";
  if (context.closed_form) {
    result["closed_form"] = *context.closed_form ? ClosedFormToJson(**context.closed_form)
                                                 : nlohmann::ordered_json(nullptr);
  }
  return result.dump(2) + "\n";
}

std::string ThresholdReportText(const ThresholdSearch& search,
                                const ThresholdReportContext& context) {
  const std::string& parameter = search.parameter;
  const std::size_t events = search.events.size();
  std::ostringstream text;
  text << ToString(search.event) << " thresholds of " << parameter << " on ["
       << FormatPrecise(search.low) << ", " << FormatPrecise(search.high) << "] ("
       << (context.degrees ? "rad" : "SI") << "), model " << context.model->name() << ": " << events
       << (events == 1 ? " event" : " events") << "\n";
  for (const ThresholdCrossing& crossing : search.events) {
    const double half_width = crossing.bracket_width / 2.0;
    text << "  " << parameter << " = " << FormatPrecise(WithoutNegativeZero(crossing.value))
         << " +- " << FormatShort(half_width);
    if (context.degrees) {
      text << " (" << FormatPrecise(WithoutNegativeZero(RadiansToDegrees(crossing.value)))
           << " deg +- " << FormatShort(RadiansToDegrees(half_width)) << " deg)";
    }
    text << ": " << crossing.from << " -> " << crossing.to;
    if (!crossing.via.empty()) text << " (via " << crossing.via << ")";
    text << "\n";
  }
  if (context.closed_form && *context.closed_form) {
    text << "characteristic polynomial: " << (*context.closed_form)->polynomial << "\n";
  }
  return text.str();
}

}  // namespace servokit
