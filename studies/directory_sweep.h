#pragma once
// A sweep into a directory, as `servokit sweep --out DIR` runs it (docs/sweep.md): the points of
// a grid classified (analysis/sweep.h), written as they are computed into the durable store of
// studies/sweep_store.h (checkpoints, resumption, sweep.json, the table files), on one process
// with its threads or shared out over the ranks of an MPI job (studies/distributed_sweep.h).
//
// Three steps, each collective under MPI (every process calls it; a failure on any ends all):
// the constructor checks everything that can be checked without touching the directory, Open
// finds what the directory holds (nothing, an unfinished run of this sweep, all of it), and Run
// computes the points still missing and finishes the files.
#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "analysis/parameter_grid.h"
#include "analysis/sweep.h"
#include "base/vocabulary.h"
#include "modeling/loaded_model.h"
#include "studies/sweep_store.h"

namespace servokit {

/// How a directory sweep ended.
enum class DirectorySweepEnd {
  kFinished,        // every point written, the tables finished
  kStopped,         // stopped on request at a block boundary; the checkpoint holds the points done
  kStoppedInTables  // every point done, stopped while building the table file; resumable
};

class DirectorySweep {
 public:
  /// Checks the sweep of `model` over `grid` with `options` into files of `format`: the table
  /// columns of the format, the thread count (threads 0 on a process of an MPI job: the cores of
  /// its machine shared among its ranks there), the classification options, and, under MPI, that
  /// every process computes the same sweep. Throws UsageError naming the problem. Touches no file.
  /// `command_line` is recorded in sweep.json. `model` must outlive the sweep (a large linear
  /// model is not copied).
  DirectorySweep(const LoadedModel& model,
                 ParameterGrid grid,
                 SweepOptions options,
                 SweepFileFormat format,
                 SweepOutputOptions output_options,
                 std::vector<std::string> command_line);
  ~DirectorySweep();
  DirectorySweep(const DirectorySweep&) = delete;
  DirectorySweep& operator=(const DirectorySweep&) = delete;

  /// Opens `directory` (rank 0 alone writes it; SweepOutput) and learns where the sweep stands.
  void Open(const std::filesystem::path& directory);

  const LoadedModel& model() const { return model_; }
  std::size_t num_points() const { return grid_.num_points(); }
  /// After Open: the directory already holds this sweep, finished (Run has nothing to do).
  bool already_complete() const { return already_complete_; }
  /// After Open: the first point still to compute (0, or where a resumed sweep goes on).
  std::size_t first_point() const { return first_point_; }

  /// Computes the points from first_point() on and finishes the files. `stop_requested` is
  /// asked after each block and while the table file is built (on every process; true on any
  /// stops all of them, with the checkpoint written); `progress` hears the points done after
  /// each block written (rank 0).
  DirectorySweepEnd Run(const std::function<bool()>& stop_requested,
                        const std::function<void(std::size_t done)>& progress);

  /// After Run: the points written (num_points(), or fewer when stopped).
  std::size_t points_done() const { return points_done_; }
  /// After Run, on rank 0: the points whose row holds an error (no solution), resumed runs too.
  std::size_t points_without_solution() const;
  /// The names of the table files: "points.csv, eigenvalues.csv", "sweep.h5" or "sweep.mat".
  std::string table_file_names() const { return SweepTableFileNames(format_); }

 private:
  std::size_t Compute(const std::function<bool()>& stop_requested,
                      const std::function<void(std::size_t)>& progress);

  const LoadedModel& model_;
  ParameterGrid grid_;
  SweepOptions options_;
  SweepFileFormat format_;
  SweepOutputOptions output_options_;
  std::vector<std::string> command_line_;
  SweepModelInfo info_;
  std::optional<SweepOutput> output_;  // rank 0, after Open
  bool already_complete_ = false;
  std::size_t first_point_ = 0, points_done_ = 0;
};

}  // namespace servokit
