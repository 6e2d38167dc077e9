#include "reports/sweep_hdf5.h"

#include <string>

#include "models/errors.h"
#include "reports/data_files_plugin.h"
#include "reports/plugins.h"
#include "reports/sweep_tables.h"

namespace servokit {

const DataFilesPlugin& DataFiles() {
  static const DataFilesPlugin* const plugin = reinterpret_cast<const DataFilesPlugin* (*)()>(
      PluginSymbol("servokit_data_files", kDataFilesPluginEntry))();
  return *plugin;
}

void WriteSweepHdf5(const std::filesystem::path& path,
                    const SweepFileMetadata& metadata,
                    TableRecordReader& points,
                    TableRecordReader& eigenvalues) {
  DataFiles().write_sweep_hdf5(path, metadata, points, eigenvalues);
}

void CheckHdf5ColumnNames(const ParameterGrid& grid) {
  for (const std::string& name : PointsColumns(grid)) {
    if (name.empty() || name == "." || name.find('/') != std::string::npos) {
      throw UsageError("the column '" + name + "' cannot name an HDF5 dataset (CSV can hold it)");
    }
  }
}

}  // namespace servokit
