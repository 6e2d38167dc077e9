#pragma once
// The columns of a sweep's two tables (docs/sweep.md, "The files"), points and eigenvalues, and
// the texts of their cells that every format writes alike: the CSV text (reports/sweep_tables.h)
// and the binary records behind sweep.h5 and sweep.mat (reports/sweep_records.h) both build on
// these, so neither includes the other for them.
#include <string>
#include <string_view>
#include <vector>

#include "analysis/parameter_grid.h"
#include "reports/table_rows.h"

namespace servokit {

/// The name of eigenvalues.csv's column that numbers a point's eigenvalues from 0 (not "k", which
/// a stiffness parameter is often called).
inline constexpr std::string_view kEigenvalueIndexColumn = "eigenvalue_index";

/// The columns of the points table with their kinds and units (names as PointsColumns).
std::vector<TableColumn> PointsTableColumns(const ParameterGrid& grid);
/// The columns of the eigenvalues table with their kinds and units (names as EigenvaluesColumns).
std::vector<TableColumn> EigenvaluesTableColumns(const ParameterGrid& grid);

/// Throws UsageError "parameter 'name': its column 'column' ..." when a varied parameter's column
/// (GridAxis::ColumnName) is also a fixed column of points.csv or eigenvalues.csv, or another
/// varied parameter's column: a table cannot have two columns of one name, in any format (CSV
/// header, HDF5 datasets, MAT struct fields). The column lists below call it; commands call it
/// first, to refuse before writing anything.
void CheckSweepColumns(const ParameterGrid& grid);

/// The columns of the points table, in order: the varied parameters (GridAxis::ColumnName), then
/// realization, P_rank, relative_degree, differentiation_index, internal_dynamics_order,
/// stability, max_real_part, error. Every format of the table (CSV, HDF5, MAT) uses these names.
std::vector<std::string> PointsColumns(const ParameterGrid& grid);
/// The columns of the eigenvalues table: the varied parameters, then kEigenvalueIndexColumn, re,
/// im, frequency_hz, damping_ratio.
std::vector<std::string> EigenvaluesColumns(const ParameterGrid& grid);

/// The header line of points.csv (with its newline): the varied parameters, then
/// realization,P_rank,relative_degree,differentiation_index,internal_dynamics_order,stability,
/// max_real_part,error.
std::string PointsCsvHeader(const ParameterGrid& grid);

/// The header line of eigenvalues.csv: the varied parameters, then
/// eigenvalue_index,re,im,frequency_hz,damping_ratio.
std::string EigenvaluesCsvHeader(const ParameterGrid& grid);

/// The text of relative_degree: one number per output, joined with ';' ("2", "1;2").
std::string JoinRelativeDegrees(const std::vector<int>& relative_degree);
/// The same text appended to `text` (no allocation of its own: sweeps write it for every row).
void AppendRelativeDegrees(std::string& text, const std::vector<int>& relative_degree);

/// `text` as one CSV field (RFC 4180): in double quotes, with inner quotes doubled.
std::string CsvQuote(const std::string& text);

}  // namespace servokit
