#pragma once
// The binary records of a sweep's tables (reports/sweep_tables.h), written while a sweep runs
// with `--format hdf5|mat` and read back once at its end to build sweep.h5 or sweep.mat. No
// number is formatted as text on the way (that is what makes these formats faster than CSV), and
// a record holds exactly the doubles the CSV would print, so both routes give the same values.
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
#include "reports/sweep_tables.h"

namespace servokit {

/// Bytes of one eigenvalue record.
inline constexpr std::size_t kEigenvalueRecordBytes = 32;

/// Appends the records of points first, first + 1, ... to `points_records` and
/// `eigenvalue_records` (the binary twin of AppendCsvRows).
void AppendRecordRows(std::size_t first,
                      std::span<const SweepPoint> points,
                      std::string& points_records,
                      std::string& eigenvalue_records);

/// Some consecutive rows of a table, by column (in the order of its TableColumn list): a number
/// column in `numbers[c]`, a text column in `texts[c]` (the other vector of that column is empty).
/// An empty CSV field is NaN in a number column and "" in a text column. A text points into the
/// reader's records or to a constant: valid as long as the reader lives.
struct TableChunk {
  std::size_t rows = 0;
  std::vector<std::vector<double>> numbers;
  std::vector<std::vector<std::string_view>> texts;
};

/// Reads the rows of one table back from its records file, a chunk at a time, from the start.
class TableRecordReader {
 public:
  virtual ~TableRecordReader() = default;
  /// The table's columns (PointsTableColumns or EigenvaluesTableColumns).
  virtual const std::vector<TableColumn>& columns() const = 0;
  /// Rows the file holds.
  virtual std::size_t rows() const = 0;
  /// Goes back to the first row.
  virtual void Rewind() = 0;
  /// The length of the longest value of each column (0 for a number column), found without
  /// decoding the rows; leaves the reader at the first row.
  virtual std::vector<std::size_t> TextWidths() = 0;
  /// Replaces `chunk` by the next rows, at most `max_rows`; returns how many (0 at the end).
  /// Throws Error when the file is cut short or holds a bad record.
  virtual std::size_t Read(std::size_t max_rows, TableChunk& chunk) = 0;
};

/// A reader of the points records at `path`, which hold grid.num_points() points.
std::unique_ptr<TableRecordReader> OpenPointRecords(const ParameterGrid& grid,
                                                    const std::filesystem::path& path);
/// A reader of the eigenvalue records at `path`.
std::unique_ptr<TableRecordReader> OpenEigenvalueRecords(const ParameterGrid& grid,
                                                         const std::filesystem::path& path);

/// What sweep.h5 and sweep.mat record of the sweep besides its tables.
struct SweepFileMetadata {
  std::string model;             // the model's name
  std::string content_hash;      // of the model file
  std::string grid;              // the varied parameters and their values, in SI
  std::string servokit_version;  // of the servokit that wrote the file
};

}  // namespace servokit
