#pragma once
// Where `servokit sweep --out DIR` keeps its work (docs/sweep.md, "The files" and "Interruption
// and resume"): the tables of reports/sweep_tables.h, and
//
//   sweep.json          what was swept (model, grid, options, command line) and `completed`
//
// With --format hdf5 or mat the tables go into one file instead, sweep.h5 (reports/sweep_hdf5.h)
// or sweep.mat (reports/sweep_mat.h). While such a sweep runs, the partial files hold binary
// records (reports/sweep_records.h) under the same checkpoints; Finish builds the file from them
// once (temp file, fsync, rename) and removes them.
//
// Written so that a sweep stopped at any moment (Ctrl-C, SIGKILL, power loss) leaves no corrupt
// file and the same command resumes it: while it runs, the tables grow as `*.partial` files,
// and `.sweep-checkpoint` records, atomically (temp file, fsync, rename), how many points are
// done and how many bytes of each partial file hold them. On restart, bytes past those sizes are
// cut off and the sweep goes on from the recorded point, so the finished tables are the same,
// byte for byte, as those of an uninterrupted run. The checkpoint carries a fingerprint of
// everything that decides the results (servokit version, model file hash, parameters, grid,
// options); a directory holding another sweep is refused rather than mixed.
#include <Eigen/Dense>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/linear_analysis.h"
#include "analysis/options.h"
#include "analysis/parameter_grid.h"
#include "analysis/sweep.h"
#include "analysis/sweep_point.h"
#include "base/vocabulary.h"
#include "modeling/loaded_model.h"
#include "reports/sweep_hdf5.h"
#include "reports/sweep_records.h"
#include "reports/sweep_tables.h"

namespace servokit {

/// The names of the table files of `format`: "points.csv, eigenvalues.csv", "sweep.h5" or
/// "sweep.mat" (the file's name for HDF5 and MAT).
std::string SweepTableFileNames(SweepFileFormat format);
/// How the rows of `format` are formatted while sweeping: CSV text for kCsv, binary records
/// (built into the file at the end) otherwise.
TableEncoding TableEncodingOf(SweepFileFormat format);
/// Throws UsageError "<label> <format>: ..." when a column of `grid` cannot be written in `format`
/// (CheckHdf5ColumnNames, CheckMatColumnNames); `label` is the caller's name for the format.
void CheckSweepFileColumns(SweepFileFormat format,
                           const ParameterGrid& grid,
                           const std::string& label);

/// The default of SweepOutputOptions::checkpoint_interval: an fsync per block would cost more
/// than the points of a small model, and a crash loses at most a second of work (an interrupt,
/// SIGINT or SIGTERM, checkpoints at once).
inline constexpr std::chrono::duration<double> kSweepCheckpointInterval{1.0};

/// How SweepOutput writes; it does not change the bytes of the files.
struct SweepOutputOptions {
  // How often the partial files are made durable (fsync) and the checkpoint is updated.
  std::chrono::duration<double> checkpoint_interval = kSweepCheckpointInterval;
  // How messages name the directory and the format where the caller wrote them (the command
  // line: "--out", "--format"), so that an error says what to change.
  std::string directory_label = "directory";
  std::string format_label = "format";
};

/// What the files record of the swept model, whatever its kind: a multibody model (Model) or a
/// large linear one (LinearModel, with the options of its analysis, which decide its zeros).
struct SweepModelInfo {
  std::string name, source, content_hash;
  std::vector<std::string> parameter_names;
  Eigen::VectorXd parameters;  // nominal values after --set, in the order of parameter_names
  // Set for a linear model: the analysis of each point (eigenvalue count, shift, solver, ...).
  std::optional<LinearAnalysisOptions> linear;
  std::size_t dof = 0, outputs = 0;  // bound the relative degrees' text (sweep.h5)
  // A multibody model's points are classified by its closed-form zero-dynamics polynomial
  // first (SweepTriesPolynomial).
  bool tries_polynomial = false;
};
/// `options.linear` is recorded for a linear model only.
SweepModelInfo DescribeSweepModel(const LoadedModel& model, const SweepOptions& options);

/// One line naming everything that decides a sweep's files: servokit version, model file hash,
/// every parameter value, the grid, the classification options and the file format (named only
/// when not CSV, so that a CSV sweep's line is what it always was). Two sweeps with the same
/// fingerprint write the same bytes; the number of threads is not part of it.
/// A linear model's line also names its analysis options (DescribeLinearSweepOptions).
std::string SweepFingerprint(const SweepModelInfo& model,
                             const ParameterGrid& grid,
                             const ClassificationOptions& options,
                             SweepFileFormat format = SweepFileFormat::kCsv);

/// The varied parameters and their values in SI, as the fingerprint names them
/// ("alpha=0:1.5707963267948966:91 d=0:2:21"; a list as "d=[0,1,2]").
std::string DescribeGrid(const ParameterGrid& grid);

/// What a sweep's sweep.json records, read back (`servokit report --from DIR`): the schema
/// SweepOutput writes, read in one place.
struct SweepRecord {
  std::filesystem::path file;  // DIR/sweep.json
  std::string model_name, model_path, content_hash;
  bool linear = false;  // `kind: linear`
  SweepFileFormat format = SweepFileFormat::kCsv;
  bool completed = false;
  // The parameters not varied, as swept (SI), in the order of the model's parameter_names.
  std::vector<std::pair<std::string, double>> fixed_parameters;
  // The grid's axes; `parameter` is not known without the model: ResolveSweepAxes.
  std::vector<GridAxis> axes;
  // The classification options of a multibody sweep (tolerances, y0, q0).
  ClassificationOptions options;
};
/// Reads DIR/sweep.json. Throws UsageError naming the file when DIR has none ("<label> DIR: no
/// sweep.json there", `label` the caller's name for DIR) or it is not a servokit sweep record.
SweepRecord ReadSweepRecord(const std::filesystem::path& directory, const std::string& label);
/// `record.axes` with each `parameter` the index of its name in `parameter_names`.
std::vector<GridAxis> ResolveSweepAxes(const SweepRecord& record,
                                       const std::vector<std::string>& parameter_names);

/// The output directory of one sweep, from opening (new, resumed or already complete) to the
/// final rename. `model` and `grid` must outlive it. Holds an exclusive lock (flock) on the
/// directory, so that two servokit processes never write the same sweep.
class SweepOutput {
 public:
  /// Creates `directory` if needed and finds what it holds: nothing of this sweep (start
  /// afresh: writes sweep.json with completed false and the headers), an unfinished run of it
  /// (resume: cuts the partial files to the checkpoint's sizes), or all of it (already_complete).
  /// Throws UsageError when the directory holds another sweep or another process writes it,
  /// and Error for I/O failures and unreadable files.
  /// `model` describes a model of either kind (DescribeSweepModel). For a linear model, sweep.json
  /// has `kind: linear` and its `options` are the analysis options of the linear sweep
  /// (rank and axis tolerances, eigen_solver, which, shift, eigenvalues); `options` here only
  /// decides the tolerances of a multibody model.
  SweepOutput(const std::filesystem::path& directory,
              SweepModelInfo model,
              const ParameterGrid& grid,
              const ClassificationOptions& options,
              std::vector<std::string> command_line,
              const SweepOutputOptions& output_options = {},
              SweepFileFormat format = SweepFileFormat::kCsv);
  ~SweepOutput();
  SweepOutput(const SweepOutput&) = delete;
  SweepOutput& operator=(const SweepOutput&) = delete;

  /// The directory already holds this sweep, finished: there is nothing to compute.
  bool already_complete() const { return already_complete_; }
  /// Points written so far (also the first point still to compute).
  std::size_t points_done() const { return points_done_; }
  /// Points written so far whose row holds an error (no solution), counting resumed runs.
  std::size_t points_without_solution() const { return points_without_solution_; }

  /// Appends a formatted block (PipelinedBlockFormatter, or FormatBlock on another process of an
  /// MPI sweep); block.first must be points_done(). Checkpoints when the last checkpoint is
  /// older than the checkpoint interval.
  void Append(const FormattedBlock& block);
  /// Makes everything appended so far durable and records it in the checkpoint.
  void Checkpoint();
  /// After the last point: renames the partial files to points.csv and eigenvalues.csv (or builds
  /// sweep.h5 or sweep.mat from them and removes them), writes sweep.json with completed true
  /// and removes the checkpoint. Safe to repeat after a crash in the middle of it (the
  /// constructor resumes at the last point, and Finish completes it). Asks `stop_requested`
  /// (when given) before and while it builds a table file: once it says true, returns false
  /// with the sweep as resumable as at the last checkpoint; true when finished.
  bool Finish(const std::function<bool()>& stop_requested = {});

 private:
  struct Paths {
    // points and eigenvalues: the CSV tables; table_file: sweep.h5 or sweep.mat.
    std::filesystem::path points, points_partial, eigenvalues, eigenvalues_partial, record,
        checkpoint, table_file;
  };
  struct FileSizes {
    std::uintmax_t points = 0, eigenvalues = 0;
  };

  void Lock();
  void RemoveStaleTemporaries() const;
  void StartAfresh();
  void Resume(const FileSizes& sizes);
  void WriteRecord(bool completed) const;
  void WriteDurably(const std::filesystem::path& path, const std::string& contents) const;
  void SyncDirectory() const;
  void CloseTables();
  bool FinalFilesExist() const;
  void RenameCsvTables();
  bool WriteTableFile(const std::function<bool()>& stop_requested);
  SweepFileMetadata TableFileMetadata() const;  // what sweep.h5 and sweep.mat record besides rows
  void StartHdf5File();
  SweepHdf5Writer& Hdf5File();  // the writer, once created
  void AppendToHdf5File(const FormattedBlock& block);

  std::filesystem::path directory_;
  Paths paths_;
  SweepModelInfo model_;
  const ParameterGrid& grid_;
  ClassificationOptions options_;
  std::vector<std::string> command_line_;
  SweepFileFormat format_;
  std::string fingerprint_;
  std::chrono::duration<double> checkpoint_interval_;
  std::string directory_label_;

  int directory_fd_ = -1;  // held open for the lock and to fsync renames
  int points_fd_ = -1, eigenvalues_fd_ = -1;
  bool already_complete_ = false;
  std::size_t points_done_ = 0, points_without_solution_ = 0;
  FileSizes sizes_;
  std::chrono::steady_clock::time_point last_checkpoint_;
  // With --format hdf5: sweep.h5 (its temporary) written as the records are, from their rows.
  std::unique_ptr<SweepHdf5Writer> hdf5_;
  std::future<std::unique_ptr<SweepHdf5Writer>> hdf5_pending_;  // being created, beside the sweep
  std::unique_ptr<RecordDecoder> records_;
  TableChunk rows_;
};

}  // namespace servokit
