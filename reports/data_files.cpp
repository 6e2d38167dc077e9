// The front of the data-files plugin (reports/data_files_plugin.h): loads it on first use and
// hands it what it needs as plain data, so that it links none of the analysis.
#include "base/vocabulary.h"
#include "reports/data_files_plugin.h"
#include "reports/plugins.h"
#include "reports/sweep_tables.h"

namespace servokit {

const DataFilesPlugin& DataFiles() {
  static const DataFilesPlugin* const plugin = reinterpret_cast<const DataFilesPlugin* (*)()>(
      PluginSymbol("servokit_data_files", kDataFilesPluginEntry))();
  return *plugin;
}

std::unique_ptr<SweepHdf5Writer> CreateSweepHdf5(const std::filesystem::path& path,
                                                 const SweepFileMetadata& metadata,
                                                 const ParameterGrid& grid,
                                                 std::size_t relative_degree_width,
                                                 std::size_t most_kept_error_bytes) {
  SweepHdf5Layout layout;
  layout.most_kept_error_bytes = most_kept_error_bytes;
  layout.points_columns = PointsTableColumns(grid);
  layout.eigenvalues_columns = EigenvaluesTableColumns(grid);
  layout.points = grid.num_points();
  for (const TableColumn& column : layout.points_columns) {
    std::size_t width = 0;
    if (column.name == "realization") width = LongestRealizationName();
    if (column.name == "relative_degree") width = relative_degree_width;
    if (column.name == "stability") width = LongestStabilityName();
    layout.points_text_widths.push_back(width);
  }
  return DataFiles().create_sweep_hdf5(path, metadata, layout);
}

std::unique_ptr<MatFileWriter> CreateMatFile(const std::string& path) {
  return DataFiles().create_mat_file(path);
}

}  // namespace servokit
