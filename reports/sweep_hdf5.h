#pragma once
// sweep.h5, the HDF5 file of `servokit sweep --format hdf5` (docs/sweep.md, "Files other tools
// read"): the two tables of reports/sweep_tables.h, one group each, one 1-D dataset per column:
//
//   /points/<column>        grid.num_points() rows     number columns: 64-bit IEEE doubles,
//   /eigenvalues/<column>   one row per eigenvalue     NaN where the CSV field is empty;
//                                                      text columns: fixed-length ASCII strings,
//                                                      NUL-padded
//
// The text columns are as wide as their longest possible value (realization, stability: the
// longest word; relative_degree: one number up to 2 dof per output, RelativeDegreeTextWidth),
// error as its longest value. Attributes (variable-length UTF-8 strings): on the root group
// `model`, `model_content_hash`, `grid`, `servokit_version`; on each group `columns` (its column
// names in table order, also the order h5py lists them in); on each dataset `unit`
// (TableColumn::unit). The file is written while the sweep runs: the points datasets are
// contiguous, their size known from the start; the eigenvalue datasets, whose size only the end
// knows, chunked (2^16 rows, fewer for a smaller grid; no filters). The bytes depend only on the
// tables and the metadata: object times are not recorded and the library's format versions are
// fixed (1.8).
#include <cstddef>
#include <filesystem>
#include <memory>

#include "analysis/parameter_grid.h"
#include "reports/table_rows.h"

namespace servokit {

/// sweep.h5 written while the sweep runs (studies/sweep_store.h): rows go in as they are
/// computed, in table order, and the file's bytes depend only on the rows, not on how they were
/// split among the calls, so that a resumed sweep that appends its records' rows again writes
/// the same file.
class SweepHdf5Writer {
 public:
  virtual ~SweepHdf5Writer() = default;
  /// Appends rows of the points table (every column but the last, error: Finish writes it).
  virtual void AppendPoints(const TableChunk& rows) = 0;
  /// Appends rows of the eigenvalue table.
  virtual void AppendEigenvalues(const TableChunk& rows) = 0;
  /// Completes the file once every row was appended: the error column from `points` (the
  /// points records, read from their start) and the last rows; the file is closed with the
  /// writer.
  virtual void Finish(TableRecordReader& points) = 0;
};

/// The default of SweepHdf5Layout::most_kept_error_bytes: 64 MB.
inline constexpr std::size_t kMostKeptErrorBytes = std::size_t{64} << 20;

/// What the file holds besides its rows: the tables' columns (PointsTableColumns,
/// EigenvaluesTableColumns) and the points table's size and text widths.
struct SweepHdf5Layout {
  std::vector<TableColumn> points_columns, eigenvalues_columns;
  std::size_t points = 0;  // rows of the points table: the grid's points
  // For each points column: the width of its texts, known before the sweep (0 for a number
  // column and for error, whose width Finish finds).
  std::vector<std::size_t> points_text_widths;
  // The error texts of the points are kept in memory up to this many bytes (points without a
  // solution are usually few), so that Finish need not read every point's record again; beyond
  // it Finish reads them from the records.
  std::size_t most_kept_error_bytes = kMostKeptErrorBytes;
};

/// Creates `path` (replacing it) for the tables of a sweep over `grid`, whose relative_degree
/// texts are at most `relative_degree_width` long. Throws Error naming `path` when HDF5 fails.
std::unique_ptr<SweepHdf5Writer> CreateSweepHdf5(
    const std::filesystem::path& path,
    const SweepFileMetadata& metadata,
    const ParameterGrid& grid,
    std::size_t relative_degree_width,
    std::size_t most_kept_error_bytes = kMostKeptErrorBytes);

/// The longest relative_degree text of a model with `dof` coordinates and `outputs` outputs:
/// a number per output, each at most 2 dof (the order of the state), joined by ';'.
std::size_t RelativeDegreeTextWidth(std::size_t dof, std::size_t outputs);

/// Throws UsageError when a column name cannot be an HDF5 link name (empty, ".", or with '/').
void CheckHdf5ColumnNames(const ParameterGrid& grid);

}  // namespace servokit
