#include "analysis/options.h"

#include "base/option_check.h"

namespace servokit {

void ClassificationOptions::Validate(const Model& model) const {
  operating_point.Validate(model);
  for (const auto& [value, field] :
       {std::pair{rank_tolerance, "rank_tolerance"},
        std::pair{imaginary_axis_tolerance, "imaginary_axis_tolerance"},
        std::pair{cross_check_tolerance, "cross_check_tolerance"}}) {
    RequireOption(value > 0.0 && value < 1.0, "ClassificationOptions", field, value,
                  "must be > 0 and < 1");
  }
}

}  // namespace servokit
