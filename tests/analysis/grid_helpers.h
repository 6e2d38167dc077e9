#pragma once
// Parameter grids for the analysis tests, built as a caller of the toolkit builds them: an axis
// per parameter name with its values (the `--vary` text is application grammar,
// studies/grid_text.h, tested in tests/studies/grid_text_test.cpp).
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "analysis/parameter_grid.h"

namespace servokit::testing {

/// `count` values from `first` to `last` (SI) of the parameter `name` of `parameter_names`.
inline GridAxis RangeAxis(const std::vector<std::string>& parameter_names,
                          const std::string& name,
                          double first,
                          double last,
                          std::size_t count) {
  return {name, ParameterIndex(parameter_names, name), ValueRange{first, last, count}};
}

/// The values `values` (SI) of the parameter `name` of `parameter_names`.
inline GridAxis ListAxis(const std::vector<std::string>& parameter_names,
                         const std::string& name,
                         std::vector<double> values) {
  return {name, ParameterIndex(parameter_names, name), std::move(values)};
}

}  // namespace servokit::testing
