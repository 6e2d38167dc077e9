#include "reports/sweep_hdf5.h"

#include <string>

#include "base/errors.h"
#include "reports/sweep_tables.h"

namespace servokit {

std::size_t RelativeDegreeTextWidth(std::size_t dof, std::size_t outputs) {
  const std::size_t digits = std::to_string(2 * dof).size();
  return outputs == 0 ? 0 : outputs * digits + (outputs - 1);
}

void CheckHdf5ColumnNames(const ParameterGrid& grid) {
  for (const std::string& name : PointsColumns(grid)) {
    if (name.empty() || name == "." || name.find('/') != std::string::npos) {
      throw UsageError("the column '" + name + "' cannot name an HDF5 dataset (CSV can hold it)");
    }
  }
}

}  // namespace servokit
