#pragma once
// The rows of a sweep's tables as columns of values, what the files other tools read are built
// from (reports/sweep_tables.h has the tables; reports/sweep_records.h the records they are read
// back from). Plain data and no analysis, so that the data-files plugin, which writes them,
// links none of it.
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace servokit {

/// What a column holds: numbers (CSV: FormatExact, empty for none; HDF5 and MAT: double, NaN for
/// none) or text.
enum class ColumnKind { kNumber, kText };

/// One column of a table: its name, what it holds and its unit ("deg", "1/s", "Hz", "1" for a
/// dimensionless ratio, "" for a count, a class, or a parameter in SI).
struct TableColumn {
  std::string name;
  ColumnKind kind = ColumnKind::kNumber;
  std::string unit;
};

/// The names of `columns`, in order (unique: CheckSweepColumns, reports/sweep_tables.h).
inline std::vector<std::string> ColumnNames(const std::vector<TableColumn>& columns) {
  std::vector<std::string> names;
  for (const TableColumn& column : columns) names.push_back(column.name);
  return names;
}

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

/// What sweep.h5 and sweep.mat record of the sweep besides its tables.
struct SweepFileMetadata {
  std::string model;             // the model's name
  std::string content_hash;      // of the model file
  std::string grid;              // the varied parameters and their values, in SI
  std::string servokit_version;  // of the servokit that wrote the file
};

}  // namespace servokit
