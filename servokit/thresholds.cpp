// api::LocateThresholds: where the class of a multibody model changes along one parameter.
#include "analysis/thresholds.h"

#include "base/option_check.h"
#include "modeling/units.h"
#include "servokit/toolkit_bridge.h"

namespace servokit::api {

std::vector<Threshold> LocateThresholds(const Model& model, const ThresholdQuery& query) {
  const servokit::Model& multibody = MultibodyModel(model, "LocateThresholds");
  const std::optional<ThresholdEvent> event = ThresholdEventFromString(query.event);
  RequireOption(event.has_value(), "ThresholdQuery", "event", query.event,
                "expected stability, oscillation, realization or structure");
  const auto parameter = multibody.FindParameter(query.parameter);
  RequireOption(parameter.has_value(), "ThresholdQuery", "parameter", query.parameter,
                "the model " + multibody.name() + " has no such parameter");
  ThresholdOptions options;
  options.classification = ToClassificationOptions(query.analysis);
  const ThresholdSearch search =
      FindThresholds(multibody, *parameter, query.low, query.high, *event, options);
  const bool degrees = multibody.parameter_display_units()[*parameter] == DisplayUnit::kDegree;
  std::vector<Threshold> thresholds;
  for (const ThresholdCrossing& crossing : search.events) {
    thresholds.push_back(
        {crossing.value, crossing.from, crossing.to, crossing.via,
         degrees ? std::optional<double>(RadiansToDegrees(crossing.value)) : std::nullopt});
  }
  return thresholds;
}

}  // namespace servokit::api
