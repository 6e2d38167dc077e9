#pragma once
// sweep.h5, the HDF5 file of `servokit sweep --format hdf5` (README "servokit sweep"): the two
// tables of reports/sweep_tables.h, one group each, one 1-D dataset per column:
//
//   /points/<column>        grid.num_points() rows     number columns: 64-bit IEEE doubles,
//   /eigenvalues/<column>   one row per eigenvalue     NaN where the CSV field is empty;
//                                                      text columns: fixed-length ASCII strings,
//                                                      NUL-padded, as wide as the longest value
//
// Attributes (variable-length UTF-8 strings): on the root group `model`, `model_content_hash`,
// `grid`, `servokit_version`; on each group `columns` (its column names in table order); on
// each dataset `unit` (TableColumn::unit). The bytes depend only on the tables and the
// metadata: object times are not recorded, the library's format versions are fixed (1.8), and
// the datasets are contiguous (no chunking, no filters).
#include <filesystem>

#include "reports/sweep_records.h"

namespace servokit {

/// Writes `path` (replacing it) from the two readers, which are read from their start. Throws
/// Error naming `path` when HDF5 fails.
void WriteSweepHdf5(const std::filesystem::path& path,
                    const SweepFileMetadata& metadata,
                    TableRecordReader& points,
                    TableRecordReader& eigenvalues);

/// Throws UsageError when a column name cannot be an HDF5 link name (empty, ".", or with '/').
void CheckHdf5ColumnNames(const ParameterGrid& grid);

}  // namespace servokit
