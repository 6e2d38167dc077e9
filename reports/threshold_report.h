#pragma once
// The report of a threshold search (`servokit threshold`, docs/threshold.md): the JSON object
// and the few lines of text, written from the search, its settings and the closed form.
#include <optional>
#include <string>

#include "analysis/characteristic_polynomial.h"
#include "analysis/thresholds.h"
#include "modeling/model.h"

namespace servokit {

/// What the report says besides the search itself.
struct ThresholdReportContext {
  const Model* model = nullptr;
  const ThresholdOptions* options = nullptr;
  // Values in degrees too: the parameter is shown in degrees, or its range was given so.
  bool degrees = false;
  // Asked for: the closed form (nullopt inside when it could not be derived). Not asked for:
  // the report has no closed form at all.
  std::optional<std::optional<CharacteristicPolynomial>> closed_form;
};

/// The JSON object, pretty-printed with a final line break.
std::string ThresholdReportJson(const ThresholdSearch& search,
                                const ThresholdReportContext& context);

/// The text: the parameter, event and range, each event as its value +- half its bracket (in
/// degrees too where the context says so), from -> to, and the characteristic polynomial.
std::string ThresholdReportText(const ThresholdSearch& search,
                                const ThresholdReportContext& context);

}  // namespace servokit
