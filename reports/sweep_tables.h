#pragma once
// The tables of a sweep (docs/sweep.md, "The files"): their columns and
// rows, formatted the same by `servokit sweep` (whose durable store, studies/sweep_store.h,
// writes them) and by the library's api::SweepToFiles.
//
//   points.csv          one row per grid point: the varied parameters (SI, or degrees in a
//                       column "<name>_deg" for one given in degrees), the class columns
//                       and `error` (empty, or why the point has no solution)
//   eigenvalues.csv     one row per zero-dynamics eigenvalue of each point
//
// The same two tables go into sweep.h5 and sweep.mat (reports/sweep_hdf5.h, reports/sweep_mat.h),
// built at the end of a sweep from binary records (reports/sweep_records.h) that FormatBlock
// writes instead of CSV text. The columns, which every format shares, are in
// reports/sweep_columns.h.
#include <array>
#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/parameter_grid.h"
#include "analysis/sweep.h"
#include "analysis/sweep_point.h"
#include "reports/sweep_columns.h"
#include "reports/table_rows.h"

namespace servokit {

class RecordDecoder;  // reports/sweep_records.h

/// Appends the rows of points first, first + 1, ... to `points_csv` and `eigenvalues_csv`.
/// Numbers are FormatExact (they read back to the same double). A point without a solution has
/// empty class columns, its message CSV-quoted in `error`, and no eigenvalue rows;
/// relative_degree of several outputs is joined with ';'; relative_degree,
/// differentiation_index and internal_dynamics_order are empty when the internal order is
/// negative (not determined: a linear model, LinearRelativeDegrees::determined false);
/// max_real_part is empty when there are no eigenvalues; eigenvalue_index numbers a point's
/// eigenvalues from 0 in SweepPoint order. The varied parameters are written in the unit they are
/// shown in (GridAxis::DisplayValue: degrees for a parameter given in degrees).
void AppendCsvRows(const ParameterGrid& grid,
                   std::size_t first,
                   std::span<const SweepPoint> points,
                   std::string& points_csv,
                   std::string& eigenvalues_csv);

/// How FormatBlock writes rows: CSV text (AppendCsvRows), or binary records (AppendRecordRows,
/// reports/sweep_records.h) from which the HDF5 and MAT files are built; kRecordsAndRows also
/// decodes the records into TableChunks (PipelinedBlockFormatter only), for a file written while
/// the sweep runs (sweep.h5), so that the thread writing it only copies them.
enum class TableEncoding { kCsv, kRecords, kRecordsAndRows };

/// One block of consecutive points, formatted as AppendCsvRows (or AppendRecordRows) writes
/// them: what SweepOutput appends. The rows are held in slices (one per formatting thread), to be
/// written in order.
struct FormattedBlock {
  std::size_t first = 0;                                 // index of the block's first point
  std::size_t points = 0;                                // number of points in the block
  std::size_t points_without_solution = 0;               // of them, points whose row holds an error
  std::vector<std::string> points_csv, eigenvalues_csv;  // slices of rows, in order
  // With kRecordsAndRows (PipelinedBlockFormatter): each slice's rows, decoded; else empty.
  std::vector<TableChunk> points_rows, eigenvalue_rows;
};

/// Formats points first, first + 1, ... into `block` (AppendCsvRows, or AppendRecordRows for
/// kRecords), on `threads` threads that each format one contiguous slice; the bytes, slices
/// joined, do not depend on `threads`. Reuses the strings `block` holds.
void FormatBlock(const ParameterGrid& grid,
                 std::size_t first,
                 std::span<const SweepPoint> points,
                 int threads,
                 TableEncoding encoding,
                 FormattedBlock& block);

/// The rows of the blocks a pipelined sweep has in flight (RunSweepPipeline): one FormattedBlock
/// per slot, one slice per chunk. FormatChunk runs on the computing threads, each writing only
/// its chunk's slice; Block, on the consuming thread, completes the slot's block. The bytes,
/// slices joined, are those FormatBlock writes, whatever the chunk size or number of threads.
class PipelinedBlockFormatter {
 public:
  /// Blocks of at most `block_size` points in chunks of `chunk_size` (SweepChunkSize).
  PipelinedBlockFormatter(const ParameterGrid& grid,
                          TableEncoding encoding,
                          std::size_t block_size,
                          std::size_t chunk_size);
  /// Formats the rows of points first, first + 1, ... (chunk `chunk` of the block in `slot`).
  void FormatChunk(int slot,
                   std::size_t chunk,
                   std::size_t first,
                   std::span<const SweepPoint> points);
  /// The block in `slot`, its points first, first + 1, ..., all of its chunks formatted.
  const FormattedBlock& Block(int slot, std::size_t first, std::span<const SweepPoint> points);
  ~PipelinedBlockFormatter();

 private:
  const ParameterGrid& grid_;
  TableEncoding encoding_;
  std::size_t chunk_size_;
  std::array<FormattedBlock, kSweepSlots> blocks_;
  std::unique_ptr<RecordDecoder> decoder_;  // with kRecordsAndRows
};

}  // namespace servokit
