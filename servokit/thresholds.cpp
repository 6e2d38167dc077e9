// api::SearchThresholds and api::LocateThresholds: where a class changes along a parameter, and
// the report `servokit threshold` prints.
#include "analysis/thresholds.h"

#include "analysis/characteristic_polynomial.h"
#include "base/option_check.h"
#include "modeling/units.h"
#include "reports/threshold_report.h"
#include "servokit/toolkit_bridge.h"

namespace servokit::api {
namespace {

// `operation` names the call in the message for a linear model.
ThresholdReport Search(const Model& model, const ThresholdQuery& query, const char* operation) {
  const servokit::Model& multibody = MultibodyModel(model, operation);
  const auto parameter = multibody.FindParameter(query.parameter);
  RequireOption(parameter.has_value(), "ThresholdQuery", "parameter", query.parameter,
                "the model " + multibody.name() + " has no such parameter");
  ThresholdOptions options;
  options.classification = ToClassificationOptions(query.analysis);
  if (query.scan_intervals) options.scan_intervals = *query.scan_intervals;
  if (query.relative_tolerance) options.relative_tolerance = *query.relative_tolerance;
  const ThresholdSearch search =
      FindThresholds(multibody, *parameter, query.low, query.high, query.event, options);

  ThresholdReportContext context;
  context.model = &multibody;
  context.options = &options;
  context.degrees =
      query.show_degrees || multibody.parameter_display_units()[*parameter] == DisplayUnit::kDegree;
  // The closed form is taken at q = 0, u = 0: not where y0 or q_guess moves the operating point.
  if (query.closed_form && !query.analysis.y0 && !query.analysis.q_guess) {
    context.closed_form =
        DeriveCharacteristicPolynomial(multibody, *parameter, query.low, query.high);
  }
  ThresholdReport report;
  for (const ThresholdCrossing& crossing : search.events) {
    report.thresholds.push_back(
        {crossing.value, crossing.from, crossing.to, crossing.via,
         context.degrees ? std::optional<double>(RadiansToDegrees(crossing.value)) : std::nullopt,
         crossing.bracket_width});
  }
  report.classifications = search.classifications;
  report.json = ThresholdReportJson(search, context);
  report.text = ThresholdReportText(search, context);
  return report;
}

}  // namespace

ThresholdSettings DefaultThresholdSettings() {
  const ThresholdOptions defaults;
  return {defaults.scan_intervals, defaults.relative_tolerance, kMaxScanIntervals};
}

ThresholdReport SearchThresholds(const Model& model, const ThresholdQuery& query) {
  return Search(model, query, "SearchThresholds");
}

std::vector<Threshold> LocateThresholds(const Model& model, const ThresholdQuery& query) {
  return Search(model, query, "LocateThresholds").thresholds;
}

}  // namespace servokit::api
