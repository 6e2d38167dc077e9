#include "analysis/options.h"

#include <string>

#include "models/errors.h"

namespace servokit {
namespace {

void RequireOpenUnitInterval(const char* field, double value) {
  if (!(value > 0.0 && value < 1.0)) {
    throw UsageError(std::string("ClassificationOptions::") + field + " = " +
                     std::to_string(value) + ": must be > 0 and < 1");
  }
}

}  // namespace

void ClassificationOptions::Validate(const Model& model) const {
  operating_point.Validate(model);
  RequireOpenUnitInterval("rank_tolerance", rank_tolerance);
  RequireOpenUnitInterval("imaginary_axis_tolerance", imaginary_axis_tolerance);
  RequireOpenUnitInterval("cross_check_tolerance", cross_check_tolerance);
}

}  // namespace servokit
