#pragma once
// sweep.mat, the MAT-file of `servokit sweep --format mat` (docs/sweep.md, "Files other
// tools read"): MAT version 5 (MATLAB's `load`, SciPy's scipy.io.loadmat), written with matio
// through reports/mat_file.h (the one MAT writer, shared with a solve's MAT file). Two 1x1 struct
// variables, `points` and `eigenvalues`, whose fields are the columns of reports/sweep_tables.h in
// table order: a number column as an N x 1 double vector (NaN where the CSV field is empty), a
// text column as an N x 1 cell array of char row vectors. A third variable, `sweep`, is a struct
// of char fields: model, model_content_hash, grid, servokit_version, and the structs
// points_units, eigenvalues_units (the unit of each column, in a field named by the column). The
// header text is fixed (matio's default holds the creation date), so the bytes depend only on
// the contents.
// MAT 5 holds at most 2 GiB per variable: the whole file is built in memory.
#include <filesystem>
#include <functional>

#include "reports/sweep_records.h"

namespace servokit {

/// Writes `path` (replacing it) from the two readers, read from their start. Throws Error
/// naming `path` when matio fails (a variable too large for MAT 5, a full disk). Asks
/// `stop_requested` (when given) between chunks of rows: once it says true, returns false and
/// leaves `path` as it was; true when the file was written.
bool WriteSweepMat(const std::filesystem::path& path,
                   const SweepFileMetadata& metadata,
                   TableRecordReader& points,
                   TableRecordReader& eigenvalues,
                   const std::function<bool()>& stop_requested = {});

/// Throws UsageError when a column name is not a MATLAB name (MatlabNameProblem): it could not
/// be a field of the structs.
void CheckMatColumnNames(const ParameterGrid& grid);

}  // namespace servokit
