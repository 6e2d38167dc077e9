#pragma once
// The binary records of a sweep's tables (reports/sweep_tables.h, columns in
// reports/sweep_columns.h), written while a sweep runs with `--format hdf5|mat` and read back once
// at its end to build sweep.h5 or sweep.mat. No number is formatted as text on the way (that is
// what makes these formats faster than CSV), and a record holds exactly the doubles the CSV would
// print, so both routes give the same values.
//
//   points records       one per grid point, in index order: a fixed 40-byte head
//                        (max_real_part, P_rank, differentiation_index, internal_dynamics_order,
//                        the byte lengths of the two texts, ok, realization, stability) followed
//                        by the relative_degree text and the error text
//   eigenvalue records   32 bytes each: the point's index, k, re, im
//
// A point's parameter values, an eigenvalue's frequency and damping ratio are computed again from
// the grid and the eigenvalue when read, as the CSV writer computes them. The records are in the
// machine's byte order: they live only in the output directory of one sweep, on one machine.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/parameter_grid.h"
#include "analysis/sweep_point.h"
#include "reports/sweep_columns.h"
#include "reports/table_rows.h"

namespace servokit {

/// Bytes of one eigenvalue record.
inline constexpr std::size_t kEigenvalueRecordBytes = 32;

/// Appends the records of points first, first + 1, ... to `points_records` and
/// `eigenvalue_records` (the binary twin of AppendCsvRows).
void AppendRecordRows(std::size_t first,
                      std::span<const SweepPoint> points,
                      std::string& points_records,
                      std::string& eigenvalue_records);

/// A reader of the points records at `path`, which hold grid.num_points() points.
std::unique_ptr<TableRecordReader> OpenPointRecords(const ParameterGrid& grid,
                                                    const std::filesystem::path& path);
/// A reader of the first `points` points records at `path` (a sweep's, up to its checkpoint).
std::unique_ptr<TableRecordReader> OpenPointRecords(const ParameterGrid& grid,
                                                    const std::filesystem::path& path,
                                                    std::size_t points);
/// A reader of the eigenvalue records at `path`.
std::unique_ptr<TableRecordReader> OpenEigenvalueRecords(const ParameterGrid& grid,
                                                         const std::filesystem::path& path);

/// Decodes records held in memory, as a sweep appends them block by block, into table rows, as
/// the readers above decode the files.
class RecordDecoder {
 public:
  explicit RecordDecoder(const ParameterGrid& grid);
  ~RecordDecoder();
  RecordDecoder(const RecordDecoder&) = delete;
  RecordDecoder& operator=(const RecordDecoder&) = delete;
  /// Replaces `rows` by the points table's rows of the point records `records`, the first of
  /// them point `first`; returns their number.
  std::size_t DecodePoints(std::string_view records, std::size_t first, TableChunk& rows) const;
  /// Replaces `rows` by the eigenvalue table's rows of `records`; returns their number.
  std::size_t DecodeEigenvalues(std::string_view records, TableChunk& rows) const;

 private:
  struct DisplayedGrid;  // each axis's values as the tables show them
  const ParameterGrid& grid_;
  std::vector<TableColumn> points_columns_, eigenvalues_columns_;
  std::unique_ptr<DisplayedGrid> values_;
};

}  // namespace servokit
